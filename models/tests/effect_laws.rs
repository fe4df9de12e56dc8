//! One test per effect's defining law, checked through the composed plant where that is
//! natural: the effect's plant against the same plant without it.

// Index loops read as the matrix algebra they check.
#![allow(clippy::needless_range_loop)]

use num_complex::Complex64;
use std::f64::consts::PI;
use zmp_models::effects::{backlash, uncertainty};
use zmp_models::harmonic::first_harmonic;
use zmp_models::lti::slowest_time_constant;
use zmp_models::{Axis, Binding, Channel, Plant, PlantOutput};

mod support;
use support::*;

fn harmonic(y: &[f64], omega: f64, t0: f64) -> Complex64 {
    first_harmonic(y, omega, H, t0)
}

fn assert_close(got: Complex64, want: Complex64, mag_tol: f64, phase_tol_deg: f64, what: &str) {
    let r = got / want;
    let (m, p) = (r.norm() - 1.0, r.arg().to_degrees());
    assert!(
        m.abs() <= mag_tol && p.abs() <= phase_tol_deg,
        "{what}: got {got}, want {want}: magnitude error {m:.3e}, phase error {p:.4} deg"
    );
}

// ---------------------------------------------------------------------------------------------
// time_delay

/// `e^{-s tau}`: the phase falls by `omega tau`, the magnitude stays. Time simulation against
/// the delay-free plant. With a step of 1 ms the fractional delay's linear interpolation costs
/// at most `(omega h)^2/8` in magnitude (2e-4 at 40 rad/s), so 0.1 % and 0.1 degree hold.
#[test]
fn time_delay_shifts_phase_by_omega_tau_and_keeps_magnitude() {
    let mut base = plant("");
    for tau in [0.0375, 0.0123, 0.2] {
        let mut delayed = plant(&format!("[time_delay]\ndelay = {tau}\n"));
        for omega in [0.5, 2.0, 8.0, 20.0, 40.0] {
            let want_shift = Complex64::from_polar(1.0, -omega * tau);
            let g0 = base.frequency_response(omega);
            let g1 = delayed.frequency_response(omega);
            for i in 0..2 {
                for j in 0..2 {
                    assert!((g1[i][j] - g0[i][j] * want_shift).norm() <= 1e-12 * g0[i][j].norm());
                }
            }
            for axis in Axis::BOTH {
                let s0 = base.simulated_response(axis, omega, 0.01);
                let s1 = delayed.simulated_response(axis, omega, 0.01);
                for i in 0..2 {
                    assert_close(
                        s1[i] / s0[i],
                        want_shift,
                        1e-3,
                        0.1,
                        &format!("delay {tau} s, {omega} rad/s, output {i} from {axis}"),
                    );
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// backlash

/// A play of total width `w` passes nothing while the input's amplitude is below `w/2`.
#[test]
fn backlash_below_half_width_gives_no_motion() {
    let w = 0.004;
    let mut p = plant(&format!("[backlash]\nwidth = {w}\n"));
    let op = [0.02, -0.01];
    for amp in [0.2 * w, 0.45 * w, 0.499 * w] {
        let rest = p.reset(op);
        for k in 1..=20_000 {
            let t = k as f64 * H;
            let r = [
                op[0] + amp * (3.0 * t).sin(),
                op[1] + amp * (7.0 * t + 1.0).sin(),
            ];
            let o = p.step(r);
            for i in 0..2 {
                assert!(
                    (o.zmp[i] - rest.zmp[i]).abs() <= 1e-12
                        && (o.com[i] - rest.com[i]).abs() <= 1e-12
                        && o.com_acceleration[i].abs() <= 1e-9,
                    "amplitude {amp} < w/2 = {}: output moved at t = {t}: {o:?} vs rest {rest:?}",
                    w / 2.0
                );
            }
        }
    }
}

/// Above `w/2` the output moves, `2 A - w` peak to peak once the play is taken up.
#[test]
fn backlash_above_half_width_moves_by_amplitude_minus_play() {
    let w = 0.004;
    let mut p = plant(&format!("[backlash]\nwidth = {w}\n"));
    let (omega, _) = whole_period(0.5);
    for amp in [0.6 * w, w, 3.0 * w] {
        let (out, _) = record(&mut p, [0.0; 2], Axis::X, omega, amp, 15.0, 2);
        let (lo, hi) = out.iter().fold((f64::MAX, f64::MIN), |(lo, hi), o| {
            (lo.min(o.com[0]), hi.max(o.com[0]))
        });
        let want = 2.0 * amp - w;
        // At 0.5 rad/s the tracking low-pass passes the slow backlash output within 0.2 %;
        // the backlash output's corners pass within 2 %.
        assert!(
            ((hi - lo) / want - 1.0).abs() < 0.02,
            "amplitude {amp}: CoM moves {} peak to peak, want 2A - w = {want}",
            hi - lo
        );
    }
}

/// The describing function of the play matches the simulated first harmonic within 2 %.
#[test]
fn backlash_describing_function_matches_simulation() {
    let w = 0.004;
    let b = w / 2.0;
    let mut p = plant(&format!("[backlash]\nwidth = {w}\n"));
    for ratio in [1.2, 1.5, 2.0, 4.0, 10.0] {
        let amp = ratio * b;
        // The formula itself at its limits.
        assert_eq!(
            backlash::describing_function(b, 0.99 * b),
            Complex64::new(0.0, 0.0)
        );
        for omega in [1.0, 5.0, 15.0] {
            let sim = p.simulated_response(Axis::X, omega, amp);
            for (i, ch) in [(0, G11), (1, G21)] {
                let df = p.describing_response(ch, omega, amp);
                let rel = (sim[i] - df).norm() / df.norm();
                assert!(
                    rel <= 0.02,
                    "A/b = {ratio}, {omega} rad/s, {ch}: simulated {} vs describing {df}: {rel:.4}",
                    sim[i]
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// acceleration_saturation

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

// ---------------------------------------------------------------------------------------------
// coulomb_friction

/// Friction takes a fixed acceleration, so it matters more for small motions: their gain
/// shrinks more, and the phase lags.
#[test]
fn coulomb_friction_shrinks_small_amplitudes_more_and_lags() {
    let mut p = plant("[coulomb_friction]\nlevel = 0.5\n");
    for omega in [1.0, 2.0, 6.0] {
        let lin = p.frequency_response(omega);
        let small = p.simulated_response(Axis::X, omega, 0.002)[0] / lin[0][0];
        let large = p.simulated_response(Axis::X, omega, 0.05)[0] / lin[0][0];
        assert!(
            small.norm() < large.norm() && large.norm() <= 1.0,
            "{omega} rad/s: gain small {} large {}",
            small.norm(),
            large.norm()
        );
        assert!(
            small.norm() < 0.9,
            "{omega} rad/s: small-amplitude gain {}",
            small.norm()
        );
        assert!(
            small.arg() < 0.0 && large.arg() < 0.0 && small.arg() < large.arg(),
            "{omega} rad/s: phase small {} large {} deg",
            small.arg().to_degrees(),
            large.arg().to_degrees()
        );
        assert!((large - 1.0).norm() < (small - 1.0).norm());
    }
}

// ---------------------------------------------------------------------------------------------
// structural_mode

/// A mode carrying a share of the path: unit gain at rest, `1 - share` far above the mode, a
/// resonance and an anti-resonance above it (at `omega_n / sqrt(1 - share)` for light damping),
/// and the time simulation agrees with the frequency response.
#[test]
fn structural_mode_with_a_share_keeps_the_rest_rigid() {
    let base = plant("");
    let (wn, zeta, share) = (20.0, 0.03, 0.4);
    let mut p = plant(&format!(
        "[structural_mode]\nomega_n = {wn}\nzeta = {zeta}\nshare = {share}\n"
    ));
    let ratio = |p: &zmp_models::Plant, w: f64| {
        p.frequency_response(w)[0][0] / base.frequency_response(w)[0][0]
    };
    assert!((ratio(&p, 1e-3).norm() - 1.0).abs() < 1e-6);
    assert!((ratio(&p, 100.0 * wn).norm() - (1.0 - share)).abs() < 1e-3);
    // The anti-resonance: the smallest gain between 1 and 3 omega_n.
    let (mut low, mut at) = (f64::INFINITY, 0.0);
    for k in 0..=7000 {
        let w = wn * (1.0 + 2.0 * k as f64 / 7000.0);
        let r = ratio(&p, w).norm();
        if r < low {
            (low, at) = (r, w);
        }
    }
    let expected = wn / (1.0 - share).sqrt();
    assert!(
        (at / expected - 1.0).abs() < 0.02,
        "anti-resonance at {at}, expected {expected}"
    );
    assert!(low < 0.2, "anti-resonance depth {low}");
    // The stepper agrees with the frequency response at the anti-resonance and at the mode.
    for w in [expected, wn] {
        let s = p.simulated_response(Axis::X, w, 0.001)[0];
        let f = p.frequency_response(w)[0][0];
        assert!(
            (s - f).norm() <= 2e-3 * f.norm().max(1e-3),
            "{w}: {s} vs {f}"
        );
    }
}

/// A lightly damped mode peaks near `omega_n` with a gain of about `1/(2 zeta)`.
#[test]
fn structural_mode_peaks_at_omega_n_with_gain_one_over_two_zeta() {
    let base = plant("");
    for zeta in [0.02, 0.05, 0.1] {
        for wn in [25.0, 60.0] {
            let mut p = plant(&format!(
                "[structural_mode]\nomega_n = {wn}\nzeta = {zeta}\n"
            ));
            // Frequency response, dense grid over 0.5..1.5 omega_n.
            let (mut peak, mut at) = (0.0, 0.0);
            for k in 0..=4000 {
                let w = wn * (0.5 + k as f64 / 4000.0);
                let r = (p.frequency_response(w)[0][0] / base.frequency_response(w)[0][0]).norm();
                if r > peak {
                    (peak, at) = (r, w);
                }
            }
            assert!(
                (at / wn - 1.0).abs() <= 2.0 * zeta * zeta + 1e-3,
                "zeta {zeta}: peak at {at}, omega_n {wn}"
            );
            assert!(
                (peak * 2.0 * zeta - 1.0).abs() <= 0.1,
                "zeta {zeta}: peak {peak} vs 1/(2 zeta) = {}",
                0.5 / zeta
            );
            // Time simulation on a coarse sweep around omega_n: the largest gain is at the
            // frequency nearest omega_n and within 10 % of 1/(2 zeta).
            let mut sweep = Vec::new();
            for k in -4i32..=4 {
                let w = wn * (1.0 + 0.5 * zeta * k as f64);
                let s = p.simulated_response(Axis::Y, w, 0.001)[1];
                let b = base.frequency_response(w)[1][1];
                sweep.push((k, (s / b).norm()));
            }
            let (k_max, g_max) =
                sweep
                    .iter()
                    .copied()
                    .fold((0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
            assert!(
                k_max.abs() <= 1,
                "zeta {zeta}: simulated peak at k = {k_max}: {sweep:?}"
            );
            assert!(
                (g_max * 2.0 * zeta - 1.0).abs() <= 0.1,
                "zeta {zeta}: simulated peak {g_max} vs {}",
                0.5 / zeta
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// sensor_lowpass

/// `wc/(s + wc)`: -3 dB and -45 degrees at the cutoff.
#[test]
fn sensor_lowpass_is_minus_3_db_and_minus_45_degrees_at_cutoff() {
    let mut base = plant("");
    for cutoff in [5.0, 20.0, 80.0] {
        let mut p = plant(&format!("[sensor_lowpass]\ncutoff = {cutoff}\n"));
        let r = p.frequency_response(cutoff)[1][0] / base.frequency_response(cutoff)[1][0];
        assert!(
            (20.0 * r.norm().log10() + 3.010_299_956_639_812).abs() < 1e-9,
            "{r}"
        );
        assert!((r.arg().to_degrees() + 45.0).abs() < 1e-9, "{r}");
        let s = p.simulated_response(Axis::X, cutoff, 0.01);
        let s0 = base.simulated_response(Axis::X, cutoff, 0.01);
        for i in 0..2 {
            let r = s[i] / s0[i];
            let db = 20.0 * r.norm().log10();
            assert!(
                (db + 3.0103).abs() < 0.02,
                "cutoff {cutoff}, output {i}: {db} dB"
            );
            assert!(
                (r.arg().to_degrees() + 45.0).abs() < 0.2,
                "cutoff {cutoff}, output {i}: {} deg",
                r.arg().to_degrees()
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// sensor_drift

/// `zmp + offset + rate t`, exactly, t from the reset; the first harmonic (fitted with the
/// trend, as a measurement would) is that of the drift-free plant.
#[test]
fn sensor_drift_adds_offset_plus_rate_times_t_and_keeps_first_harmonic() {
    let (offset, rate) = (0.003, 2e-4);
    let mut base = plant("");
    let mut p = plant(&format!(
        "[sensor_drift]\noffset = {offset}\nrate = {rate}\n"
    ));
    for omega in [0.7, 4.0, 25.0] {
        let g0 = base.frequency_response(omega);
        let g1 = p.frequency_response(omega);
        assert_eq!(g0, g1, "the drift has no frequency response of its own");
    }
    let op = [0.05, 0.02];
    let r0 = base.reset(op);
    let r1 = p.reset(op);
    for i in 0..2 {
        assert!((r1.zmp[i] - r0.zmp[i] - offset).abs() <= 1e-15);
    }
    let (omega, per) = whole_period(3.0);
    let n = 20_000;
    let (mut y0, mut y1) = (Vec::new(), Vec::new());
    for k in 1..=n {
        let t = k as f64 * H;
        let r = [
            op[0] + 0.01 * (omega * t).sin(),
            op[1] + 0.004 * (omega * t).cos(),
        ];
        let (o0, o1) = (base.step(r), p.step(r));
        for i in 0..2 {
            let want = offset + rate * t;
            assert!(
                (o1.zmp[i] - o0.zmp[i] - want).abs() <= 1e-14,
                "t = {t}: drift {} vs {want}",
                o1.zmp[i] - o0.zmp[i]
            );
            assert_eq!(o1.com, o0.com);
        }
        if k > n - 4 * per {
            y0.push(o0.zmp[0]);
            y1.push(o1.zmp[0]);
        }
    }
    let t0 = (n - 4 * per + 1) as f64 * H;
    let p0 = harmonic(&y0, omega, t0);
    let p1 = harmonic_with_trend(&y1, omega, t0);
    assert!((p1 - p0).norm() <= 1e-9 * p0.norm(), "{p1} vs {p0}");
    // Without the trend term the ramp would leak into the fit: the law needs it.
    let leaky = harmonic(&y1, omega, t0);
    assert!((leaky - p0).norm() > 1e-6 * p0.norm());
}

/// Least squares of `c + d t + alpha sin + beta cos`; returns `alpha + j beta`.
fn harmonic_with_trend(y: &[f64], omega: f64, t0: f64) -> Complex64 {
    use nalgebra::{Matrix4, Vector4};
    let mut m = Matrix4::<f64>::zeros();
    let mut r = Vector4::<f64>::zeros();
    let tm = t0 + 0.5 * y.len() as f64 * H;
    for (k, &yk) in y.iter().enumerate() {
        let t = t0 + k as f64 * H;
        let (s, c) = (omega * t).sin_cos();
        let phi = Vector4::new(1.0, t - tm, s, c);
        m += phi * phi.transpose();
        r += phi * yk;
    }
    let x = m.lu().solve(&r).unwrap();
    Complex64::new(x[2], x[3])
}

// ---------------------------------------------------------------------------------------------
// operating_point_dependence

/// `a_ij(x_c) = a_ij (1 + da_dx x + da_dy y)`, `b_ij(x_c)` likewise, at the CoM position: the
/// rest output is `a(op) op`; a small motion about `op` sees the slope of that static map,
/// `a_ij(op) + da_j (a op)_i` (the DC gain, the response at frequency, a small step in time);
/// and that slope is the one of the rest outputs at neighbouring operating points.
#[test]
fn operating_point_dependence_scales_a_and_b_as_documented() {
    let (da_dx, da_dy, db_dx, db_dy) = (1.5, -0.8, -2.0, 0.5);
    let mut p = plant(&format!(
        "[operating_point_dependence]\nda_dx = {da_dx}\nda_dy = {da_dy}\ndb_dx = {db_dx}\n\
         db_dy = {db_dy}\n"
    ));
    let base = plant("");
    let a = base.pendulum().a;
    let b = base.pendulum().b;
    // At the origin the model's own coefficients.
    for w in [0.0, 3.0, 30.0] {
        assert_eq!(p.frequency_response(w), base.frequency_response(w));
    }
    for op in [[0.06, -0.04], [-0.03, 0.08]] {
        let sa = 1.0 + da_dx * op[0] + da_dy * op[1];
        let sb = 1.0 + db_dx * op[0] + db_dy * op[1];
        p.set_operating_point(op);
        assert_eq!(p.operating_point(), op);
        let da = [da_dx, da_dy];
        let lin = |i: usize, j: usize| a[i][j] * sa + da[j] * (a[i][0] * op[0] + a[i][1] * op[1]);
        // DC gain: G(0) = a_ij(op) + da_j (a op)_i.
        let g0 = p.frequency_response(0.0);
        for i in 0..2 {
            for j in 0..2 {
                let want = lin(i, j);
                assert!(
                    (g0[i][j].re - want).abs() <= 1e-12 * want.abs(),
                    "{op:?} {i}{j}"
                );
                assert!(g0[i][j].im.abs() <= 1e-15);
            }
        }
        // At frequency: (a_lin(op) + b(op) w^2) H(jw).
        for w in [1.0, 10.0, 40.0] {
            let s = Complex64::new(0.0, w);
            let hw = 900.0 / (s * s + 60.0 * s + 900.0);
            let g = p.frequency_response(w);
            for i in 0..2 {
                for j in 0..2 {
                    let want = (lin(i, j) + b[i][j] * sb * w * w) * hw;
                    assert!((g[i][j] - want).norm() <= 1e-12 * want.norm());
                }
            }
        }
        // Rest output and DC gain in the time domain.
        let rest = p.reset(op);
        for i in 0..2 {
            let want = sa * (a[i][0] * op[0] + a[i][1] * op[1]);
            assert!(
                (rest.zmp[i] - want).abs() <= 1e-15,
                "{} vs {want}",
                rest.zmp[i]
            );
        }
        let d = [0.002, -0.001];
        let o = p.advance([op[0] + d[0], op[1] + d[1]], 10_000);
        for i in 0..2 {
            let gain = (o.zmp[i] - rest.zmp[i]) / 1.0;
            let want = lin(i, 0) * d[0] + lin(i, 1) * d[1];
            assert!(
                (gain - want).abs() <= 1e-12,
                "{op:?} output {i}: {gain} vs {want}"
            );
        }
        // The small-signal gain is the slope of the rest ZMP over operating points (central
        // differences; the static map is quadratic, so they are exact up to rounding).
        let eps = 1e-4;
        for j in 0..2 {
            let mut at = |s: f64| {
                let mut o = op;
                o[j] += s;
                p.set_operating_point(o);
                p.reset(o).zmp
            };
            let (hi, lo) = (at(eps), at(-eps));
            for i in 0..2 {
                let slope = (hi[i] - lo[i]) / (2.0 * eps);
                assert!(
                    (slope - g0[i][j].re).abs() <= 1e-9,
                    "{op:?} d zmp_{i}/d op_{j}: {slope} vs G(0) {}",
                    g0[i][j].re
                );
            }
        }
        p.set_operating_point(op);
        p.reset(op);
        // And the time response at frequency matches the scaled frequency response.
        let sim = p.simulated_response(Axis::Y, 10.0, 0.005);
        let g = p.frequency_response(10.0);
        assert_close(sim[0], g[0][1], 0.005, 0.5, "G12 at op");
        assert_close(sim[1], g[1][1], 0.005, 0.5, "G22 at op");
    }
}

// ---------------------------------------------------------------------------------------------
// uncertainty

/// Random realisations of `Delta` are stable and `||Delta||_inf <= |delta|`, on a dense grid;
/// they differ between seeds and are not all constant.
#[test]
fn uncertainty_random_delta_is_stable_and_bounded() {
    let grid: Vec<f64> = (0..3000)
        .map(|k| 10f64.powf(-4.0 + 8.0 * k as f64 / 2999.0))
        .collect();
    let mut dynamic = 0;
    for gain in [1.0, -1.0, 0.37] {
        for seed in 1..=300u64 {
            let d = uncertainty::delta(gain, seed);
            let tau = slowest_time_constant(&d.den);
            assert!(tau.is_finite(), "gain {gain} seed {seed}: unstable {d:?}");
            let peak = grid.iter().map(|&w| d.freq(w).norm()).fold(0.0, f64::max);
            assert!(
                peak <= gain.abs() * (1.0 + 1e-12),
                "gain {gain} seed {seed}: ||Delta|| {peak}"
            );
            if (d.freq(1e-4).norm() - d.freq(1e4).norm()).abs() > 0.01
                || (d.freq(1.0) - d.freq(1e-4)).norm() > 0.01
            {
                dynamic += 1;
            }
        }
    }
    assert!(
        dynamic > 600,
        "only {dynamic} of 900 realisations are dynamic"
    );
    assert_ne!(uncertainty::delta(1.0, 1), uncertainty::delta(1.0, 2));
    // Seed 0 is the constant.
    assert_eq!(
        uncertainty::delta(0.4, 0).freq(3.0),
        Complex64::new(0.4, 0.0)
    );
}

/// Through the plant: `|G/G_nominal - 1| = |W Delta| <= |W| |delta|` on a dense grid, and the
/// time response is the frequency response.
#[test]
fn uncertainty_in_the_plant_is_bounded_and_time_response_matches() {
    let weights = "[uncertainty.G11]\nk = 4.0\nz = 1.0\np = 10.0\n\
                   [uncertainty.G12]\nk = 4.0\nz = 5.0\np = 20.0\n\
                   [uncertainty.G21]\nk = 7.0\nz = 1.0\np = 10.0\n\
                   [uncertainty.G22]\nk = 1.0\nz = 0.1\np = 0.3\n";
    let nominal = plant("");
    for (gain, seed) in [(1.0f64, 3u64), (-1.0, 17), (0.6, 101), (-0.9, 4242)] {
        let mut p = plant(&format!(
            "[uncertainty]\ndelta = {gain}\ndelta_seed = {seed}\n{weights}"
        ));
        let spec_w = spec(&format!("[uncertainty]\n{weights}"));
        for k in 0..2000 {
            let w = 10f64.powf(-3.0 + 6.0 * k as f64 / 1999.0);
            let g = p.frequency_response(w);
            let g0 = nominal.frequency_response(w);
            for ch in Channel::ALL {
                let (i, j) = (ch.output.index(), ch.input.index());
                let v = |n: &str| {
                    spec_w
                        .value("uncertainty", Binding::Channel(ch), n)
                        .unwrap()
                };
                let wt = uncertainty::weight(v("k"), v("z"), v("p")).freq(w);
                let dev = (g[i][j] / g0[i][j] - 1.0).norm();
                assert!(
                    dev <= wt.norm() * gain.abs() * (1.0 + 1e-9),
                    "seed {seed} {ch} at {w}: |W Delta| {dev} > |W| |delta| {}",
                    wt.norm() * gain.abs()
                );
            }
        }
        for omega in [0.3, 3.0, 30.0] {
            let g = p.frequency_response(omega);
            for axis in Axis::BOTH {
                let s = p.simulated_response(axis, omega, 0.01);
                for i in 0..2 {
                    assert_close(
                        s[i],
                        g[i][axis.index()],
                        0.005,
                        0.5,
                        &format!("seed {seed}, {omega} rad/s, output {i} from {axis}"),
                    );
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// tracking_lowpass

/// `reset` puts the plant at rest: stepping the same reference changes nothing, the CoM is the
/// reference, its acceleration zero, and the ZMP is `a x_c` (with every linear effect on).
#[test]
fn tracking_lowpass_reset_is_at_rest_and_zmp_is_a_times_com() {
    let all_linear = "[uncertainty]\ndelta = 0.7\ndelta_seed = 9\nk = 2.0\nz = 1.0\np = 5.0\n\
                      [time_delay]\ndelay = 0.02\n\
                      [structural_mode]\nomega_n = 50.0\nzeta = 0.05\n\
                      [sensor_lowpass]\ncutoff = 40.0\n";
    for extra in ["", all_linear] {
        let mut p = plant(extra);
        let a = p.pendulum().a;
        for r in [[0.0, 0.0], [0.12, -0.03], [-0.2, 0.15]] {
            let rest = p.reset(r);
            for j in 0..2 {
                assert!((rest.com[j] - r[j]).abs() <= 1e-15);
                assert_eq!(rest.com_acceleration[j], 0.0);
            }
            // At rest the ZMP is the DC gain times the CoM: `a x_c` for the nominal model,
            // `a (1 + W(0) Delta(0)) x_c` with the uncertainty.
            let g0 = p.frequency_response(0.0);
            for i in 0..2 {
                let want = g0[i][0].re * r[0] + g0[i][1].re * r[1];
                assert!(
                    (rest.zmp[i] - want).abs() <= 1e-12,
                    "{} vs {want}",
                    rest.zmp[i]
                );
                if extra.is_empty() {
                    let want = a[i][0] * r[0] + a[i][1] * r[1];
                    assert!(
                        (rest.zmp[i] - want).abs() <= 1e-15,
                        "{} vs {want}",
                        rest.zmp[i]
                    );
                }
            }
            for _ in 0..2000 {
                let o = p.step(r);
                for i in 0..2 {
                    assert!((o.zmp[i] - rest.zmp[i]).abs() <= 1e-12, "{o:?} vs {rest:?}");
                    assert!((o.com[i] - r[i]).abs() <= 1e-12);
                    assert!(o.com_acceleration[i].abs() <= 1e-9);
                }
            }
        }
    }
}

/// The CoM follows its reference through `wn^2/(s^2 + 2 zeta wn s + wn^2)`: at `wn` the gain is
/// `1/(2 zeta)` and the phase -90 degrees.
#[test]
fn tracking_lowpass_at_omega_n() {
    for (wn, zeta) in [(30.0, 1.0), (12.0, 0.3), (50.0, 0.7)] {
        let mut p = plant(&format!(
            "[tracking_lowpass.x]\nomega_n = {wn}\nzeta = {zeta}\n\
             [tracking_lowpass.y]\nomega_n = 30.0\nzeta = 1.0\n"
        ));
        let omega = wn;
        let settle = 10.0 * p.slowest_time_constant();
        let (out, t0) = record(&mut p, [0.0; 2], Axis::X, omega, 0.01, settle, 4);
        let com: Vec<f64> = out.iter().map(|o| o.com[0]).collect();
        let g = harmonic(&com, omega, t0) / 0.01;
        let want = Complex64::from_polar(0.5 / zeta, -PI / 2.0);
        assert_close(g, want, 0.005, 0.5, &format!("wn {wn} zeta {zeta}"));
    }
}

/// `slowest_time_constant` is a bound on the slowest linear time constant, also for an
/// overdamped tracking low-pass (zeta > 1), whose slow pole is `wn (zeta - sqrt(zeta^2 - 1))`.
#[test]
fn slowest_time_constant_bounds_the_tracking_lowpass() {
    for zeta in [0.2, 0.7, 1.0, 1.5, 2.0, 5.0] {
        let wn = 10.0;
        let p = plant(&format!(
            "[tracking_lowpass.x]\nomega_n = {wn}\nzeta = {zeta}\n\
             [tracking_lowpass.y]\nomega_n = {wn}\nzeta = {zeta}\n"
        ));
        let exact = slowest_time_constant(&p.tracking_lowpass(Axis::X).tf().den);
        let got = p.slowest_time_constant();
        assert!(
            got >= exact * (1.0 - 1e-9),
            "zeta {zeta}: slowest_time_constant {got} s below the slow pole's {exact} s"
        );
        assert!(
            got <= exact * 1.5,
            "zeta {zeta}: {got} s is far above {exact} s"
        );
    }
}
