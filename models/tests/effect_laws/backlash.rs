//! `backlash`: no motion below the half width, the amplitude minus the play above it, and
//! the describing function against the simulation.

use crate::support::{plant, record, whole_period, G11, G21, H};
use num_complex::Complex64;
use zmp_models::effects::backlash;
use zmp_models::Axis;

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
