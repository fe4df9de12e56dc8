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
