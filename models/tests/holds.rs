// Index loops read as the outputs they compare.
#![allow(clippy::needless_range_loop)]

//! The plant under the two holds an importer can ask for, against the exact discretisation of
//! the seed's continuous model:
//!
//! - zero-order hold (`Plant::advance`: the input held over the step, as an FMI communication
//!   step or a digital controller gives it): the outputs at the steps equal the exact
//!   zero-order-hold discretisation of `G_ZMP,ij(s) = (a_ij - b_ij s^2) wn^2 / (s^2 +
//!   2 zeta wn s + wn^2)` over the step `H`, computed here from the transfer function written
//!   out (one state-space of the whole channel, not the plant's servo/pendulum split);
//! - a whole-step time delay passes a held input through exactly (shifted by its steps).

use zmp_models::lti::{canonical, discretise_foh, Poly, TransferFunction};
use zmp_models::EffectKind;
use zmp_models::{Binding, ModelSpec, Plant};

const PAPER: &str = include_str!("../params/silo2-paper.toml");

fn paper() -> ModelSpec {
    ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap()
}

/// `G_ij(s)` of the nominal seed model, from its parameters.
fn g(spec: &ModelSpec, i: usize, j: usize) -> TransferFunction {
    let pend = &spec
        .get(EffectKind::Pendulum, Binding::Global)
        .unwrap()
        .values;
    let (a, b) = (pend[2 * i + j], pend[4 + 2 * i + j]);
    let lp = &spec
        .get(
            EffectKind::TrackingLowpass,
            Binding::Axis(zmp_models::Axis::from_index(j).unwrap()),
        )
        .unwrap()
        .values;
    let (wn, z) = (lp[0], lp[1]);
    TransferFunction::new(Poly::new(&[a, 0.0, -b]), Poly::new(&[1.0, 0.0, 0.0])).mul(
        &TransferFunction::new(
            Poly::new(&[wn * wn]),
            Poly::new(&[wn * wn, 2.0 * z * wn, 1.0]),
        ),
    )
}

/// Exact zero-order-hold response of `tf` from rest to the inputs `u[k]` held over
/// `[k H, (k+1) H]`: the output at `(k+1) H`, the input still `u[k]`.
fn zoh_response(tf: &TransferFunction, u: &[f64], big_h: f64) -> Vec<f64> {
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

/// The input: a sine of `amp` at `omega` around `op`, sampled at `k H`.
fn samples(op: f64, amp: f64, omega: f64, big_h: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| op + amp * (omega * k as f64 * big_h).sin())
        .collect()
}

/// Largest deviation of the plant's held response from the exact one, relative to the
/// largest output excursion, over 2 s on both outputs, for each communication step.
#[test]
fn held_input_equals_exact_zero_order_hold_of_g_zmp() {
    let spec = paper();
    let h = 1e-3;
    for (steps, omega) in [(1usize, 3.0), (2, 3.0), (10, 3.0), (1, 15.0), (10, 15.0)] {
        let big_h = steps as f64 * h;
        let n = (2.0 / big_h).round() as usize;
        let op = [0.12, 0.02];
        for j in 0..2 {
            let mut plant = Plant::new(&spec, h).unwrap();
            let rest = plant.reset(op);
            let u = samples(op[j], 0.005, omega, big_h, n);
            let mut got = [Vec::new(), Vec::new()];
            for &uk in &u {
                let mut r = op;
                r[j] = uk;
                let o = plant.advance(r, steps);
                got[0].push(o.zmp[0] - rest.zmp[0]);
                got[1].push(o.zmp[1] - rest.zmp[1]);
            }
            let du: Vec<f64> = u.iter().map(|v| v - op[j]).collect();
            for i in 0..2 {
                let want = zoh_response(&g(&spec, i, j), &du, big_h);
                let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let err = got[i]
                    .iter()
                    .zip(&want)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                assert!(
                    err <= 1e-9 * scale,
                    "H = {big_h} s, omega {omega}: G{}{} off by {:.2e} relative",
                    i + 1,
                    j + 1,
                    err / scale
                );
            }
        }
    }
}

/// A delay of whole steps delays a held (jumping) input exactly: the delayed plant's outputs
/// are the undelayed plant's, shifted.
#[test]
fn whole_step_delay_shifts_a_held_input_exactly() {
    let h = 1e-3;
    let plain = paper();
    let delayed = ModelSpec::parse(
        &format!("{PAPER}\n[time_delay]\ndelay = 0.04\n"),
        "delayed.toml",
    )
    .unwrap();
    let mut p = Plant::new(&plain, h).unwrap();
    let mut q = Plant::new(&delayed, h).unwrap();
    p.reset([0.1, 0.0]);
    q.reset([0.1, 0.0]);
    let u = |k: usize| {
        [
            0.1 + 0.004 * ((k / 7) as f64 * 0.9).sin(),
            0.003 * (k / 5 % 2) as f64,
        ]
    };
    let mut a = Vec::new();
    let mut b = Vec::new();
    for k in 0..400 {
        a.push(p.advance(u(k), 1).zmp);
        b.push(q.advance(u(k), 1).zmp);
    }
    for k in 40..400 {
        for i in 0..2 {
            assert!(
                (b[k][i] - a[k - 40][i]).abs() < 1e-12,
                "step {k}: {} vs {}",
                b[k][i],
                a[k - 40][i]
            );
        }
    }
}

/// Exact first-order-hold response of `tf` from rest to the polyline through `u[k]` at `k H`:
/// the output at `(k+1) H`.
fn foh_response(tf: &TransferFunction, u: &[f64], big_h: f64) -> Vec<f64> {
    let (a, b, c, d) = canonical(tf);
    let (phi, gamma0, gamma1) = discretise_foh(&a, &b, big_h);
    let mut x = nalgebra::DVector::zeros(a.nrows());
    u.windows(2)
        .map(|w| {
            x = &phi * &x + &gamma0 * w[0] + &gamma1 * ((w[1] - w[0]) / big_h);
            c.dot(&x) + d * w[1]
        })
        .collect()
}

/// Ramped inputs (`step_from` with the values at both ends of each internal step, as the FMUs
/// do with input derivatives) give the exact first-order-hold discretisation, also when the
/// line's slope changes only every few steps.
#[test]
fn ramped_input_equals_exact_first_order_hold_of_g_zmp() {
    let spec = paper();
    let h = 1e-3;
    for steps in [1usize, 2, 10] {
        let big_h = steps as f64 * h;
        let n = (2.0 / big_h).round() as usize;
        let op = [0.12, 0.02];
        let u = samples(op[0], 0.005, 9.0, big_h, n + 1);
        let mut plant = Plant::new(&spec, h).unwrap();
        let rest = plant.reset(op);
        let mut got = Vec::new();
        for w in u.windows(2) {
            let mut o = plant.last_output();
            for m in 0..steps {
                let at = |m: usize| w[0] + (w[1] - w[0]) * m as f64 / steps as f64;
                o = plant.step_from([at(m), op[1]], [at(m + 1), op[1]]);
            }
            got.push(o.zmp[0] - rest.zmp[0]);
        }
        let du: Vec<f64> = u.iter().map(|v| v - op[0]).collect();
        let want = foh_response(&g(&spec, 0, 0), &du, big_h);
        let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let err = got
            .iter()
            .zip(&want)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(
            err <= 1e-9 * scale,
            "H = {big_h} s: off by {:.2e} relative",
            err / scale
        );
    }
}

/// With the uncertainty acting (`Delta = 0.5` on G11), the block after the pendulum sees the
/// pendulum's output as a ramp between steps: close to, not exactly, the zero-order hold of the
/// whole channel `G11 (1 + W11 Delta)`. Bound set before measuring: 1e-3 relative at 1 ms.
#[test]
fn held_input_with_uncertainty_is_close_to_exact() {
    let text = PAPER.replace("delta = 0.0", "delta = 0.5");
    let spec = ModelSpec::parse(&text, "delta.toml").unwrap();
    let h = 1e-3;
    let op = [0.12, 0.02];
    let n = 2000;
    let u = samples(op[0], 0.005, 3.0, h, n);
    let mut plant = Plant::new(&spec, h).unwrap();
    let rest = plant.reset(op);
    let got: Vec<f64> = u
        .iter()
        .map(|&v| plant.advance([v, op[1]], 1).zmp[0] - rest.zmp[0])
        .collect();
    let unc = zmp_models::effects::uncertainty::channel_factor(
        &spec
            .get(
                EffectKind::Uncertainty,
                Binding::Channel(zmp_models::Channel::ALL[0]),
            )
            .unwrap()
            .values,
    );
    let du: Vec<f64> = u.iter().map(|v| v - op[0]).collect();
    let want = zoh_response(&g(&spec, 0, 0).mul(&unc), &du, h);
    let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let err = got
        .iter()
        .zip(&want)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    eprintln!(
        "G11 (1 + W Delta), Delta = 0.5, H = 1 ms: {:.2e} relative",
        err / scale
    );
    assert!(err <= 1e-3 * scale, "off by {:.2e} relative", err / scale);
}
