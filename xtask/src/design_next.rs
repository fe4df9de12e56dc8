//! `cargo xtask design-next CAMPAIGN --model M1.toml --model M2.toml`: the records that will
//! separate rival model structures (`zmp_diagnose::design`), written as a design file.

use crate::diagnose::read;
use crate::simulate::load_model;
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use zmp_diagnose::design::limits::CapSource;
use zmp_diagnose::design::{design_next, to_toml, DesignOptions, Designed, Rival, PILOT};
use zmp_files::{check_file, write_file, Kind};

/// What `cargo xtask design-next` was asked.
#[derive(clap::Args, Debug)]
pub struct DesignArgs {
    /// Campaign folder (with campaign.toml).
    pub campaign: PathBuf,
    /// A rival model file (zmp-model/1); give two or three.
    #[arg(long = "model", value_name = "M.toml")]
    pub models: Vec<PathBuf>,
    /// Most records proposed.
    #[arg(long, default_value_t = zmp_diagnose::design::MAX_RECORDS)]
    pub max_records: usize,
    /// Separation (noise standard deviations) at which the design stops. Default: where the
    /// diagnosis's criterion decides a pair with 99 % probability, 2 sqrt(c) (z + 2.33), z the
    /// threshold of a search from the rivals and c the best rival's chi-square per component
    /// on the campaign (at least 1)
    #[arg(long = "target")]
    pub target_sigma: Option<f64>,
    /// Highest candidate frequency, rad/s. Default: twice the campaign's highest, below the
    /// slowest rival's servo omega_n. When designing again after a pilot, give the first
    /// design's highest (it prints it), so that the band grows once, not at every stage
    #[arg(long = "max-omega", value_name = "RAD_S")]
    pub max_omega: Option<f64>,
    /// Noise seed written into the design (for the simulators).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Design file to write (default <campaign>-design-next.toml beside the campaign).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Overwrite an existing design file.
    #[arg(long)]
    pub force: bool,
    /// Print the design, separations and limits as JSON.
    #[arg(long)]
    pub json: bool,
}

/// The design file beside the campaign folder: `<campaign>-design-next.toml`.
fn default_out(campaign: &Path) -> PathBuf {
    let name = campaign
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "campaign".into());
    campaign.with_file_name(format!("{name}-design-next.toml"))
}

pub fn design_next_cmd(a: &DesignArgs) -> Result<Designed> {
    let out = a.out.clone().unwrap_or_else(|| default_out(&a.campaign));
    check_file(&out, Kind::Design, a.force)?;
    let rivals = a
        .models
        .iter()
        .map(|p| {
            Ok(Rival {
                label: p.display().to_string(),
                spec: load_model(p)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let camp = read(&a.campaign, a.json)?;
    let opts = DesignOptions {
        campaign_path: a.campaign.display().to_string(),
        max_records: a.max_records,
        target_sigma: a.target_sigma,
        threads: zmp_campaign::par::budget(),
        seed: a.seed,
        decision: None,
        omega_cap: a.max_omega,
    };
    let spinner = if a.json {
        ProgressBar::hidden()
    } else {
        let pb = ProgressBar::new_spinner();
        pb.set_style(
            ProgressStyle::with_template("{spinner} {elapsed_precise} {msg}")
                .expect("valid template"),
        );
        pb.enable_steady_tick(std::time::Duration::from_millis(200));
        pb
    };
    let started = std::time::Instant::now();
    let d = design_next(&camp, &rivals, &opts, &|m| {
        spinner.set_message(m.to_string())
    })?;
    spinner.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();
    // No record needed (the campaign separates every pair already), or none helps: no file.
    let written = (!d.records.is_empty()).then_some(out.as_path());
    if let Some(out) = written {
        write_file(out, Kind::Design, to_toml(&d).as_bytes(), a.force)
            .with_context(|| format!("writing design {}", out.display()))?;
    }
    if a.json {
        let v = json(&d, &a.campaign, written, seconds);
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        print_text(&d, written, seconds);
    }
    Ok(d)
}

fn cap_source(s: CapSource) -> &'static str {
    match s {
        CapSource::Campaign => "the largest the campaign demanded",
        CapSource::IdentifiedLimit => "an identified acceleration limit",
    }
}

pub(crate) fn print_text(d: &Designed, out: Option<&Path>, seconds: f64) {
    println!(
        "{} records, {:.0} s of recording, designed in {seconds:.1} s: {}",
        d.records.len(),
        d.total_time_s(),
        if d.decided() {
            format!(
                "every pair separated by at least {:.1} noise standard deviations",
                d.target_sigma
            )
        } else {
            format!(
                "the least separated pair at {:.2} of the target {:.1} noise standard deviations",
                d.min_sigma(),
                d.target_sigma
            )
        }
    );
    if let Some(c) = d.decision {
        println!(
            "  target {:.1}: where the diagnosis's criterion (z > {:.2}, mismatch factor {:.2}) \
             decides a pair with probability 99 %",
            d.target_sigma, c.z_crit, c.mismatch
        );
    }
    for (k, l) in d.labels.iter().enumerate() {
        println!("  M{}: {l}", k + 1);
    }
    println!("predicted separation, noise standard deviations (Mi true, Mj refitted with every parameter):");
    for s in &d.separations {
        if s.nested {
            println!(
                "  M{} true, M{} refitted: nested (M{} reproduces M{} on every record; the data \
                 decide by the significance of its extra parameters)",
                s.truth + 1,
                s.rival + 1,
                s.rival + 1,
                s.truth + 1
            );
        } else {
            println!(
                "  M{} true, M{} refitted: {:.2} on the campaign -> {:.2} with the records",
                s.truth + 1,
                s.rival + 1,
                s.campaign_sigma,
                s.total_sigma
            );
        }
    }
    println!("records (axis, frequency, amplitude, operating point, length):");
    for r in &d.records {
        println!(
            "  {}  {:8.3} rad/s  {:7.3} mm  ({:+.3}, {:+.3}) m  {:6.1} s",
            r.excited,
            r.omega,
            r.amplitude * 1e3,
            r.operating_point[0],
            r.operating_point[1],
            r.duration_s
        );
    }
    if d.records.len() > PILOT {
        println!(
            "run the first {PILOT} records first (the pilot), append them, refit the models on \
             the extended campaign and design again with --max-omega {:.3} --max-records {}: \
             the separations above assume the campaign's noise and the models' values where \
             the records lie, which the pilot measures (docs/src/design-next.md)",
            d.limits.omega_max,
            d.records.len() - PILOT
        );
    }
    print_limits(d);
    match out {
        Some(out) => println!("wrote {}", out.display()),
        None if d.decided() => println!("the campaign separates them already: no design written"),
        None => println!("no record within the limits separates them: no design written"),
    }
}

/// The limits and the records' timing the design kept to.
fn print_limits(d: &Designed) {
    let l = &d.limits;
    let t = &d.timing;
    println!("limits used:");
    println!(
        "  frequencies {:.3}-{:.3} rad/s: from the campaign's lowest to the lower of twice its \
         highest and the slowest servo's omega_n ({:.1} rad/s), or --max-omega",
        l.omega_min, l.omega_max, l.servo_omega_n
    );
    println!(
        "  operating points: the campaign's {}; ZMP within x [{:.4}, {:.4}] m, y [{:.4}, \
         {:.4}] m (the range the campaign's records reached)",
        l.operating_points.len(),
        l.zmp_range[0][0],
        l.zmp_range[0][1],
        l.zmp_range[1][0],
        l.zmp_range[1][1]
    );
    println!(
        "  trunk acceleration within x {:.3} m/s2 ({}), y {:.3} m/s2 ({}): respected, not probed",
        l.acceleration_cap[0].0,
        cap_source(l.acceleration_cap[0].1),
        l.acceleration_cap[1].0,
        cap_source(l.acceleration_cap[1].1)
    );
    println!(
        "  amplitudes {:.3}-{:.3} mm, the excited ZMP at least 10 noise standard deviations and \
         3 sensor steps of {:.4} mm; {} of {} candidates within every limit",
        l.amplitudes[0] * 1e3,
        l.amplitudes[l.amplitudes.len() - 1] * 1e3,
        l.resolution * 1e3,
        d.candidates,
        d.grid
    );
    println!(
        "  records timed as the campaign's: {} s transient, at least {} periods and {} s of \
         steady state, {} Hz ({})",
        t.transient_s,
        t.periods,
        t.min_steady_s,
        t.sample_rate_hz,
        if t.exact {
            "read back from the records' lengths"
        } else {
            "from the identification's windows"
        }
    );
}

pub(crate) fn json(
    d: &Designed,
    campaign: &Path,
    out: Option<&Path>,
    seconds: f64,
) -> serde_json::Value {
    let l = &d.limits;
    let t = &d.timing;
    serde_json::json!({
        "campaign": campaign,
        "models": d.labels,
        "design": out,
        "records": d.records.iter().map(|r| serde_json::json!({
            "excited": r.excited, "omega": r.omega, "amplitude_m": r.amplitude,
            "operating_point_m": r.operating_point, "duration_s": r.duration_s,
        })).collect::<Vec<_>>(),
        "separations": d.separations.iter().map(|s| serde_json::json!({
            "truth": d.labels[s.truth], "rival": d.labels[s.rival], "nested": s.nested,
            "campaign_sigma": s.campaign_sigma, "total_sigma": s.total_sigma,
            "added_sigma": s.added_sigma,
        })).collect::<Vec<_>>(),
        "smallest_sigma_path": d.path,
        "target_sigma": d.target_sigma,
        "decision": d.decision.map(|c| serde_json::json!({"z_crit": c.z_crit, "mismatch": c.mismatch})),
        "decided": d.decided(),
        "pilot_records": PILOT.min(d.records.len()),
        "total_time_s": d.total_time_s(),
        "seconds": seconds,
        "candidates": d.candidates,
        "grid": d.grid,
        "limits": {
            "omega_min": l.omega_min, "omega_max": l.omega_max,
            "servo_omega_n": l.servo_omega_n,
            "operating_points_m": l.operating_points,
            "zmp_range_m": l.zmp_range,
            "acceleration_cap_m_s2": [l.acceleration_cap[0].0, l.acceleration_cap[1].0],
            "resolution_m": l.resolution,
        },
        "timing": {
            "sample_rate_hz": t.sample_rate_hz, "transient_s": t.transient_s,
            "periods": t.periods, "min_steady_s": t.min_steady_s, "read_back": t.exact,
        },
    })
}
