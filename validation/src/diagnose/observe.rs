//! What the diagnosis compares: per record, over its steady-state window, the first-harmonic
//! phasors of input and outputs, the third harmonics, and each output's linear trend, with
//! their noise variances from the fit residual.
//!
//! One least-squares regression per signal on `[1, t - t_mid, sin k w t, cos k w t (k = 1..K)]`.
//! Whole periods, so the columns are nearly orthogonal and the trend does not leak into the
//! first harmonic.

use crate::campaign::Record;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use zmp_models::Axis;

/// Harmonics fitted besides the fundamental's neighbours.
pub const HARMONICS: usize = 3;

/// The steady-state summary of one record.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    pub index: usize,
    pub excited: Axis,
    /// Excitation frequency, rad/s.
    pub omega: f64,
    pub operating_point: [f64; 2],
    /// Reference amplitude the campaign commands, m (the describing functions' argument).
    pub nominal_amplitude: f64,
    /// Window used, s.
    pub t0: f64,
    pub t1: f64,
    /// Input first-harmonic phasor (sin-referenced), m.
    pub u1: Complex64,
    /// Output first-harmonic phasors `[zmp_x, zmp_y]`, m.
    pub y1: [Complex64; 2],
    /// Variance of the real (= imaginary) part of each `y1`, m².
    pub y1_var: [f64; 2],
    /// Third-harmonic phasors of the outputs, m.
    pub y3: [Complex64; 2],
    /// Linear trend of each output, m/s, and its variance.
    pub slope: [f64; 2],
    pub slope_var: [f64; 2],
    /// Residual noise standard deviation of each output, m.
    pub noise_std: [f64; 2],
    /// Number of samples in the window.
    pub samples: usize,
}

impl Observation {
    /// Measured frequency response of output `i` from the excited input.
    pub fn g(&self, i: usize) -> Complex64 {
        self.y1[i] / self.u1
    }

    /// Input amplitude, m.
    pub fn amplitude(&self) -> f64 {
        self.u1.norm()
    }

    pub fn duration(&self) -> f64 {
        self.t1 - self.t0
    }
}

struct Fit {
    coef: Vec<f64>,
    /// Diagonal of `(X^T X)^{-1}`.
    inv_diag: Vec<f64>,
    residual_var: f64,
}

fn regress(t: &[f64], y: &[f64], omega: f64, t_mid: f64, k_max: usize) -> Option<Fit> {
    let p = 2 + 2 * k_max;
    let mut xtx = DMatrix::<f64>::zeros(p, p);
    let mut xty = DVector::<f64>::zeros(p);
    let mut row = vec![0.0; p];
    for (&tk, &yk) in t.iter().zip(y) {
        row[0] = 1.0;
        row[1] = tk - t_mid;
        for k in 1..=k_max {
            let (s, c) = (k as f64 * omega * tk).sin_cos();
            row[2 * k] = s;
            row[2 * k + 1] = c;
        }
        for a in 0..p {
            xty[a] += row[a] * yk;
            for b in a..p {
                xtx[(a, b)] += row[a] * row[b];
            }
        }
    }
    for a in 0..p {
        for b in 0..a {
            xtx[(a, b)] = xtx[(b, a)];
        }
    }
    let inv = xtx.try_inverse()?;
    let coef = &inv * &xty;
    let mut sse = 0.0;
    for (&tk, &yk) in t.iter().zip(y) {
        let mut f = coef[0] + coef[1] * (tk - t_mid);
        for k in 1..=k_max {
            let (s, c) = (k as f64 * omega * tk).sin_cos();
            f += coef[2 * k] * s + coef[2 * k + 1] * c;
        }
        sse += (yk - f) * (yk - f);
    }
    let dof = (t.len() as f64 - p as f64).max(1.0);
    Some(Fit {
        coef: coef.iter().copied().collect(),
        inv_diag: (0..p).map(|a| inv[(a, a)]).collect(),
        residual_var: sse / dof,
    })
}

/// Summarises `rec` (the `index`-th record) over whole periods from `steady_start_s` on, at
/// frequency `omega` (the commanded one, or a refined estimate). `None` if fewer than two
/// whole periods remain or the fit is singular.
pub fn observe(rec: &Record, index: usize, steady_start_s: f64, omega: f64) -> Option<Observation> {
    let dt = rec.dt();
    let period = 2.0 * std::f64::consts::PI / omega;
    let i0 = rec.t.iter().position(|&t| t >= rec.t[0] + steady_start_s)?;
    let avail = rec.t[rec.len() - 1] - rec.t[i0];
    let periods = (avail / period).floor();
    if periods < 2.0 {
        return None;
    }
    let n = ((periods * period) / dt).round() as usize;
    let i1 = (i0 + n).min(rec.len());
    let t = &rec.t[i0..i1];
    let t_mid = 0.5 * (t[0] + t[t.len() - 1]);
    let u = regress(t, &rec.input(rec.meta.excited)[i0..i1], omega, t_mid, 1)?;
    let mut obs = Observation {
        index,
        excited: rec.meta.excited,
        omega,
        operating_point: rec.meta.operating_point,
        nominal_amplitude: rec.meta.amplitude,
        t0: t[0],
        t1: t[t.len() - 1],
        u1: Complex64::new(u.coef[2], u.coef[3]),
        y1: [Complex64::new(0.0, 0.0); 2],
        y1_var: [0.0; 2],
        y3: [Complex64::new(0.0, 0.0); 2],
        slope: [0.0; 2],
        slope_var: [0.0; 2],
        noise_std: [0.0; 2],
        samples: t.len(),
    };
    for (i, axis) in Axis::BOTH.into_iter().enumerate() {
        let f = regress(t, &rec.output(axis)[i0..i1], omega, t_mid, HARMONICS)?;
        obs.y1[i] = Complex64::new(f.coef[2], f.coef[3]);
        obs.y1_var[i] = f.residual_var * 0.5 * (f.inv_diag[2] + f.inv_diag[3]);
        obs.y3[i] = Complex64::new(f.coef[6], f.coef[7]);
        obs.slope[i] = f.coef[1];
        obs.slope_var[i] = f.residual_var * f.inv_diag[1];
        obs.noise_std[i] = f.residual_var.sqrt();
    }
    (obs.u1.norm() > 0.0).then_some(obs)
}
