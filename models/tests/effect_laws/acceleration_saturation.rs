//! `acceleration_saturation`: the CoM acceleration bounded, the gain compressed with odd
//! harmonics, the passive damping beyond the limit.

use crate::support::{plant, whole_period, G11, H};
use crate::{assert_close, harmonic};
use num_complex::Complex64;
use std::f64::consts::PI;
use zmp_models::{Axis, Plant, PlantOutput};

#[test]
fn acceleration_saturation_bounds_the_com_acceleration() {
    let limit = 1.0;
    let mut p = plant(&format!("[acceleration_saturation]\nlimit = {limit}\n"));
    p.reset([0.0; 2]);
    let mut peak: f64 = 0.0;
    for k in 1..=30_000 {
        let t = k as f64 * H;
        // Sines far beyond the limit (0.05 m at 10 rad/s asks for 5 m/s^2), then steps.
        let r = if t < 15.0 {
            [0.05 * (10.0 * t).sin(), 0.03 * (17.0 * t).cos()]
        } else {
            let s = if (t * 0.5).fract() < 0.5 { 0.1 } else { -0.1 };
            [s, -s]
        };
        let o = p.step(r);
        for a in o.com_acceleration {
            assert!(a.abs() <= limit, "t = {t}: |acceleration| {a} > {limit}");
            peak = peak.max(a.abs());
        }
    }
    assert_eq!(peak, limit, "the test never reached the limit");
}

/// Runs the sine until the response is periodic (`signal` repeats sample for sample, within
/// 1e-8 of its range, over two consecutive periods), then records four periods.
/// `omega` must come from [`whole_period`].
fn record_periodic(
    plant: &mut Plant,
    excited: Axis,
    omega: f64,
    amplitude: f64,
    signal: impl Fn(&PlantOutput) -> f64,
) -> (Vec<PlantOutput>, f64) {
    let (_, per) = whole_period(omega);
    let op = plant.operating_point();
    plant.reset(op);
    let mut k = 0usize;
    let step = |plant: &mut Plant, k: &mut usize| {
        *k += 1;
        let mut r = op;
        r[excited.index()] += amplitude * (omega * *k as f64 * H).sin();
        plant.step(r)
    };
    let mut prev: Vec<f64> = vec![f64::NAN; per];
    let mut settled = 0;
    while settled < 2 {
        assert!(k < 5_000_000, "no periodic steady state after {k} steps");
        let y: Vec<f64> = (0..per).map(|_| signal(&step(plant, &mut k))).collect();
        let (lo, hi) = y
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), &v| (l.min(v), h.max(v)));
        let change = y
            .iter()
            .zip(&prev)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        // NaN on the first period compares false.
        settled = if change <= 1e-8 * (hi - lo) {
            settled + 1
        } else {
            0
        };
        prev = y;
    }
    let t0 = (k + 1) as f64 * H;
    let out = (0..4 * per).map(|_| step(plant, &mut k)).collect();
    (out, t0)
}

/// Gain compression and odd harmonics as `amplitude * omega^2` grows past the limit.
///
/// The laws that hold for any acceleration bounded by `L`: the fundamental of the CoM
/// acceleration is at most `(4/pi) L` (a square wave's), so the gain falls as `1/amplitude` once
/// the servo saturates; the clamp is odd, so the periodic response has odd harmonics only.
///
/// Finding (not asserted): this servo, a PD loop whose acceleration is clamped, does not
/// compress gradually. Just past the limit it jumps into a bang-bang cycle (saturated ~99 % of
/// the time) whose fundamental is `(4/pi) L / omega^2`, larger than the linear response: gain
/// 1.25 at 1.05x the limit, 5 rad/s (jump resonance); from rest at 2 rad/s it lands there even
/// at 0.95x. Deeper in saturation (0.2 m at 5 rad/s, 4.9x) the steady state is a period-3
/// subharmonic. The gain falls below one from about 1.35x.
#[test]
fn acceleration_saturation_compresses_gain_and_adds_odd_harmonics() {
    let limit = 1.0;
    let mut p = plant(&format!("[acceleration_saturation]\nlimit = {limit}\n"));
    // An even number of steps per period: the sampled input is then exactly odd under a shift
    // of half a period, and so is the sampled periodic response (no even harmonics to rounding;
    // with an odd number the integration of the clamp's corners differs between the half
    // periods by part of a step, which leaves a second harmonic of ~1e-4).
    let omega = 2.0 * PI / (1256.0 * H);
    let linear = p.frequency_response(omega)[0][0];
    let h_servo = p.tracking_lowpass(Axis::X).tf().freq(omega).norm();
    let bound = 4.0 / PI * limit;
    let mut last: Option<(f64, f64)> = None;
    // Steady-state CoM acceleration of the linear servo over the limit.
    for demand in [0.25, 0.75, 1.6, 2.4, 3.2] {
        let amp = demand * limit / (omega * omega * h_servo);
        let (out, t0) = record_periodic(&mut p, Axis::X, omega, amp, |o| o.zmp[0]);
        let z: Vec<f64> = out.iter().map(|o| o.zmp[0]).collect();
        let acc: Vec<f64> = out.iter().map(|o| o.com_acceleration[0]).collect();
        let first = harmonic(&z, omega, t0) / amp;
        let second = harmonic(&z, 2.0 * omega, t0).norm() / amp / first.norm();
        let third = harmonic(&z, 3.0 * omega, t0).norm() / amp / first.norm();
        let acc1 = harmonic(&acc, omega, t0).norm();
        let gain = first.norm() / linear.norm();
        assert!(
            acc1 <= bound * (1.0 + 1e-9),
            "{demand}x: acceleration fundamental {acc1}"
        );
        if demand < 1.0 {
            // The first-order-hold stepper's own error here is (omega h)^2/12 times the
            // feedthrough ratio |b wn^2 + G|/|G| = 34: 7e-5.
            assert!(
                (gain - 1.0).abs() < 2e-4,
                "{demand}x: linear regime, gain {gain}"
            );
            assert!(
                third < 1e-9,
                "{demand}x: third harmonic {third} in the linear regime"
            );
        } else {
            // Bang-bang: the fundamental sits at the bound, the gain falls as 1/amplitude.
            assert!(
                acc1 >= 0.98 * bound,
                "{demand}x: acceleration fundamental {acc1}"
            );
            if let Some((amp0, gain0)) = last.filter(|_| demand > 1.6) {
                assert!(gain < gain0, "{demand}x: gain {gain} not below {gain0}");
                let ratio = (gain * amp) / (gain0 * amp0);
                assert!(
                    (ratio - 1.0).abs() < 0.01,
                    "{demand}x: gain x amplitude moved {ratio}"
                );
            }
            assert!(third > 0.1, "{demand}x: third harmonic {third}");
            assert!(
                second < 1e-6 * third,
                "{demand}x: second {second}, third {third}"
            );
        }
        // The plant's own simulated response and the describing response (servo-level first
        // harmonic) both give this steady state.
        let sim = p.simulated_response(Axis::X, omega, amp)[0];
        assert_close(
            sim,
            first,
            1e-4,
            0.01,
            &format!("simulated_response, {demand}x"),
        );
        let df = p.describing_response(G11, omega, amp);
        assert_close(
            df,
            first,
            1e-3,
            0.05,
            &format!("describing_response, {demand}x"),
        );
        last = Some((amp, gain));
    }
    let (_, gain) = last.unwrap();
    assert!(
        gain < 0.5,
        "3.2x the limit should be strongly compressed: gain {gain}"
    );
}

/// `passive_damping = c`: the servo's force `x_c'' + c x_c'` is what the limit clamps, and the
/// damping `c x_c'` keeps braking while the force is at the limit. Below the limit the plant is
/// the linear one; past it, the damping outside the clamp compresses the gain further than the
/// clamp alone (the independent robot's load drag); the describing response and the plant's
/// own simulation agree.
#[test]
fn acceleration_saturation_passive_damping_acts_beyond_the_limit() {
    let (limit, c) = (1.0, 20.0);
    let with = |c: f64| {
        plant(&format!(
            "[acceleration_saturation]\nlimit = {limit}\npassive_damping = {c}\n"
        ))
    };
    let (omega, per) = whole_period(8.0);
    let h_servo = plant("").tracking_lowpass(Axis::X).tf().freq(omega).norm();
    let force_gain = Complex64::new(-omega * omega, omega * c).norm() * h_servo;
    // The time law, deep in saturation: |x'' + c x'| <= limit at every step (velocity by a
    // central difference), and it reaches the limit. With the seed's law (c = 0) the
    // acceleration itself would reach the limit while the trunk moves the same way.
    let amp = 3.0 * limit / force_gain;
    let mut p = with(c);
    let (out, _) = record_periodic(&mut p, Axis::X, omega, amp, |o| o.zmp[0]);
    let mut peak: f64 = 0.0;
    for k in 1..out.len() - 1 {
        let v = (out[k + 1].com[0] - out[k - 1].com[0]) / (2.0 * H);
        let force = out[k].com_acceleration[0] + c * v;
        assert!(
            force.abs() <= limit * (1.0 + 1e-2),
            "step {k}: force {force} beyond the limit {limit} (acceleration {}, velocity {v})",
            out[k].com_acceleration[0]
        );
        peak = peak.max(force.abs());
    }
    assert!(
        peak >= 0.99 * limit,
        "the force never reached the limit: {peak}"
    );
    assert_eq!(per, (2.0 * PI / (omega * H)).round() as usize);
    // Below the limit: the linear plant, whatever c.
    let low = 0.5 * limit / force_gain;
    let lin = with(0.0).simulated_response(Axis::X, omega, low)[0];
    let damped = with(c).simulated_response(Axis::X, omega, low)[0];
    assert_close(damped, lin, 1e-9, 1e-7, "below the limit");
    assert_close(
        plant("").frequency_response(omega)[0][0],
        lin,
        2e-4,
        0.01,
        "linear plant",
    );
    // Beyond it: more compression than the clamp alone, and the describing response holds.
    for demand in [1.5, 3.0] {
        let amp = demand * limit / force_gain;
        let clamp_only = with(0.0).simulated_response(Axis::X, omega, amp)[0];
        let mut p = with(c);
        let sim = p.simulated_response(Axis::X, omega, amp)[0];
        assert!(
            sim.norm() < 0.97 * clamp_only.norm(),
            "{demand}x: gain {} with the passive damping, {} without",
            sim.norm(),
            clamp_only.norm()
        );
        let df = p.describing_response(G11, omega, amp);
        assert_close(
            df,
            sim,
            1e-3,
            0.05,
            &format!("describing_response, {demand}x"),
        );
    }
}
