//! The FMUs through FMPy (the venv's Python): `fmpy validate`, and `simulate_fmu` of the plant
//! against the in-process Rust simulation.

mod common;

use common::*;
use serde_json::Value;
use zmp_models::Plant;

fn floats(v: &Value, key: &str) -> Vec<f64> {
    v[key]
        .as_array()
        .unwrap_or_else(|| panic!("{key} missing"))
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

#[test]
fn fmpy_validate_reports_no_problem() {
    let fmus = fmus_all();
    assert_eq!(fmus.all().len(), 5);
    let files: Vec<String> = fmus.all().iter().map(|p| p.display().to_string()).collect();
    let args: Vec<&str> = files.iter().map(String::as_str).collect();
    let out: Value = serde_json::from_str(&run_python("validate.py", &args)).expect("json");
    for f in &files {
        let (text, code) = (out[f][0].as_str().unwrap(), out[f][1].as_i64().unwrap());
        assert_eq!(code, 0, "fmpy validate {f}:\n{text}");
        assert!(
            text.contains("No problems found."),
            "fmpy validate {f}:\n{text}"
        );
    }
}

/// simulate_fmu with an input signal equals the in-process plant stepped the same way: reset at
/// the first input sample, then per communication step `Plant::advance(u_k, n_{k+1} - n_k)`
/// with `n_k` the last grid point at or before `t_k`.
fn plant_matches(plant_fmu: &std::path::Path, dt: f64, stop: f64) {
    let h = 1e-3;
    let start_values = r#"{"uncertainty.G11.delta": 0.6, "uncertainty.G11.delta_seed": 7,
        "uncertainty.G22.delta": -0.4, "pendulum.b11": 0.3}"#;
    let plant_fmu = plant_fmu.display().to_string();
    let out: Value = serde_json::from_str(&run_python(
        "simulate_plant.py",
        &[&plant_fmu, &dt.to_string(), &stop.to_string(), start_values],
    ))
    .expect("json");
    let (t_in, x, y) = (
        floats(&out, "t_in"),
        floats(&out, "x_cr"),
        floats(&out, "y_cr"),
    );
    let time = floats(&out, "time");
    let got: Vec<Vec<f64>> = ["zmp_x", "zmp_y", "x_c", "y_c"]
        .iter()
        .map(|k| floats(&out, k))
        .collect();
    assert_eq!(time.len(), t_in.len(), "one record per communication point");

    let mut spec = spec();
    let sv: Value = serde_json::from_str(start_values).unwrap();
    for p in spec.parameters() {
        if let Some(v) = sv.get(&p.key) {
            spec.effects[p.effect].values[p.index] = v.as_f64().unwrap();
        }
    }
    let mut plant = Plant::new(&spec, h).unwrap();
    let mut o = plant.reset([x[0], y[0]]);
    let mut want: Vec<Vec<f64>> = vec![Vec::new(); 4];
    for k in 0..time.len() {
        if k > 0 {
            assert!(
                (time[k] - t_in[k]).abs() < 1e-12,
                "FMPy stepped at {} not {}",
                time[k],
                t_in[k]
            );
            let steps = grid_floor(time[k], h) - grid_floor(time[k - 1], h);
            if steps > 0 {
                o = plant.advance([x[k - 1], y[k - 1]], steps as usize);
            }
        }
        for (w, v) in want
            .iter_mut()
            .zip([o.zmp[0], o.zmp[1], o.com[0], o.com[1]])
        {
            w.push(v);
        }
    }
    for (i, name) in ["zmp_x", "zmp_y", "x_c", "y_c"].iter().enumerate() {
        let (d, k) = max_abs_diff(&got[i], &want[i]);
        assert!(
            d <= 1e-9,
            "{name}: FMPy and in-process differ by {d:e} at t = {} (dt = {dt})",
            time[k]
        );
    }
    // The signal moved the plant: the comparison is not of constants.
    let span = got[0].iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - got[0].iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(span > 1e-3, "zmp_x barely moved ({span})");
}

#[test]
fn simulate_fmu_matches_in_process_plant_multiple_of_h() {
    plant_matches(&fmus().plant(), 0.01, 3.0);
}

#[test]
fn simulate_fmu_matches_in_process_plant_one_step_per_h() {
    plant_matches(&fmus().plant(), 0.001, 1.0);
}

#[test]
fn simulate_fmu_matches_in_process_plant_off_grid() {
    // 2.5 h: communication points between grid points (outputs at the grid point before).
    plant_matches(&fmus().plant(), 0.0025, 2.0);
}

#[test]
fn simulate_fmu_matches_in_process_plant_fmi3() {
    plant_matches(&fmus_all().plant3(), 0.01, 3.0);
    plant_matches(&fmus_all().plant3(), 0.0025, 2.0);
}

// The FMPy per-step overhead against a trivial FMU is measured by the FMU benchmark
// (`cargo bench -p zmp-bench --bench fmu`), not by a timed test.
