//! First-harmonic estimation: the phasor of a sampled signal at a known frequency.
//!
//! Convention used throughout: a signal `c + |P| sin(omega t + arg P)` has phasor `P`, so the
//! ratio of output to input phasors is the frequency response `G(j omega)`.

use nalgebra::{Matrix3, Vector3};
use num_complex::Complex64;

/// Least-squares fit of `c + alpha sin(omega t) + beta cos(omega t)` to samples
/// `y[k]` at `t0 + k dt`; returns `alpha + j beta`. Use whole periods for the best conditioning.
pub fn first_harmonic(y: &[f64], omega: f64, dt: f64, t0: f64) -> Complex64 {
    let mut m = Matrix3::<f64>::zeros();
    let mut r = Vector3::<f64>::zeros();
    for (k, &yk) in y.iter().enumerate() {
        let t = t0 + k as f64 * dt;
        let (s, c) = (omega * t).sin_cos();
        let phi = Vector3::new(1.0, s, c);
        m += phi * phi.transpose();
        r += phi * yk;
    }
    match m.lu().solve(&r) {
        Some(x) => Complex64::new(x[1], x[2]),
        None => Complex64::new(f64::NAN, f64::NAN),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_phasor() {
        let (w, dt) = (2.0, 0.01);
        let y: Vec<f64> = (0..1000)
            .map(|k| 0.3 + 1.5 * (w * (0.2 + k as f64 * dt) + 0.4).sin())
            .collect();
        let p = first_harmonic(&y, w, dt, 0.2);
        assert!((p.norm() - 1.5).abs() < 1e-9);
        assert!((p.arg() - 0.4).abs() < 1e-9);
    }
}
