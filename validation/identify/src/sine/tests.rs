//! The harmonic regression against dense least squares and finite differences.

use super::*;

/// A sine with harmonics and a deterministic pseudo-noise, `n` samples.
pub(super) fn signal(n: usize, omega: f64, dt: f64, phase: f64) -> Vec<f64> {
    (0..n)
        .map(|k| {
            let t = k as f64 * dt;
            let noise = ((k as f64 * 12.9898).sin() * 43758.5453).fract() - 0.5;
            0.3 + (omega * t + phase).sin()
                + 0.05 * (3.0 * omega * t + 0.2).sin()
                + 0.02 * (2.0 * omega * t).cos()
                + 0.01 * noise
        })
        .collect()
}

/// The fit with the normal matrix summed sample by sample, solved densely.
fn brute_force(y: &[f64], omega: f64, dt: f64, k: usize) -> (Vec<f64>, f64) {
    let m = 1 + 2 * k;
    let mut ata = nalgebra::DMatrix::<f64>::zeros(m, m);
    let mut aty = nalgebra::DVector::<f64>::zeros(m);
    let mut yy = 0.0;
    for (i, &yi) in y.iter().enumerate() {
        let x = omega * i as f64 * dt;
        let phi = nalgebra::DVector::from_fn(m, |a, _| match a {
            0 => 1.0,
            a if a % 2 == 1 => (a.div_ceil(2) as f64 * x).sin(),
            a => ((a / 2) as f64 * x).cos(),
        });
        ata += &phi * phi.transpose();
        aty += &phi * yi;
        yy += yi * yi;
    }
    let x = ata.cholesky().unwrap().solve(&aty);
    (x.iter().copied().collect(), yy - x.dot(&aty))
}

#[test]
fn closed_form_normal_matrix_matches_summation() {
    let (dt, omega) = (0.005, 3.7);
    for (n, k) in [(2000usize, 3usize), (777, 1), (5003, 5)] {
        let y = signal(n, omega * 1.001, dt, 0.4);
        let fit = harmonic_fit([&y[..]], omega, dt, k).unwrap();
        let (x, rss) = brute_force(&y, omega, dt, k);
        for h in 0..k {
            let got = fit.harmonics[0][h];
            let want = Complex64::new(x[1 + 2 * h], x[2 + 2 * h]);
            assert!(
                (got - want).norm() < 1e-9,
                "n {n} k {k} h {h}: {got} vs {want}"
            );
        }
        assert!(
            (fit.rss[0] - rss).abs() < 1e-8 * fit.yy[0],
            "{} vs {rss}",
            fit.rss[0]
        );
    }
}

#[test]
fn trend_column_matches_a_dense_fit_and_keeps_a_ramp_out_of_the_harmonics() {
    let (dt, omega, n) = (0.005, 1.3, 3001);
    let ramp = 4e-4;
    let clean = signal(n, omega, dt, 0.4);
    let y: Vec<f64> = clean
        .iter()
        .enumerate()
        .map(|(k, v)| v + ramp * k as f64 * dt)
        .collect();
    let k = 3;
    let fit = harmonic_fit_trend([&y[..]], omega, dt, k).unwrap();
    // Dense least squares on [1, t - t_mid, sin, cos ...].
    let m = 2 + 2 * k;
    let c = (n as f64 - 1.0) / 2.0;
    let mut ata = nalgebra::DMatrix::<f64>::zeros(m, m);
    let mut aty = nalgebra::DVector::<f64>::zeros(m);
    for (i, &yi) in y.iter().enumerate() {
        let x = omega * i as f64 * dt;
        let phi = nalgebra::DVector::from_fn(m, |a, _| match a {
            0 => 1.0,
            1 => (i as f64 - c) * dt,
            a if a % 2 == 0 => ((a / 2) as f64 * x).sin(),
            a => (((a - 1) / 2) as f64 * x).cos(),
        });
        ata += &phi * phi.transpose();
        aty += &phi * yi;
    }
    let x = ata.clone().cholesky().unwrap().solve(&aty);
    assert!(
        (fit.trend[0] - x[1]).abs() < 1e-9,
        "{} vs {}",
        fit.trend[0],
        x[1]
    );
    assert!((fit.dc[0] - x[0]).abs() < 1e-9);
    for h in 0..k {
        let want = Complex64::new(x[2 + 2 * h], x[3 + 2 * h]);
        assert!((fit.harmonics[0][h] - want).norm() < 1e-9, "h {h}");
    }
    // The trend's variance factor equals the dense inverse's entry.
    let inv = ata.try_inverse().unwrap();
    assert!((fit.inv_diag_trend - inv[(1, 1)]).abs() < 1e-6 * inv[(1, 1)]);
    assert!((fit.inv_diag_h1[0] - inv[(2, 2)]).abs() < 1e-6 * inv[(2, 2)]);
    // The ramp is recovered and does not move the fundamental: the same as without it.
    // (within four standard errors of the pseudo-noise: 1.2e-5)
    assert!((fit.trend[0] - ramp).abs() < 5e-5, "trend {}", fit.trend[0]);
    let plain = harmonic_fit_trend([&clean[..]], omega, dt, k).unwrap();
    assert!((fit.harmonics[0][0] - plain.harmonics[0][0]).norm() < 1e-9);
    // Without the trend column the ramp biases the fundamental by about 2 r / omega.
    let biased = harmonic_fit([&y[..]], omega, dt, k).unwrap();
    assert!((biased.harmonics[0][0] - plain.harmonics[0][0]).norm() > 2e-4);
}

#[test]
fn cost_derivatives_match_finite_differences() {
    let (dt, omega, n) = (0.005, 2.3, 4000);
    let y1 = signal(n, omega * 1.0007, dt, 0.1);
    let y2: Vec<f64> = signal(n, omega * 1.0007, dt, 1.3)
        .iter()
        .map(|v| 0.4 * v)
        .collect();
    let sig = [&y1[..], &y2[..]];
    let (f0, d1, d2) = harmonic_fit_with_slope(sig, omega, dt, 3, None).unwrap();
    let h = 1e-4;
    let c = |w: f64| harmonic_fit(sig, w, dt, 3).unwrap().cost();
    let fd1 = (c(omega + h) - c(omega - h)) / (2.0 * h);
    let fd2 = (c(omega + h) - 2.0 * f0.cost() + c(omega - h)) / (h * h);
    assert!(
        (d1 - fd1).abs() < 1e-4 * fd1.abs().max(1.0),
        "{d1} vs {fd1}"
    );
    assert!((d2 - fd2).abs() < 1e-3 * fd2.abs(), "{d2} vs {fd2}");
    // The Newton step lands on the minimum of the cost.
    let (w, moved) = refine_frequency(sig, [0.0; 2], omega, dt, 3).unwrap();
    let (lo, hi) = (c(w - 1e-4), c(w + 1e-4));
    assert!(c(w) <= lo && c(w) <= hi, "{w}: {lo} {} {hi}", c(w));
    assert!(moved.is_some(), "the frequency was off by 0.07 %");
}

#[test]
fn refinement_on_the_detrended_signals_from_one_pass_each() {
    // Two ramps of different slopes on two off-frequency signals.
    let (dt, omega, n) = (0.005, 2.3, 4001);
    let ramp = [3e-3, -1.2e-3];
    let ys: Vec<Vec<f64>> = (0..2)
        .map(|j| {
            signal(n, omega * 1.0006, dt, 0.1 + j as f64)
                .iter()
                .enumerate()
                .map(|(k, v)| v + ramp[j] * k as f64 * dt)
                .collect()
        })
        .collect();
    let sig = [&ys[0][..], &ys[1][..]];
    let first = harmonic_fit_trend(sig, omega, dt, 3).unwrap();
    // The same ramps taken out by hand, the way the refinement takes them out.
    let c = (n as f64 - 1.0) / 2.0;
    let detrended: Vec<Vec<f64>> = (0..2)
        .map(|j| {
            let r = first.trend[j] * dt;
            sig[j]
                .iter()
                .enumerate()
                .map(|(k, y)| y - r * (k as f64 - c))
                .collect()
        })
        .collect();
    let dsig = [&detrended[0][..], &detrended[1][..]];
    let (w, moved) = refine_frequency(sig, first.trend, omega, dt, 3).unwrap();
    let (w_hand, _) = refine_frequency(dsig, [0.0; 2], omega, dt, 3).unwrap();
    assert!((w - w_hand).abs() < 1e-12, "{w} against {w_hand}");
    assert!((w - omega * 1.0006).abs() < 1e-4 * omega, "{w}");
    // The fit it returns is the trend fit at the new frequency of the signals as they are.
    let got = moved.expect("moved");
    let want = harmonic_fit_trend(sig, w, dt, 3).unwrap();
    for j in 0..2 {
        assert!((got.trend[j] - want.trend[j]).abs() < 1e-12);
        assert!((got.rss[j] - want.rss[j]).abs() < 1e-9 * want.yy[j]);
        for h in 0..3 {
            assert!((got.harmonics[j][h] - want.harmonics[j][h]).norm() < 1e-12);
        }
    }
    // And the cost it checked the step with is the plain fit's on the detrended signals.
    let pass = dispatch(
        sig,
        w,
        dt,
        3,
        Mode::Trend,
        Some(first.trend.map(|r| r * dt)),
    )
    .unwrap();
    let plain = harmonic_fit(dsig, w, dt, 3).unwrap().cost();
    let cost = pass.detrended_cost.unwrap();
    assert!(
        (cost - plain).abs() < 1e-9 * plain.max(1e-12),
        "{cost} against {plain}"
    );
}
