//! The FMUs through FMPy (the venv's Python): `fmpy validate`, and `simulate_fmu` of the plant
//! against the in-process Rust simulation.

mod common;

use common::*;
use serde_json::Value;
use zmp_models::EffectKind;
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

/// `G_ZMP,ij(s) = (a_ij - b_ij s^2) wn^2/(s^2 + 2 zeta wn s + wn^2)` of the nominal model,
/// written out from its parameters (the seed's formula, section 6.5).
fn g_zmp(spec: &zmp_models::ModelSpec, i: usize, j: usize) -> zmp_models::lti::TransferFunction {
    use zmp_models::lti::{Poly, TransferFunction};
    use zmp_models::{Axis, Binding};
    let pend = &spec
        .get(EffectKind::Pendulum, Binding::Global)
        .unwrap()
        .values;
    let (a, b) = (pend[2 * i + j], pend[4 + 2 * i + j]);
    let lp = &spec
        .get(
            EffectKind::TrackingLowpass,
            Binding::Axis(Axis::from_index(j).unwrap()),
        )
        .unwrap()
        .values;
    let (wn, z) = (lp[0], lp[1]);
    TransferFunction::new(Poly::new(&[a, 0.0, -b]), Poly::new(&[1.0])).mul(&TransferFunction::new(
        Poly::new(&[wn * wn]),
        Poly::new(&[wn * wn, 2.0 * z * wn, 1.0]),
    ))
}

/// Exact zero-order-hold response from rest of `tf` to `u[k]` held over `[k H, (k+1) H]`: the
/// output at `(k+1) H`, the input still `u[k]`.
fn exact_zoh(tf: &zmp_models::lti::TransferFunction, u: &[f64], big_h: f64) -> Vec<f64> {
    use zmp_models::lti::{canonical, discretise_foh};
    let (a, b, c, d) = canonical(tf);
    let (phi, gamma0, _) = discretise_foh(&a, &b, big_h);
    let mut x = nalgebra::DVector::zeros(a.nrows());
    u.iter()
        .map(|&uk| {
            x = &phi * &x + &gamma0 * uk;
            c.dot(&x) + d * uk
        })
        .collect()
}

/// FMI co-simulation holds the input set at t over [t, t + H]: under FMPy (no input
/// derivatives) with a sine sampled at the communication points, the plant FMU's outputs equal
/// the exact zero-order-hold discretisation of the seed's G_ZMP over H, within 1e-6 of the
/// output's excursion, at 1, 2 and 10 ms. (The former ramp over the first internal step was
/// 8-15 % off.)
#[test]
fn simulate_fmu_equals_exact_zero_order_hold() {
    let plant = fmus().plant().display().to_string();
    let spec = spec();
    let omega = 6.0;
    for dt in [0.001, 0.002, 0.01] {
        let out: Value = serde_json::from_str(&run_python(
            "simulate_sine.py",
            &[
                &plant,
                &dt.to_string(),
                "2.0",
                &omega.to_string(),
                &dt.to_string(),
                "0",
            ],
        ))
        .expect("json");
        let x0 = out["x0"].as_f64().unwrap();
        let u: Vec<f64> = floats(&out, "x_cr").iter().map(|v| v - x0).collect();
        let time = floats(&out, "time");
        assert_eq!(time.len(), u.len());
        for (i, name) in ["zmp_x", "zmp_y"].iter().enumerate() {
            let got = floats(&out, name);
            let want = exact_zoh(&g_zmp(&spec, i, 0), &u[..u.len() - 1], dt);
            let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            // got[k + 1] is the output at (k + 1) H, relative to the rest value got[0].
            let err = (0..want.len())
                .map(|k| ((got[k + 1] - got[0]) - want[k]).abs())
                .fold(0.0f64, f64::max);
            eprintln!("H = {dt} s, {name}: {:.2e} of the excursion", err / scale);
            assert!(
                err <= 1e-6 * scale,
                "H = {dt} s, {name}: off the exact zero-order hold by {:.2e} relative",
                err / scale
            );
            assert!(scale > 1e-3, "{name} barely moved ({scale})");
        }
    }
}

/// With input derivatives (`set_input_derivatives=True`: fmi2SetRealInputDerivatives, order 1)
/// the plant follows the polyline through the input samples, so a sampled sine gives the
/// continuous plant's frequency response: first harmonic of both outputs within 0.1 % of
/// G(j omega) at 1 ms, at three frequencies whose periods are whole numbers of steps.
#[test]
fn simulate_fmu_with_input_derivatives_has_the_continuous_response() {
    let plant = fmus().plant().display().to_string();
    let model = zmp_models::Plant::new(&spec(), 1e-3).unwrap();
    let dt = 0.001;
    for period in [2.0, 0.5, 0.25] {
        let omega = 2.0 * std::f64::consts::PI / period;
        let settle = 1.5;
        let stop = settle + 2.0 * period;
        let out: Value = serde_json::from_str(&run_python(
            "simulate_sine.py",
            &[
                &plant,
                &dt.to_string(),
                &stop.to_string(),
                &omega.to_string(),
                &dt.to_string(),
                "1",
            ],
        ))
        .expect("json");
        let time = floats(&out, "time");
        let start = (settle / dt).round() as usize;
        let n = (2.0 * period / dt).round() as usize;
        assert!((time[start] - settle).abs() < 1e-9 && time.len() > start + n);
        let g = model.frequency_response(omega);
        for (i, name) in ["zmp_x", "zmp_y"].iter().enumerate() {
            let y = floats(&out, name);
            let h1 =
                zmp_models::harmonic::first_harmonic(&y[start..start + n], omega, dt, time[start]);
            let rel = (h1 / 0.005 - g[i][0]).norm() / g[i][0].norm();
            eprintln!("omega {omega:.3} rad/s, {name}: {rel:.2e} off G(j omega)");
            assert!(
                rel <= 1e-3,
                "omega {omega}: {name} off G(j omega) by {rel:.2e}"
            );
        }
    }
}
