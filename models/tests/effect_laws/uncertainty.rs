//! `uncertainty`: random realisations of `Delta` stable and bounded, alone and in the plant.

use crate::assert_close;
use crate::support::{plant, spec};
use num_complex::Complex64;
use zmp_models::effects::uncertainty;
use zmp_models::lti::slowest_time_constant;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, Channel};

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
                        .value(EffectKind::Uncertainty, Binding::Channel(ch), n)
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
