//! `structural_mode`: the rest of the path rigid under a share, the peak `1 / (2 zeta)` at
//! `omega_n`.

use crate::support::plant;
use zmp_models::Axis;

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
