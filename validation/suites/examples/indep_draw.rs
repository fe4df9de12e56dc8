//! One out-of-sample draw (zmp-indep-sim) through the user's loop, with every diagnosis in
//! words: a development aid (`cargo run --release -p zmp-suites --example indep_draw --
//! SEED SCENARIO`, e.g. `1 single:time_delay`).

use zmp_campaign::read_campaign;
use zmp_diagnose::iterate::run_loop;
use zmp_diagnose::measure::{chi2_parts, chi2_total, components, predict};
use zmp_diagnose::observe::Observation;
use zmp_diagnose::DiagnoseOptions;
use zmp_identify::IdentifyOptions;
use zmp_indep_sim::{draw_with, write_campaign, CouplingForm, Design, DrawOptions};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seed: u64 = args.first().map_or(Ok(1), |s| s.parse())?;
    let scenario = args.get(1).map_or("clean", |s| s.as_str());
    let design = Design::default();
    let robot = draw_with(
        seed,
        &scenario.parse().map_err(|e| anyhow::anyhow!("{e}"))?,
        &design,
        &DrawOptions {
            coupling_form: Some(CouplingForm::Pendulum),
        },
    );
    for h in &robot.hidden {
        println!("hidden: {h:?}");
    }
    let dir = tempfile::tempdir()?;
    let camp_dir = dir.path().join("campaign");
    write_campaign(&robot, &design, &camp_dir, true)?;
    if let Some(keep) = args.get(2) {
        write_campaign(&robot, &design, std::path::Path::new(keep), true)?;
        zmp_files::write_file(
            std::path::Path::new(&format!("{keep}.truth.json")),
            zmp_files::Kind::Json,
            robot.to_json().as_bytes(),
            true,
        )?;
    }
    let camp = read_campaign(&camp_dir)?;
    // As the blind suites run a draw (one thread, their time limit) when
    // ZMP_DRAW_TIME_LIMIT gives the limit in seconds.
    let limit = std::env::var("ZMP_DRAW_TIME_LIMIT")
        .ok()
        .map(|s| s.parse::<f64>())
        .transpose()?;
    let one = limit.is_some();
    let t = std::time::Instant::now();
    let r = run_loop(
        &camp,
        None,
        &IdentifyOptions {
            threads: one.then_some(1),
            ..IdentifyOptions::default()
        },
        &DiagnoseOptions {
            threads: if one {
                1
            } else {
                DiagnoseOptions::default().threads
            },
            time_limit: limit.map(std::time::Duration::from_secs_f64),
            ..DiagnoseOptions::default()
        },
        &|what| eprintln!("{:7.1} s  {what}", t.elapsed().as_secs_f64()),
    )?;
    for w in &r.identification.warnings {
        println!("identify: {w}");
    }
    for d in &r.diagnoses {
        print!("{}", d.to_text());
    }
    println!(
        "found {:?}; explained {}; {:.2}x -> {:.2}x the floor; {:.1} s",
        r.found,
        r.explained,
        r.identified_error / r.noise_floor,
        r.final_error / r.noise_floor,
        t.elapsed().as_secs_f64()
    );
    // Each version's chi-square per residual component (about 1 for a right model; the loop
    // calls a model explained at EXPLAINED_CHI2_PER_COMPONENT or below, with the error rule).
    let obs: Vec<&Observation> = r.observations.iter().collect();
    let per = |m: &zmp_models::ModelSpec| -> anyhow::Result<String> {
        let preds = predict(m, &obs)?;
        let [(c1, n1), (c3, n3)] = chi2_parts(&obs, &preds);
        Ok(format!(
            "{:.2} (first harmonic and trend {:.2}, third harmonic {:.2} over {} components)",
            chi2_total(&obs, &preds) / components(&obs) as f64,
            c1 / n1.max(1) as f64,
            c3 / n3.max(1) as f64,
            n3
        ))
    };
    println!(
        "chi-square per component: identified {}",
        per(&r.identification.model)?
    );
    for (added, v) in &r.versions {
        println!("  {:?}: {}", added, per(&v.spec)?);
        if std::env::var_os("ZMP_DRAW_THIRD").is_some() {
            // The records whose third harmonic the version misses most.
            let preds = predict(&v.spec, &obs)?;
            let mut rows: Vec<(f64, String)> = Vec::new();
            for (o, p) in obs.iter().zip(&preds).filter(|(o, _)| o.third_band) {
                for i in 0..2 {
                    let pred = o.third(p.g3[i]);
                    let z = (o.y3[i] - pred).norm() / o.y3_var[i].sqrt();
                    rows.push((
                        z,
                        format!(
                            "    rec {:3} {:?}->{i} w {:5.2} A {:.3}: y3 {:.2e} at {:6.1} deg, model {:.2e} at {:6.1} deg, sd {:.1e}, |z| {:.1}",
                            o.index, o.excited, o.omega, o.nominal_amplitude,
                            o.y3[i].norm(), o.y3[i].arg().to_degrees(),
                            pred.norm(), pred.arg().to_degrees(), o.y3_var[i].sqrt(), z
                        ),
                    ));
                }
            }
            rows.sort_by(|a, b| b.0.total_cmp(&a.0));
            for (_, row) in rows.iter().take(12) {
                println!("{row}");
            }
        }
    }
    println!("final model:\n{}", r.final_model.to_toml());
    Ok(())
}
