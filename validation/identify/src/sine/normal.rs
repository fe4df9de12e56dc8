//! The normal matrix of the harmonic regressors in closed form: every entry is a geometric
//! sum of the regressors' angles, so no pass over the data is needed for it.

use num_complex::Complex64;

/// `G_p(m) = sum_{k<n} k^p e^{i m theta k}` for `p = 0, 1, 2`: the sums that every entry of the
/// normal matrix of the harmonic regressors (and its derivatives in the frequency) is made of.
/// In closed form from the Dirichlet kernel `D = sin(n phi/2)/sin(phi/2)`, `phi = m theta`:
/// `G_0 = e^{i phi c} D`, `G_1 = -i dG_0/dphi`, `G_2 = -d2G_0/dphi2`, `c = (n-1)/2`. Summed
/// directly (slow, exact) where `sin(phi/2)` nearly vanishes (a harmonic at a multiple of the
/// sampling rate).
pub(super) fn geometric_sums(n: usize, theta: f64, m: usize) -> [Complex64; 3] {
    let nf = n as f64;
    if m == 0 {
        return [
            Complex64::new(nf, 0.0),
            Complex64::new(nf * (nf - 1.0) / 2.0, 0.0),
            Complex64::new((nf - 1.0) * nf * (2.0 * nf - 1.0) / 6.0, 0.0),
        ];
    }
    let phi = m as f64 * theta;
    let (s, co) = (0.5 * phi).sin_cos();
    if s.abs() < 1e-6 {
        let mut g = [Complex64::new(0.0, 0.0); 3];
        for k in 0..n {
            let kf = k as f64;
            let (sn, cs) = (phi * kf).sin_cos();
            let z = Complex64::new(cs, sn);
            g[0] += z;
            g[1] += z * kf;
            g[2] += z * (kf * kf);
        }
        return g;
    }
    let (big_s, big_c) = (0.5 * nf * phi).sin_cos();
    let c = (nf - 1.0) / 2.0;
    let d0 = big_s / s;
    let u = 0.5 * nf * big_c * s - 0.5 * big_s * co;
    let d1 = u / (s * s);
    let d2 = big_s * (1.0 - nf * nf) / (4.0 * s) - u * co / (s * s * s);
    let (es, ec) = (phi * c).sin_cos();
    let e = Complex64::new(ec, es);
    let i = Complex64::new(0.0, 1.0);
    [
        e * d0,
        e * (c * d0 - i * d1),
        e * (c * c * d0 - 2.0 * c * d1 * i - d2),
    ]
}

/// The `m x m` matrix `sum_k w_k phi_a phi_b` of the regressors (DC, then sin and cos of each
/// harmonic) from `e[q] = sum_k w_k e^{i q theta k}`, `q = 0..=2K`, by the product formulas.
pub(super) fn regressor_matrix(e: &[Complex64], k_max: usize) -> nalgebra::DMatrix<f64> {
    // Column 0 is DC (harmonic 0, "cos"), column 2h-1 sin(h x), column 2h cos(h x).
    let col = |c: usize| -> (bool, usize) { (c % 2 == 1, c.div_ceil(2)) };
    let entry = |p: usize, q: usize| -> f64 {
        let ((p_sin, a), (q_sin, b)) = (col(p), col(q));
        let (diff, sum) = (e[a.abs_diff(b)], e[a + b]);
        // Products of sines and cosines as sums and differences of angles.
        match (p_sin, q_sin) {
            (false, false) if a == 0 && b == 0 => e[0].re,
            (false, false) if a == 0 || b == 0 => sum.re,
            (false, false) => 0.5 * (diff.re + sum.re),
            (true, true) => 0.5 * (diff.re - sum.re),
            (true, false) if b == 0 => sum.im,
            (false, true) if a == 0 => sum.im,
            // sin A cos B = (sin(A + B) + sin(A - B)) / 2
            (true, false) => 0.5 * (sum.im + if a >= b { diff.im } else { -diff.im }),
            (false, true) => 0.5 * (sum.im + if b >= a { diff.im } else { -diff.im }),
        }
    };
    let m = 1 + 2 * k_max;
    nalgebra::DMatrix::from_fn(m, m, entry)
}
