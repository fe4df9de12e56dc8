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
