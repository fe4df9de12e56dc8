//! `sensor_drift`: offset plus rate times t, the first harmonic kept.

use crate::harmonic;
use crate::support::{plant, whole_period, H};
use num_complex::Complex64;

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

/// A sensor re-zeroed at every record whose drift rate changes from record to record
/// (`rate_spread > 0`): in record `k` the reading is `zmp + offset + r_k t` exactly, t from the
/// record's start, with `r_k` the documented draw (`rate + rate_spread z_k`, z_k the first
/// standard normal number of ChaCha8 seeded with `rate_seed`, stream `2k + axis`, computed
/// here with `rand_distr`); the records' rates differ, and over 400 records their mean and
/// standard deviation are those of the law (each within its 99.9 % sampling interval:
/// `3.29 spread / sqrt(n)` for the mean, `3.29 spread / sqrt(2 (n - 1))` for the standard
/// deviation). The first harmonic fitted with a trend is the drift-free plant's in every record.
/// With `rate_spread = 0` every record drifts at `rate`, bit for bit the law before the spread.
#[test]
fn sensor_drift_per_record_draws_each_records_rate_from_its_law() {
    use rand::SeedableRng;
    use rand_distr::Distribution;
    let (offset, rate, spread, seed) = (0.001, 1e-4, 3e-4, 77u64);
    let text = format!(
        "[sensor_drift]\noffset = {offset}\nrate = {rate}\nrate_spread = {spread}\n\
         rate_seed = {seed}\n"
    );
    let mut base = plant("");
    let mut p = plant(&text);
    let drawn = |axis: u64, k: u64| {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(2 * k + axis);
        let z: f64 = rand_distr::StandardNormal.sample(&mut rng);
        rate + spread * z
    };
    let (omega, per) = whole_period(2.0);
    let op = [0.02, -0.01];
    for k in [0u64, 1, 2, 17] {
        p.set_record(k);
        base.reset(op);
        p.reset(op);
        let (mut y0, mut y1) = (Vec::new(), Vec::new());
        let n = 6 * per;
        for s in 1..=n {
            let t = s as f64 * H;
            let r = [op[0] + 0.006 * (omega * t).sin(), op[1]];
            let (o0, o1) = (base.step(r), p.step(r));
            for i in 0..2 {
                let want = offset + drawn(i as u64, k) * t;
                assert!(
                    (o1.zmp[i] - o0.zmp[i] - want).abs() <= 1e-14,
                    "record {k}, axis {i}, t = {t}"
                );
            }
            if s > n - 4 * per {
                y0.push(o0.zmp[1]);
                y1.push(o1.zmp[1]);
            }
        }
        let t0 = (n - 4 * per + 1) as f64 * H;
        let (p0, p1) = (
            harmonic(&y0, omega, t0),
            harmonic_with_trend(&y1, omega, t0),
        );
        assert!(
            (p1 - p0).norm() <= 1e-9 * p0.norm(),
            "record {k}: {p1} vs {p0}"
        );
    }
    assert_ne!(drawn(0, 1), drawn(0, 2));
    assert_ne!(drawn(0, 1), drawn(1, 1));
    // The spread of the rates over many records.
    let n = 400u64;
    let rates: Vec<f64> = (0..n)
        .map(|k| {
            p.set_record(k);
            p.reset(op);
            // The drift after one step of 1 ms is the record's rate times H.
            (p.step(op).zmp[0] - p.reset(op).zmp[0]) / H
        })
        .collect();
    let mean = rates.iter().sum::<f64>() / n as f64;
    let sd = (rates.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
    let z = 3.29;
    assert!(
        (mean - rate).abs() <= z * spread / (n as f64).sqrt(),
        "mean {mean}"
    );
    assert!(
        (sd - spread).abs() <= z * spread / (2.0 * (n - 1) as f64).sqrt(),
        "sd {sd}"
    );
    // No spread: one rate, bit for bit.
    let mut one = plant(&format!(
        "[sensor_drift]\noffset = {offset}\nrate = {rate}\n"
    ));
    let mut zero = plant(&format!(
        "[sensor_drift]\noffset = {offset}\nrate = {rate}\nrate_spread = 0.0\nrate_seed = 5\n"
    ));
    for k in [0u64, 3] {
        zero.set_record(k);
        one.reset(op);
        zero.reset(op);
        for s in 1..=1000 {
            let r = [op[0] + 0.004 * (0.01 * s as f64).sin(), op[1]];
            assert_eq!(one.step(r), zero.step(r));
        }
    }
}
