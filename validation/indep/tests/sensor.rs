//! The measurement: drift, noise statistics, quantisation, determinism.

mod common;
use common::*;
use zmp_indep_sim::{simulate, simulate_records, AxisName, Design, Noise};

#[test]
fn drift_adds_exactly_rate_times_t() {
    let plain = linear_robot();
    let mut drifting = linear_robot();
    let rate = [3e-4, -1e-4];
    drifting.sensor.drift_rate = rate;
    let d = design([0.01, 0.0], &[AxisName::X], &[0.004], &[2.0], 1.0);
    let (a, b) = (&simulate(&plain, &d)[0], &simulate(&drifting, &d)[0]);
    for k in 0..a.t.len() {
        for (i, (ca, cb)) in [(&a.zmp_x, &b.zmp_x), (&a.zmp_y, &b.zmp_y)]
            .into_iter()
            .enumerate()
        {
            let got = cb[k] - ca[k];
            assert!(
                (got - rate[i] * a.t[k]).abs() < 1e-12,
                "t = {}: drift {got} != {}",
                a.t[k],
                rate[i] * a.t[k]
            );
        }
    }
}

/// A long record at rest-like excitation whose noise is `measured − noise-free`.
fn noise_record(
    noise: Noise,
    quantisation: f64,
    seconds: f64,
    seed: u64,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let robot = linear_robot();
    let d = Design {
        noise: Some(noise),
        quantisation,
        seed,
        transient_s: 0.0,
        periods: 1.0,
        min_steady_s: seconds,
        ..design([0.0, 0.0], &[AxisName::X], &[1e-3], &[1.0], 0.0)
    };
    let rec = simulate(&robot, &d).remove(0);
    let res_x: Vec<f64> = rec
        .zmp_x
        .iter()
        .zip(&rec.truth.zmp_noise_free[0])
        .map(|(m, c)| m - c)
        .collect();
    let res_y: Vec<f64> = rec
        .zmp_y
        .iter()
        .zip(&rec.truth.zmp_noise_free[1])
        .map(|(m, c)| m - c)
        .collect();
    (res_x, res_y, rec.zmp_x)
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}
fn variance(v: &[f64]) -> f64 {
    let m = mean(v);
    v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64
}
fn autocorrelation(v: &[f64], lag: usize) -> f64 {
    let m = mean(v);
    let num: f64 = v.windows(lag + 1).map(|w| (w[0] - m) * (w[lag] - m)).sum();
    let den: f64 = v.iter().map(|x| (x - m).powi(2)).sum();
    num / den
}

#[test]
fn white_noise_has_its_variance_and_no_memory() {
    let sigma = 5e-4;
    let (x, y, _) = noise_record(
        Noise {
            white_std: sigma,
            coloured_std: 0.0,
            coloured_tau: 1.0,
        },
        0.0,
        200.0,
        7,
    );
    for v in [&x, &y] {
        let n = v.len() as f64;
        assert!(mean(v).abs() < 4.0 * sigma / n.sqrt(), "mean {}", mean(v));
        let ratio = variance(v) / (sigma * sigma);
        assert!(
            (ratio - 1.0).abs() < 4.0 * (2.0 / n).sqrt(),
            "variance ratio {ratio}"
        );
        for lag in [1, 5] {
            let r = autocorrelation(v, lag);
            assert!(r.abs() < 4.0 / n.sqrt(), "lag-{lag} autocorrelation {r}");
        }
    }
    let cross =
        x.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>() / (x.len() as f64 * sigma * sigma);
    assert!(
        cross.abs() < 4.0 / (x.len() as f64).sqrt(),
        "x and y noise correlated: {cross}"
    );
}

#[test]
fn coloured_noise_has_its_variance_and_correlation_time() {
    let (sigma, tau): (f64, f64) = (3e-4, 0.2);
    let dt = 1.0 / 200.0;
    let phi = (-dt / tau).exp();
    let mut x = Vec::new();
    for seed in 0..4 {
        let (a, b, _) = noise_record(
            Noise {
                white_std: 0.0,
                coloured_std: sigma,
                coloured_tau: tau,
            },
            0.0,
            150.0,
            seed,
        );
        x.push(a);
        x.push(b);
    }
    // Eight independent 150 s records: about 8 × 150 / (2 τ) = 3000 independent samples.
    let all: Vec<f64> = x.concat();
    let n_eff = all.len() as f64 * (1.0 - phi) / (1.0 + phi);
    assert!(
        mean(&all).abs() < 4.0 * sigma / n_eff.sqrt(),
        "mean {}",
        mean(&all)
    );
    let ratio = x.iter().map(|v| variance(v)).sum::<f64>() / x.len() as f64 / (sigma * sigma);
    assert!((ratio - 1.0).abs() < 0.1, "variance ratio {ratio}");
    for (lag, tol) in [(1usize, 0.01), (40, 0.06)] {
        let r = x.iter().map(|v| autocorrelation(v, lag)).sum::<f64>() / x.len() as f64;
        let want = (-(lag as f64) * dt / tau).exp();
        assert!(
            (r - want).abs() < tol,
            "lag {lag}: autocorrelation {r}, want {want}"
        );
    }
}

#[test]
fn white_and_coloured_add_and_quantisation_rounds_to_its_grid() {
    let (w, c, q) = (4e-4, 2e-4, 1e-4);
    let (x, _, measured) = noise_record(
        Noise {
            white_std: w,
            coloured_std: c,
            coloured_tau: 0.3,
        },
        q,
        200.0,
        3,
    );
    let want = w * w + c * c + q * q / 12.0;
    let ratio = variance(&x) / want;
    assert!((ratio - 1.0).abs() < 0.1, "variance ratio {ratio}");
    for m in &measured {
        let k = m / q;
        assert!((k - k.round()).abs() < 1e-6, "{m} is not on the {q} grid");
    }
}

#[test]
fn a_seed_gives_the_same_records_and_each_record_its_own_stream() {
    let mut robot = linear_robot();
    robot.sensor.noise = Noise {
        white_std: 5e-4,
        coloured_std: 2e-4,
        coloured_tau: 0.5,
    };
    let d = Design {
        noise: None,
        quantisation: 1e-4,
        seed: 11,
        ..design(
            [0.0, 0.0],
            &[AxisName::X, AxisName::Y],
            &[0.003],
            &[1.0, 4.0],
            1.0,
        )
    };
    let a = simulate(&robot, &d);
    let b = simulate(&robot, &d);
    for (ra, rb) in a.iter().zip(&b) {
        assert_eq!(ra.zmp_x, rb.zmp_x);
        assert_eq!(ra.zmp_y, rb.zmp_y);
    }
    // Record 3 alone equals record 3 of the campaign: its noise does not depend on the others.
    let alone = simulate_records(&robot, &d, &d.records()[3..4]);
    assert_eq!(alone[0].zmp_x, a[3].zmp_x);
    // Another noise seed changes the noise, not the physics.
    let other = simulate(
        &robot,
        &Design {
            seed: 12,
            ..d.clone()
        },
    );
    assert_ne!(other[0].zmp_x, a[0].zmp_x);
    assert_eq!(other[0].truth.zmp_noise_free, a[0].truth.zmp_noise_free);
}
