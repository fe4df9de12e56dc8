//! Helpers shared by the tests: small designs, robots and an independent complex arithmetic.
#![allow(dead_code)]

use zmp_indep_sim::{AxisName, Design, Noise, Robot};

/// A noise-free, unquantised design with one operating point.
pub fn design(
    op: [f64; 2],
    excited: &[AxisName],
    amplitudes: &[f64],
    omegas: &[f64],
    transient_s: f64,
) -> Design {
    Design {
        name: "test".into(),
        operating_points: vec![op],
        amplitudes: amplitudes.to_vec(),
        omegas: omegas.to_vec(),
        excited: excited.to_vec(),
        transient_s,
        periods: 3.0,
        min_steady_s: 2.0,
        quantisation: 0.0,
        noise: Some(Noise::zero()),
        ..Design::default()
    }
}

/// The seed's nominal robot with distinct servos on the two axes and no noise.
pub fn linear_robot() -> Robot {
    let mut r = Robot::seed_nominal();
    r.axes[0].servo.omega_n = 27.0;
    r.axes[0].servo.zeta = 0.85;
    r.axes[1].servo.omega_n = 35.0;
    r.axes[1].servo.zeta = 1.05;
    r.sensor.noise = Noise::zero();
    r
}

/// `(re, im)` complex product, quotient, modulus: written here, not taken from the crate.
pub fn cmul(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
}
pub fn cdiv(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    let d = b.0 * b.0 + b.1 * b.1;
    ((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
}
pub fn cabs(a: (f64, f64)) -> f64 {
    a.0.hypot(a.1)
}
pub fn csub(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 - b.0, a.1 - b.1)
}

/// First-harmonic phasor `S + jC` of a least-squares fit `y ≈ c + S sin ωt + C cos ωt` over
/// `from ≤ t < to` (normal equations solved by Cramer's rule: independent of the crate's fit).
pub fn phasor(t: &[f64], y: &[f64], omega: f64, from: f64, to: f64) -> (f64, f64) {
    let mut g = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for k in 0..t.len() {
        if t[k] < from - 1e-9 || t[k] >= to - 1e-9 {
            continue;
        }
        let r = [1.0, (omega * t[k]).sin(), (omega * t[k]).cos()];
        for p in 0..3 {
            b[p] += r[p] * y[k];
            for q in 0..3 {
                g[p][q] += r[p] * r[q];
            }
        }
    }
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(g);
    let col = |c: usize| {
        let mut m = g;
        for r in 0..3 {
            m[r][c] = b[r];
        }
        det(m) / d
    };
    (col(1), col(2))
}

/// The phasor of a record's column over its steady window.
pub fn steady(rec: &zmp_indep_sim::RecordData, y: &[f64]) -> (f64, f64) {
    phasor(
        &rec.t,
        y,
        rec.meta.omega,
        rec.meta.steady_start_s,
        rec.meta.steady_end_s(),
    )
}
