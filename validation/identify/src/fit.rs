//! The pendulum fit (Levenberg-Marquardt on the complex gains, jointly with the tracking
//! low-pass) and the uncertainty-weight envelope fit.

use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// One measured gain: channel `(i, j)`, frequency, value, per-component standard deviation,
/// and a fixed complex factor of the model (extra linear effects of a start model; 1 if none).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Point {
    pub i: usize,
    pub j: usize,
    pub omega: f64,
    pub g: Complex64,
    pub sigma: f64,
    pub factor: Complex64,
}

/// Parameters in fit order: a11 a12 a21 a22 b11 b12 b21 b22 omega_n zeta.
pub(crate) const NP: usize = 10;

pub(crate) fn lowpass(omega: f64, wn: f64, zeta: f64) -> Complex64 {
    let wn2 = wn * wn;
    Complex64::new(wn2, 0.0) / Complex64::new(wn2 - omega * omega, 2.0 * zeta * wn * omega)
}

pub(crate) fn model(p: &[f64; NP], pt: &Point) -> Complex64 {
    let c = 2 * pt.i + pt.j;
    (p[c] + p[4 + c] * pt.omega * pt.omega) * lowpass(pt.omega, p[8], p[9]) * pt.factor
}

/// Result of the weighted fit.
#[derive(Debug, Clone)]
pub(crate) struct LmResult {
    pub params: [f64; NP],
    pub stderr: [f64; NP],
    pub chi2: f64,
    pub dof: usize,
    #[allow(dead_code)]
    pub converged: bool,
}

fn residuals_jacobian(
    p: &[f64; NP],
    pts: &[Point],
    free: &[usize],
) -> (DVector<f64>, DMatrix<f64>) {
    let m = 2 * pts.len();
    let mut r = DVector::zeros(m);
    let mut jac = DMatrix::zeros(m, free.len());
    for (k, pt) in pts.iter().enumerate() {
        let c = 2 * pt.i + pt.j;
        let h = lowpass(pt.omega, p[8], p[9]);
        let pend = p[c] + p[4 + c] * pt.omega * pt.omega;
        let g = pend * h * pt.factor;
        let e = (pt.g - g) / pt.sigma;
        r[2 * k] = e.re;
        r[2 * k + 1] = e.im;
        // d(model)/d(theta), model residual is (meas - model)/sigma: Jacobian of the model/sigma.
        let s2 = Complex64::new(-pt.omega * pt.omega, 0.0);
        let jw = Complex64::new(0.0, pt.omega);
        let den = s2 + 2.0 * p[9] * p[8] * jw + p[8] * p[8];
        // H = wn^2 / den; dH/dwn = (2 wn den - wn^2 (2 zeta jw + 2 wn)) / den^2
        let dh_dwn =
            (2.0 * p[8] * den - p[8] * p[8] * (2.0 * p[9] * jw + 2.0 * p[8])) / (den * den);
        let dh_dz = -(p[8] * p[8]) * (2.0 * p[8] * jw) / (den * den);
        for (col, &q) in free.iter().enumerate() {
            let d = if q == c {
                h * pt.factor
            } else if q == 4 + c {
                h * pt.factor * pt.omega * pt.omega
            } else if q == 8 {
                pend * dh_dwn * pt.factor
            } else if q == 9 {
                pend * dh_dz * pt.factor
            } else {
                Complex64::new(0.0, 0.0)
            };
            jac[(2 * k, col)] = d.re / pt.sigma;
            jac[(2 * k + 1, col)] = d.im / pt.sigma;
        }
    }
    (r, jac)
}

/// Levenberg-Marquardt on the parameters `free` (the others stay at `p0`). Standard errors from
/// `(J^T W J)^-1`, scaled by the reduced chi-square when it exceeds one.
pub(crate) fn levenberg_marquardt(p0: [f64; NP], pts: &[Point], free: &[usize]) -> LmResult {
    let mut p = p0;
    let (mut r, mut jac) = residuals_jacobian(&p, pts, free);
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let mut converged = false;
    for _ in 0..200 {
        let jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * &r;
        let mut improved = false;
        for _ in 0..30 {
            let mut a = jtj.clone();
            for d in 0..free.len() {
                a[(d, d)] += lambda * jtj[(d, d)].max(1e-30);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&jtr)) else {
                lambda *= 10.0;
                continue;
            };
            let mut q = p;
            for (col, &k) in free.iter().enumerate() {
                q[k] += step[col];
            }
            // Keep the low-pass physical.
            if q[8] <= 0.0 || q[9] <= 0.0 {
                lambda *= 10.0;
                continue;
            }
            let (rq, jq) = residuals_jacobian(&q, pts, free);
            let cq = rq.norm_squared();
            if cq < cost {
                let rel = (cost - cq) / cost.max(1e-300);
                p = q;
                r = rq;
                jac = jq;
                cost = cq;
                lambda = (lambda / 3.0).max(1e-12);
                improved = true;
                if rel < 1e-12 {
                    converged = true;
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            converged = true;
        }
        if converged {
            break;
        }
    }
    let m = 2 * pts.len();
    let dof = m.saturating_sub(free.len());
    let red = if dof > 0 { cost / dof as f64 } else { 1.0 };
    let jtj = jac.transpose() * &jac;
    let mut stderr = [0.0; NP];
    let inv = jtj
        .clone()
        .cholesky()
        .map(|c| c.inverse())
        .or_else(|| jtj.pseudo_inverse(1e-14).ok());
    if let Some(inv) = inv {
        for (col, &k) in free.iter().enumerate() {
            stderr[k] = (inv[(col, col)].max(0.0) * red.max(1.0)).sqrt();
        }
    } else {
        for &k in free {
            stderr[k] = f64::INFINITY;
        }
    }
    LmResult {
        params: p,
        stderr,
        chi2: cost,
        dof,
        converged,
    }
}

/// Linear weighted least squares of `a, b` per channel for a fixed low-pass: the start of the
/// joint fit.
pub(crate) fn linear_start(pts: &[Point], wn: f64, zeta: f64) -> [f64; NP] {
    let mut p = [0.0; NP];
    p[8] = wn;
    p[9] = zeta;
    for c in 0..4 {
        let mut a = nalgebra::Matrix2::<f64>::zeros();
        let mut rhs = nalgebra::Vector2::<f64>::zeros();
        for pt in pts.iter().filter(|pt| 2 * pt.i + pt.j == c) {
            let h = lowpass(pt.omega, wn, zeta) * pt.factor;
            let w2 = pt.omega * pt.omega;
            for (x, y) in [(h.re, pt.g.re), (h.im, pt.g.im)] {
                let phi = nalgebra::Vector2::new(x, x * w2);
                let wgt = 1.0 / (pt.sigma * pt.sigma);
                a += phi * phi.transpose() * wgt;
                rhs += phi * y * wgt;
            }
        }
        if let Some(x) = a.lu().solve(&rhs) {
            p[c] = x[0];
            p[4 + c] = x[1];
        }
    }
    p
}

/// `|W(j omega)|` for `W = k (s + z)/(s + p)`.
pub(crate) fn weight_mag(k: f64, z: f64, p: f64, omega: f64) -> f64 {
    k * (omega * omega + z * z).sqrt() / (omega * omega + p * p).sqrt()
}

/// Fits `W = k (s + z)/(s + p)` as an upper envelope of `l(omega)`: `|W| >= l` at every point,
/// minimal in the least squares of `log |W| - log l`. Grid search on `(z, p)` (log scale), `k`
/// the smallest that satisfies the envelope; then a pattern search around the best.
pub(crate) fn fit_weight(omega: &[f64], l: &[f64]) -> Option<(f64, f64, f64)> {
    let pts: Vec<(f64, f64)> = omega
        .iter()
        .zip(l)
        .filter(|(w, v)| w.is_finite() && **w > 0.0 && v.is_finite() && **v > 0.0)
        .map(|(w, v)| (*w, v.ln()))
        .collect();
    if pts.is_empty() {
        return None;
    }
    let wmin = pts.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let wmax = pts.iter().map(|p| p.0).fold(0.0, f64::max);
    // log|W(j w)| = log k + A(z, w) - A(p, w) with A(x, w) = ln(w^2 + x^2) / 2, so with A
    // tabulated per candidate z and p the cost of a pair takes additions only.
    let a_row = |x: f64| -> Vec<f64> {
        pts.iter()
            .map(|(w, _)| 0.5 * (w * w + x * x).ln())
            .collect()
    };
    // k is set by the largest residual ln l - shape (the envelope touches there).
    let cost = |za: &[f64], pb: &[f64]| -> f64 {
        let resid = || {
            za.iter()
                .zip(pb)
                .zip(&pts)
                .map(|((za, pb), (_, lv))| lv - (za - pb))
        };
        let logk = resid().fold(f64::NEG_INFINITY, f64::max);
        resid().map(|d| (logk - d) * (logk - d)).sum()
    };
    // Global grid on log z, log p (shared values), two decades beyond the data each side.
    const N: usize = 48;
    let (lo, hi) = ((wmin / 100.0).ln(), (wmax * 100.0).ln());
    let grid: Vec<f64> = (0..=N)
        .map(|a| lo + (hi - lo) * a as f64 / N as f64)
        .collect();
    let rows: Vec<Vec<f64>> = grid.iter().map(|g| a_row(g.exp())).collect();
    let mut best = (f64::INFINITY, 0.0, 0.0);
    for (a, za) in rows.iter().enumerate() {
        for (b, pb) in rows.iter().enumerate() {
            let c = cost(za, pb);
            if c < best.0 - 1e-15 {
                best = (c, grid[a], grid[b]);
            }
        }
    }
    // Local pattern search from the best grid point: move to the best of the 3 x 3 neighbours,
    // halve the step when the centre stays best.
    let mut step = (hi - lo) / N as f64;
    while step > 1e-4 {
        let lzs = [best.1 - step, best.1, best.1 + step].map(|v| v.clamp(lo, hi));
        let lps = [best.2 - step, best.2, best.2 + step].map(|v| v.clamp(lo, hi));
        let (zr, pr) = (lzs.map(|v| a_row(v.exp())), lps.map(|v| a_row(v.exp())));
        let mut moved = false;
        for (za, lz) in zr.iter().zip(lzs) {
            for (pb, lp) in pr.iter().zip(lps) {
                let c = cost(za, pb);
                if c < best.0 - 1e-15 {
                    best = (c, lz, lp);
                    moved = true;
                }
            }
        }
        if !moved {
            step /= 2.0;
        }
    }
    let (z, p) = (best.1.exp(), best.2.exp());
    let z = z.clamp(1e-6, 1e4);
    let p = p.clamp(1e-6, 1e4);
    // Recompute k for the clamped pole/zero, with a hair of margin for rounding in the file.
    let k = pts
        .iter()
        .map(|(w, lv)| (lv - weight_mag(1.0, z, p, *w).ln()).exp())
        .fold(0.0, f64::max)
        * (1.0 + 1e-9);
    Some((k.clamp(1e-9, 1e3), z, p))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log_grid(n: usize, lo: f64, hi: f64) -> Vec<f64> {
        (0..n)
            .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
            .collect()
    }

    #[test]
    fn weight_of_an_exact_weight_shape_is_recovered() {
        let w = log_grid(14, 0.5, 15.0);
        let (k0, z0, p0) = (0.05, 1.5, 12.0);
        let l: Vec<f64> = w.iter().map(|&w| weight_mag(k0, z0, p0, w)).collect();
        let (k, z, p) = fit_weight(&w, &l).unwrap();
        for (&w, &l) in w.iter().zip(&l) {
            let m = weight_mag(k, z, p, w);
            assert!(m >= l, "envelope violated at {w}: {m} < {l}");
            assert!(m <= 1.001 * l, "loose at {w}: {m} vs {l}");
        }
        assert!(
            (z / z0 - 1.0).abs() < 0.01 && (p / p0 - 1.0).abs() < 0.01,
            "{z} {p}"
        );
    }

    #[test]
    fn weight_is_an_upper_envelope_of_scattered_levels() {
        let w = log_grid(14, 0.5, 15.0);
        // A rising spread with scatter: every point must lie under |W|.
        let l: Vec<f64> = w
            .iter()
            .enumerate()
            .map(|(i, &w)| 0.02 * (1.0 + w / 4.0) * (1.0 + 0.3 * ((i * 7 % 5) as f64 / 4.0)))
            .collect();
        let (k, z, p) = fit_weight(&w, &l).unwrap();
        let ratio: Vec<f64> = w
            .iter()
            .zip(&l)
            .map(|(&w, &l)| weight_mag(k, z, p, w) / l)
            .collect();
        assert!(ratio.iter().all(|&r| r >= 1.0), "{ratio:?}");
        // Touches at least one point (k is the smallest that satisfies the envelope).
        let min = ratio.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(min < 1.0 + 1e-6, "{min}");
        // And follows the rise: at most the scatter (1.3x) plus a little above the levels.
        assert!(ratio.iter().all(|&r| r < 1.6), "{ratio:?}");
    }
}
