//! The residual, its bins near zero frequency and the harmonics taken out, against direct sums.

use super::super::super::sine::harmonic_fit_trend;
use super::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// First-order filtered (pole in [0, 1): 0 is white) Gaussian noise of the given standard
/// deviation, on a sine with a third harmonic and a ramp.
fn noisy(n: usize, omega: f64, dt: f64, std: f64, pole: f64, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let g = Normal::new(0.0, 1.0).unwrap();
    let scale = std * (1.0 - pole * pole).sqrt();
    let mut e = 0.0;
    (0..n)
        .map(|k| {
            let t = k as f64 * dt;
            e = pole * e + scale * g.sample(&mut rng);
            0.004 * (omega * t).sin() + 0.0005 * (3.0 * omega * t).cos() + 2e-4 * t + e
        })
        .collect()
}

/// The residual of `fit` evaluated term by term with exact sines.
fn direct_residual(y: &[f64], fit: &HarmonicFit<1>, omega: f64, dt: f64) -> Vec<f64> {
    let n = y.len();
    let c = (n as f64 - 1.0) / 2.0;
    (0..n)
        .map(|k| {
            let mut f = fit.dc[0] + fit.trend[0] * (k as f64 - c) * dt;
            for (h, p) in fit.harmonics[0].iter().enumerate() {
                let (sn, cs) = ((h + 1) as f64 * omega * k as f64 * dt).sin_cos();
                f += p.re * sn + p.im * cs;
            }
            y[k] - f
        })
        .collect()
}

#[test]
fn goertzel_power_matches_a_direct_sum() {
    // A slow ramp, an offset and a tone (harder than a residual, whose mean and trend are
    // fitted out); angles from a few bins of a long record up to near Nyquist. A bin's
    // power scatters by 100 % (an exponential variable): 1e-7 is far below what matters.
    for n in [7usize, 3000, 20000] {
        let x: Vec<f64> = (0..n)
            .map(|k| {
                1e-3 * k as f64 / n as f64
                    + (0.37 * k as f64).sin()
                    + ((k * 7919) % 13) as f64 * 0.01
            })
            .collect();
        let angles: Vec<f64> = [3.0, 4.5, 10.0]
            .iter()
            .map(|m| 2.0 * PI * m / n as f64)
            .chain([0.37, 0.4, 3.1])
            .collect();
        let got: Vec<f64> = angles
            .chunks(GROUP)
            .flat_map(|g| goertzel_power(&x, g))
            .collect();
        for (a, p) in angles.iter().zip(&got) {
            let (mut re, mut im) = (0.0, 0.0);
            for (k, xk) in x.iter().enumerate() {
                let (s, c) = (a * k as f64).sin_cos();
                re += xk * c;
                im -= xk * s;
            }
            let want = re * re + im * im;
            let scale = x.iter().map(|v| v * v).sum::<f64>();
            assert!(
                (p - want).abs() <= 1e-7 * want + 1e-12 * scale,
                "n {n} angle {a}: {p} against {want}"
            );
        }
    }
}

#[test]
fn the_residual_and_its_bins_match_direct_sums() {
    // What the recursions (harmonics, Goertzel) must give, on whole and fractional periods.
    for (n, omega) in [(6000usize, 2.0), (3771, 2.3), (1200, 15.0)] {
        let dt = 0.005;
        let y = noisy(n, omega, dt, 5e-4, 0.6, 7);
        let fit = harmonic_fit_trend([&y[..]], omega, dt, 3).unwrap();
        let e = residuals([&y[..]], &fit, omega, dt, n);
        let want = direct_residual(&y, &fit, omega, dt);
        for k in 0..n {
            assert!((e[k] - want[k]).abs() < 1e-12, "n {n} sample {k}");
        }
        let bins = zero_bin_frequencies(n, dt, omega);
        assert!(!bins.is_empty());
        let [powers] = bin_powers::<1>(&e, n, &bins, dt);
        for (&w, &p) in bins.iter().zip(&powers) {
            let (mut re, mut im) = (0.0, 0.0);
            for (k, ek) in want.iter().enumerate() {
                let (sn, cs) = (w * k as f64 * dt).sin_cos();
                re += ek * cs;
                im -= ek * sn;
            }
            let direct = (re * re + im * im) / n as f64;
            assert!(
                (p - direct).abs() <= 1e-6 * direct,
                "n {n} omega {omega} bin {w}: {p:e} against {direct:e}"
            );
        }
    }
}

#[test]
fn bins_near_zero_avoid_every_harmonic_and_see_white_noise_as_its_variance() {
    // Three whole periods: the harmonics are bins 3, 6, 9, ...; none of them is taken, however
    // high (a play's odd harmonics reach far beyond the fitted three).
    let (dt, omega) = (0.005, 0.5);
    let n = (3.0 * 2.0 * PI / omega / dt).round() as usize;
    let res = 2.0 * PI / (n as f64 * dt);
    let bins = zero_bin_frequencies(n, dt, omega);
    assert_eq!(bins.len(), BINS);
    for w in &bins {
        let m = (w / res).round() as usize;
        assert!(m >= 3 && !m.is_multiple_of(3), "bin {m} of {bins:?}");
    }
    // White noise: every bin's power per sample is the variance (an exponential variable
    // each: 40 records x 8 bins give the mean to about 6 %).
    let mut ratios = Vec::new();
    for seed in 0..40 {
        let y = noisy(n, omega, dt, 5e-4, 0.0, seed);
        let fit = harmonic_fit_trend([&y[..]], omega, dt, 3).unwrap();
        let e = residuals([&y[..]], &fit, omega, dt, n);
        let [p] = bin_powers::<1>(&e, n, &bins, dt);
        ratios.extend(p.iter().map(|v| v / 25e-8));
    }
    let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
    assert!((mean - 1.0).abs() < 0.2, "{mean}");
}

#[test]
fn harmonics_above_the_fitted_ones_are_taken_out() {
    // A square-like wave (odd harmonics to the 15th) at a period of no whole number of
    // samples, fitted with three harmonics: its residual keeps the 5th to the 15th;
    // `remove_harmonics` leaves less than a thousandth of them.
    let (dt, omega) = (0.005, 7.3);
    let per = 2.0 * PI / (omega * dt);
    let n = (9.0 * per).round() as usize;
    let y: Vec<f64> = (0..n)
        .map(|k| {
            let t = k as f64 * dt;
            (1..=15)
                .step_by(2)
                .map(|h| 0.01 / h as f64 * (h as f64 * omega * t + 0.2).sin())
                .sum()
        })
        .collect();
    let fit = harmonic_fit_trend([&y[..]], omega, dt, 3).unwrap();
    let mut e = residuals([&y[..]], &fit, omega, dt, n);
    let before = e.iter().map(|v| v * v).sum::<f64>();
    remove_harmonics::<1>(&mut e, n, omega, dt, 4, CLEAN_HARMONICS);
    let after = e.iter().map(|v| v * v).sum::<f64>();
    assert!(
        after < 1e-3 * before,
        "residual power {after:e} of {before:e} left"
    );
}
