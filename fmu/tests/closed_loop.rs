//! The closed loop of the plant and controller FMUs run by FMPy (examples/fmpy_closed_loop.py,
//! FMU2Slave and FMU3Slave) reproduces `zmp_models::closed_loop::run`, and FMI 3.0 matches
//! FMI 2.0. (The Rust-importer closed loop is in tests/importer.rs.)

mod common;

use common::*;
use serde_json::Value;
use std::path::Path;
use zmp_models::closed_loop::{run, StepExperiment};
use zmp_models::controller::{CascadeController, CascadeParams};
use zmp_models::Plant;

fn pairs(v: &Value, key: &str) -> Vec<[f64; 2]> {
    v[key]
        .as_array()
        .unwrap_or_else(|| panic!("{key} missing"))
        .iter()
        .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
        .collect()
}

fn worst(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    assert_eq!(a.len(), b.len(), "trace lengths differ");
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| [(x[0] - y[0]).abs(), (x[1] - y[1]).abs()])
        .fold(0.0, f64::max)
}

fn fmpy_closed_loop(
    plant: &Path,
    controller: &Path,
    exp: &StepExperiment,
    figure: Option<&Path>,
) -> Value {
    let dir = plant.parent().unwrap();
    let json = dir.join(format!(
        "{}.trace.json",
        plant.file_stem().unwrap().to_string_lossy()
    ));
    let exp_json = serde_json::json!({
        "zmp_ref_before": exp.zmp_ref_before, "zmp_ref_after": exp.zmp_ref_after,
        "load_time": exp.load_time, "load_mass": exp.load_mass, "robot_mass": exp.robot_mass,
        "load_position": exp.load_position, "duration": exp.duration,
        "controller_period": exp.controller_period,
    })
    .to_string();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/fmpy_closed_loop.py");
    let (p, c, j) = (
        plant.display().to_string(),
        controller.display().to_string(),
        json.display().to_string(),
    );
    let fig = figure.map(|f| f.display().to_string());
    let mut args = vec![
        script.to_str().unwrap(),
        "--plant",
        &p,
        "--controller",
        &c,
        "--json",
        &j,
        "--experiment",
        &exp_json,
    ];
    match &fig {
        Some(f) => args.extend(["--out", f.as_str()]),
        None => args.push("--no-plot"),
    }
    let out = std::process::Command::new(python())
        .args(&args)
        .output()
        .expect("running python");
    assert!(
        out.status.success(),
        "fmpy_closed_loop.py failed:\n{}\n{}\nIf fmpy is missing, run `cargo xtask setup`.",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap()
}

#[test]
fn fmpy_closed_loop_reproduces_in_process_experiment() {
    let fmus = fmus_all();
    let exp = StepExperiment::silo2();
    let mut plant = Plant::new(&spec(), 1e-3).unwrap();
    let mut ctrl = CascadeController::new(CascadeParams::silo2(), exp.controller_period);
    let want = run(&mut plant, &mut ctrl, &exp);

    let figure = fmus.dir.join("fmpy_closed_loop.png");
    let _ = std::fs::remove_file(&figure);
    let v2 = fmpy_closed_loop(&fmus.plant(), &fmus.controller(), &exp, Some(&figure));
    let v3 = fmpy_closed_loop(&fmus.plant3(), &fmus.controller3(), &exp, None);
    assert!(
        std::fs::metadata(&figure)
            .map(|m| m.len() > 10_000)
            .unwrap_or(false),
        "the example wrote no figure at {}",
        figure.display()
    );
    for (name, got) in [("FMI 2.0", &v2), ("FMI 3.0", &v3)] {
        for (key, w) in [
            ("zmp", &want.zmp),
            ("com_ref", &want.com_ref),
            ("com", &want.com),
            ("theta", &want.theta),
        ] {
            let d = worst(&pairs(got, key), w);
            assert!(
                d <= 1e-9,
                "{name}: {key} differs from closed_loop::run by {d:e}"
            );
        }
    }
    for key in ["zmp", "com_ref", "com", "theta"] {
        let d = worst(&pairs(&v2, key), &pairs(&v3, key));
        assert!(d <= 1e-9, "FMI 3.0 and FMI 2.0 differ in {key} by {d:e}");
    }
}

/// A second co-simulation master: plant and controller FMUs in closed loop inside an FMU
/// container built by fmu-manipulation-toolbox (sequential schedule, controller first, 10 ms
/// step), simulated by FMPy, reproduce `closed_loop::run` of the seed's reference step
/// (40 s; the load of the full experiment acts on the measurement between the FMUs, which a
/// container of the two cannot express).
#[test]
fn container_closed_loop_reproduces_in_process_experiment() {
    let fmus = fmus();
    let exp = StepExperiment {
        duration: 40.0,
        load_time: f64::INFINITY,
        ..StepExperiment::silo2()
    };
    let mut plant = Plant::new(&spec(), 1e-3).unwrap();
    let mut ctrl = CascadeController::new(CascadeParams::silo2(), exp.controller_period);
    let want = run(&mut plant, &mut ctrl, &exp);
    let work = fmus.dir.join("container");
    let _ = std::fs::remove_dir_all(&work);
    let (c, p, w) = (
        fmus.controller().display().to_string(),
        fmus.plant().display().to_string(),
        work.display().to_string(),
    );
    let out: Value = serde_json::from_str(&run_python(
        "container_closed_loop.py",
        &[
            &c,
            &p,
            &w,
            &exp.duration.to_string(),
            &exp.controller_period.to_string(),
        ],
    ))
    .expect("json");
    let series = |name: &str| -> Vec<f64> {
        out[name]
            .as_array()
            .unwrap_or_else(|| panic!("{name} missing"))
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    let time = series("time");
    assert_eq!(time.len(), want.t.len(), "one sample per controller period");
    for (key, axis, w) in [
        ("plant_zmp_x", 0, &want.zmp),
        ("plant_zmp_y", 1, &want.zmp),
        ("controller_x_cr", 0, &want.com_ref),
        ("controller_y_cr", 1, &want.com_ref),
        ("plant_x_c", 0, &want.com),
        ("controller_theta_x", 0, &want.theta),
    ] {
        let got = series(key);
        let d = got
            .iter()
            .zip(w.iter())
            .map(|(g, w)| (g - w[axis]).abs())
            .fold(0.0, f64::max);
        eprintln!("{key}: container vs closed_loop::run {d:.2e}");
        // Not 1e-9 as FMPy's own master gives: the toolbox initialises the controller before
        // the loop's values reach it (its "Loop of links" warning), so the controller's first
        // preview sample sees a zero ZMP and the plant starts 0.09 um off its rest point; the
        // loop then differs by up to 3.1e-5 m (measured). Bound set after that measurement.
        // (Trunk angles, rad: 2.8e-4 measured.)
        let bound = if key.contains("theta") { 1e-3 } else { 1e-4 };
        assert!(d <= bound, "{key} differs from closed_loop::run by {d:e}");
    }
    // The loop did its job: the ZMP reached the new reference.
    let z = series("plant_zmp_x");
    assert!(
        (z[z.len() - 1] - 0.17).abs() < 0.005,
        "final zmp_x {}",
        z[z.len() - 1]
    );
}

/// `fmutool -check` (fmu-manipulation-toolbox's FMI 2.0/3.0 schema and semantic checks) finds
/// nothing to report on any of the four FMUs.
#[test]
fn fmutool_check_is_clean_for_all_four_fmus() {
    let fmus = fmus_all();
    let fmutool = python().with_file_name("fmutool");
    for f in [
        fmus.plant(),
        fmus.controller(),
        fmus.plant3(),
        fmus.controller3(),
    ] {
        let out = std::process::Command::new(&fmutool)
            .args(["-input", f.to_str().unwrap(), "-check"])
            .output()
            .unwrap_or_else(|e| {
                panic!(
                    "running {}: {e} (run `cargo xtask setup`)",
                    fmutool.display()
                )
            });
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            out.status.success(),
            "fmutool -check {}:\n{text}",
            f.display()
        );
        assert!(
            text.contains("seems to be compliant with FMI-") && text.contains("No semantic error"),
            "fmutool -check {}:\n{text}",
            f.display()
        );
        let bad: Vec<&str> = text
            .lines()
            .filter(|l| l.contains("ERROR") || l.contains("WARNING"))
            .collect();
        assert!(bad.is_empty(), "fmutool -check {}: {bad:?}", f.display());
    }
}
