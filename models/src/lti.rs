//! Small SISO linear time-invariant blocks: transfer functions, exact discretisation, stepping.
//!
//! Discretisation is first-order hold (ramp-invariant): between two steps the input is taken to
//! move linearly from its previous value to the new one. This is exact for piecewise-linear
//! inputs, so a finely sampled sine sees no half-step phase lag (zero-order hold would add
//! `-omega*h/2`, half a degree already at 17 rad/s with a 1 ms step).
//!
//! The same discretisation is exact for inputs that also jump at the steps: [`DiscreteLti::jump`]
//! moves the input's value at the step's start without touching the state, and the step then
//! ramps from there. The exact zero-order hold (input constant over the step) is `jump(u)`
//! followed by `step(u)`: `x[k+1] = phi x[k] + gamma0 u[k]`, the `gamma0` of
//! [`discretise_foh`].

use crate::memo::Memo;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// Largest state dimension of one block; fixed so stepping never allocates.
pub const MAX_ORDER: usize = 6;

/// A polynomial in `s`, coefficients in ascending powers: `c[0] + c[1] s + c[2] s^2 + ...`.
#[derive(Debug, Clone, PartialEq)]
pub struct Poly(pub Vec<f64>);

impl Poly {
    /// The polynomial of coefficients `ascending` (constant first), trailing zeros dropped.
    pub fn new(ascending: &[f64]) -> Poly {
        let mut c = ascending.to_vec();
        while c.len() > 1 && c[c.len() - 1] == 0.0 {
            c.pop();
        }
        Poly(c)
    }

    /// The degree: the highest power with a non-zero coefficient (0 for a constant).
    pub fn degree(&self) -> usize {
        self.0.len().saturating_sub(1)
    }

    /// The polynomial's value at `s` (Horner).
    pub fn eval(&self, s: Complex64) -> Complex64 {
        self.0
            .iter()
            .rev()
            .fold(Complex64::new(0.0, 0.0), |acc, &c| acc * s + c)
    }

    /// The product `self * other`.
    pub fn mul(&self, other: &Poly) -> Poly {
        let mut c = vec![0.0; self.0.len() + other.0.len() - 1];
        for (i, a) in self.0.iter().enumerate() {
            for (j, b) in other.0.iter().enumerate() {
                c[i + j] += a * b;
            }
        }
        Poly::new(&c)
    }

    /// The sum `self + other`.
    pub fn add(&self, other: &Poly) -> Poly {
        let n = self.0.len().max(other.0.len());
        let c: Vec<f64> = (0..n)
            .map(|i| self.0.get(i).copied().unwrap_or(0.0) + other.0.get(i).copied().unwrap_or(0.0))
            .collect();
        Poly::new(&c)
    }

    /// Every coefficient times `k`.
    pub fn scale(&self, k: f64) -> Poly {
        Poly::new(&self.0.iter().map(|c| c * k).collect::<Vec<_>>())
    }
}

/// A proper rational transfer function `num(s) / den(s)`.
#[derive(Debug, Clone, PartialEq)]
pub struct TransferFunction {
    /// Numerator polynomial.
    pub num: Poly,
    /// Denominator polynomial.
    pub den: Poly,
}

impl TransferFunction {
    /// The transfer function `num / den`.
    pub fn new(num: Poly, den: Poly) -> TransferFunction {
        TransferFunction { num, den }
    }

    /// The constant gain `k`.
    pub fn gain(k: f64) -> TransferFunction {
        TransferFunction::new(Poly::new(&[k]), Poly::new(&[1.0]))
    }

    /// The value at the complex frequency `s` (rad/s).
    pub fn eval(&self, s: Complex64) -> Complex64 {
        self.num.eval(s) / self.den.eval(s)
    }

    /// The frequency response at `omega` (rad/s): the value at `s = j omega`.
    pub fn freq(&self, omega: f64) -> Complex64 {
        self.eval(Complex64::new(0.0, omega))
    }

    /// The series connection `self * other`.
    pub fn mul(&self, other: &TransferFunction) -> TransferFunction {
        TransferFunction::new(self.num.mul(&other.num), self.den.mul(&other.den))
    }

    /// `self + other` over the common denominator.
    pub fn add(&self, other: &TransferFunction) -> TransferFunction {
        TransferFunction::new(
            self.num.mul(&other.den).add(&other.num.mul(&self.den)),
            self.den.mul(&other.den),
        )
    }
}

/// Continuous state space in controllable canonical form, from a proper transfer function.
pub fn canonical(tf: &TransferFunction) -> (DMatrix<f64>, DVector<f64>, DVector<f64>, f64) {
    let lead = *tf.den.0.last().expect("denominator has a coefficient");
    let den: Vec<f64> = tf.den.0.iter().map(|c| c / lead).collect();
    let n = den.len() - 1;
    let mut num: Vec<f64> = tf.num.0.iter().map(|c| c / lead).collect();
    num.resize(n + 1, 0.0);
    let d = num[n];
    let mut a = DMatrix::zeros(n, n);
    for i in 0..n.saturating_sub(1) {
        a[(i, i + 1)] = 1.0;
    }
    if n > 0 {
        for j in 0..n {
            a[(n - 1, j)] = -den[j];
        }
    }
    let mut b = DVector::zeros(n);
    if n > 0 {
        b[n - 1] = 1.0;
    }
    let c = DVector::from_iterator(n, (0..n).map(|j| num[j] - d * den[j]));
    (a, b, c, d)
}

/// First-order-hold discretisation of `x' = A x + B u` over step `h`.
///
/// Returns `(phi, gamma0, gamma1)` with
/// `x[k+1] = phi x[k] + gamma0 u[k] + gamma1 (u[k+1] - u[k]) / h`.
///
/// Remembered by the exact bits of `A`, `B` and `h`: a fit builds the same plant's blocks over
/// and over (every Jacobian column of a parameter they do not hold, every candidate beside the
/// unchanged servo), and the matrix exponential was a tenth of a diagnosis's instructions.
pub fn discretise_foh(
    a: &DMatrix<f64>,
    b: &DVector<f64>,
    h: f64,
) -> (DMatrix<f64>, DVector<f64>, DVector<f64>) {
    let key: Vec<u64> = [a.nrows() as f64, h]
        .iter()
        .chain(a.iter())
        .chain(b.iter())
        .map(|v| v.to_bits())
        .collect();
    FOH_CACHE.get_or(key, || discretise_foh_uncached(a, b, h))
}

type Foh = (DMatrix<f64>, DVector<f64>, DVector<f64>);

/// [`discretise_foh`]'s memory.
static FOH_CACHE: Memo<Vec<u64>, Foh> = Memo::new(4096);

fn discretise_foh_uncached(a: &DMatrix<f64>, b: &DVector<f64>, h: f64) -> Foh {
    let n = a.nrows();
    // exp([[A, B, 0], [0, 0, 1], [0, 0, 0]] h) = [[phi, gamma0, gamma1], ...]
    let mut m = DMatrix::zeros(n + 2, n + 2);
    m.view_mut((0, 0), (n, n)).copy_from(&(a * h));
    m.view_mut((0, n), (n, 1)).copy_from(&(b * h));
    m[(n, n + 1)] = h;
    let e = m.exp();
    let phi = e.view((0, 0), (n, n)).into_owned();
    let g0 = e.column(n).rows(0, n).into_owned();
    let g1 = e.column(n + 1).rows(0, n).into_owned();
    (phi, g0, g1)
}

/// A discretised SISO LTI block that steps without allocating.
#[derive(Debug, Clone)]
pub struct DiscreteLti {
    n: usize,
    phi: [[f64; MAX_ORDER]; MAX_ORDER],
    g0: [f64; MAX_ORDER],
    /// `gamma1 / h`, so the step needs no division.
    g1: [f64; MAX_ORDER],
    c: [f64; MAX_ORDER],
    d: f64,
    /// `x_ss = xdc * u` for a constant input: the steady state used by `reset`.
    xdc: [f64; MAX_ORDER],
    x: [f64; MAX_ORDER],
    u_prev: f64,
}

impl DiscreteLti {
    /// Discretises `tf` with step `h`. `tf` must be proper, stable, and of order `<= MAX_ORDER`.
    pub fn new(tf: &TransferFunction, h: f64) -> DiscreteLti {
        let (a, b, c, d) = canonical(tf);
        Self::from_state_space(&a, &b, &c, d, h)
    }

    /// Discretises `x' = a x + b u`, `y = c x + d u` with step `h` (s) and a first-order hold of the input; order at most [`MAX_ORDER`].
    pub fn from_state_space(
        a: &DMatrix<f64>,
        b: &DVector<f64>,
        c: &DVector<f64>,
        d: f64,
        h: f64,
    ) -> DiscreteLti {
        let n = a.nrows();
        assert!(n <= MAX_ORDER, "LTI block of order {n} exceeds {MAX_ORDER}");
        let (phi_m, g0_m, g1_m) = discretise_foh(a, b, h);
        let mut s = DiscreteLti {
            n,
            phi: [[0.0; MAX_ORDER]; MAX_ORDER],
            g0: [0.0; MAX_ORDER],
            g1: [0.0; MAX_ORDER],
            c: [0.0; MAX_ORDER],
            d,
            xdc: [0.0; MAX_ORDER],
            x: [0.0; MAX_ORDER],
            u_prev: 0.0,
        };
        for i in 0..n {
            for j in 0..n {
                s.phi[i][j] = phi_m[(i, j)];
            }
            s.g0[i] = g0_m[i];
            s.g1[i] = g1_m[i] / h;
            s.c[i] = c[i];
        }
        if n > 0 {
            if let Some(inv) = a.clone().try_inverse() {
                let xdc = -(inv * b);
                for i in 0..n {
                    s.xdc[i] = xdc[i];
                }
            }
        }
        s
    }

    /// The state dimension.
    pub fn order(&self) -> usize {
        self.n
    }

    /// Puts the block at rest for the constant input `u`; returns the output at rest.
    pub fn reset(&mut self, u: f64) -> f64 {
        for i in 0..self.n {
            self.x[i] = self.xdc[i] * u;
        }
        self.u_prev = u;
        self.output(u)
    }

    /// The input jumps to `u` now (the state is continuous); returns the output just after.
    /// The next [`DiscreteLti::step`] ramps from `u`.
    #[inline]
    pub fn jump(&mut self, u: f64) -> f64 {
        self.u_prev = u;
        self.output(u)
    }

    /// Advances one step; the input has moved linearly from the previous value to `u`.
    #[inline]
    pub fn step(&mut self, u: f64) -> f64 {
        // Dispatch on the order so each loop is unrolled at compile time.
        match self.n {
            0 => {
                self.u_prev = u;
                self.d * u
            }
            1 => self.step_n::<1>(u),
            2 => self.step_n::<2>(u),
            3 => self.step_n::<3>(u),
            4 => self.step_n::<4>(u),
            5 => self.step_n::<5>(u),
            _ => self.step_n::<MAX_ORDER>(u),
        }
    }

    #[inline(always)]
    fn step_n<const N: usize>(&mut self, u: f64) -> f64 {
        let du = u - self.u_prev;
        let mut next = [0.0; N];
        for (i, nx) in next.iter_mut().enumerate() {
            let mut acc = self.g0[i] * self.u_prev + self.g1[i] * du;
            for j in 0..N {
                acc += self.phi[i][j] * self.x[j];
            }
            *nx = acc;
        }
        let mut y = self.d * u;
        for i in 0..N {
            self.x[i] = next[i];
            y += self.c[i] * next[i];
        }
        self.u_prev = u;
        y
    }

    #[inline]
    fn output(&self, u: f64) -> f64 {
        let mut y = self.d * u;
        for i in 0..self.n {
            y += self.c[i] * self.x[i];
        }
        y
    }
}

/// QR sweeps [`eigenvalues`] allows per dimension: the shifted QR iteration deflates an
/// eigenvalue in two or three sweeps.
const MAX_SWEEPS_PER_DIM: usize = 100;

/// The eigenvalues of a square matrix, or `None` when an entry is not finite or the QR
/// iteration does not converge within 100 sweeps per dimension.
/// nalgebra's `complex_eigenvalues` iterates without a limit: on a matrix with a NaN (a
/// fit's parameters at an edge, a simulated orbit that blew up) it never returns, and a
/// diagnosis held by it ignored its time limit (held-out draw 1240001).
pub fn eigenvalues(a: &DMatrix<f64>) -> Option<Vec<Complex64>> {
    if !a.is_square() || !a.iter().all(|v| v.is_finite()) {
        return None;
    }
    let sweeps = MAX_SWEEPS_PER_DIM * a.nrows().max(1);
    let schur = nalgebra::linalg::Schur::try_new(a.clone(), f64::EPSILON, sweeps)?;
    let eig: Vec<Complex64> = schur.complex_eigenvalues().iter().copied().collect();
    eig.iter()
        .all(|z| z.re.is_finite() && z.im.is_finite())
        .then_some(eig)
}

/// The largest eigenvalue modulus of a square matrix (see [`eigenvalues`] for `None`).
pub fn spectral_radius(a: &DMatrix<f64>) -> Option<f64> {
    Some(eigenvalues(a)?.iter().map(|z| z.norm()).fold(0.0, f64::max))
}

/// A bound on the slowest time constant of a stable denominator, from its roots' real parts
/// (the roots are found as eigenvalues of the companion matrix).
pub fn slowest_time_constant(den: &Poly) -> f64 {
    let n = den.degree();
    if n == 0 {
        return 0.0;
    }
    let lead = den.0[n];
    let mut a = DMatrix::zeros(n, n);
    for i in 0..n - 1 {
        a[(i + 1, i)] = 1.0;
    }
    for i in 0..n {
        a[(i, n - 1)] = -den.0[i] / lead;
    }
    // Not known (not finite, or no convergence): as slow as an unstable pole.
    let Some(eig) = eigenvalues(&a) else {
        return f64::INFINITY;
    };
    eig.iter()
        .map(|l| {
            if l.re < 0.0 {
                -1.0 / l.re
            } else {
                f64::INFINITY
            }
        })
        .fold(0.0, f64::max)
}

/// `n` log-spaced values from `lo` to `hi` (a frequency grid, both ends included).
pub fn logspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![lo];
    }
    (0..n)
        .map(|k| lo * (hi / lo).powf(k as f64 / (n - 1) as f64))
        .collect()
}
#[cfg(test)]
mod tests {
    use super::*;

    /// Runs `f` on its own thread and fails if it has not returned within ten seconds (a hang
    /// becomes a failure, not a stuck test run).
    fn within_ten_seconds<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let _ = tx.send(f());
        });
        rx.recv_timeout(std::time::Duration::from_secs(10))
            .expect("returned within ten seconds")
    }

    #[test]
    fn eigenvalues_of_a_matrix_with_a_nan_are_none_not_a_hang() {
        // nalgebra's unbounded QR iteration never returns on such a matrix of three rows or
        // more (a 2x2 is solved in closed form).
        let mut a = DMatrix::from_fn(3, 3, |i, j| 0.1 * (i as f64 + 1.0) - 0.05 * j as f64);
        a[(1, 0)] = f64::NAN;
        assert_eq!(within_ten_seconds(move || eigenvalues(&a)), None);
        let mut b = DMatrix::from_fn(4, 4, |i, j| if i == j { 0.5 } else { 0.01 });
        b[(2, 3)] = f64::INFINITY;
        assert_eq!(within_ten_seconds(move || spectral_radius(&b)), None);
    }

    #[test]
    fn eigenvalues_are_those_of_the_matrix() {
        // A rotation scaled by 0.9 (eigenvalues 0.9 e^{+-i 0.3}) and a real 2x2 block.
        let (r, th) = (0.9f64, 0.3f64);
        let a = DMatrix::from_row_slice(
            3,
            3,
            &[
                r * th.cos(),
                -r * th.sin(),
                0.0,
                r * th.sin(),
                r * th.cos(),
                0.0,
                0.0,
                0.0,
                -0.5,
            ],
        );
        let mut eig = eigenvalues(&a).expect("finite");
        eig.sort_by(|x, y| x.im.total_cmp(&y.im));
        let want = [
            Complex64::from_polar(r, -th),
            Complex64::new(-0.5, 0.0),
            Complex64::from_polar(r, th),
        ];
        for (g, w) in eig.iter().zip(want) {
            assert!((g - w).norm() < 1e-12, "{g} against {w}");
        }
        assert!((spectral_radius(&a).unwrap() - r).abs() < 1e-12);
        // The companion matrix of (s + 1)(s + 4): time constants 1 s and 0.25 s.
        let den = Poly::new(&[4.0, 5.0, 1.0]);
        assert!((slowest_time_constant(&den) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn first_order_step_matches_exponential() {
        // 1/(s+2): unit step response 0.5 (1 - e^{-2t}); FOH with a held input is exact.
        let tf = TransferFunction::new(Poly::new(&[1.0]), Poly::new(&[2.0, 1.0]));
        let h = 0.01;
        let mut sys = DiscreteLti::new(&tf, h);
        sys.reset(0.0);
        // First step ramps 0 -> 1; from then on the input is constant.
        sys.step(1.0);
        let mut y = 0.0;
        for _ in 1..100 {
            y = sys.step(1.0);
        }
        // Exact response to the ramp-then-hold input at t = 1 s.
        let t: f64 = 1.0;
        let ramp_end = 0.5 * (h - (1.0 - (-2.0 * h).exp()) / 2.0) / h;
        let x_h = ramp_end;
        let exact = 0.5 + (x_h - 0.5) * (-2.0 * (t - h)).exp();
        assert!((y - exact).abs() < 1e-12, "{y} vs {exact}");
    }

    /// Jump then step is the exact zero-order hold: 1/(s+2) under a held unit input from rest
    /// is 0.5 (1 - e^{-2t}) at every step, with no ramp over the first.
    #[test]
    fn jump_then_step_is_the_exact_zero_order_hold() {
        let tf = TransferFunction::new(Poly::new(&[1.0]), Poly::new(&[2.0, 1.0]));
        let h = 0.01;
        let mut sys = DiscreteLti::new(&tf, h);
        sys.reset(0.0);
        // The jump moves no state: the output just after it is still at rest (no feedthrough).
        assert_eq!(sys.jump(1.0), 0.0);
        for k in 1..=100 {
            let y = sys.step(1.0);
            let exact = 0.5 * (1.0 - (-2.0 * k as f64 * h).exp());
            assert!((y - exact).abs() < 1e-14, "step {k}: {y} vs {exact}");
        }
    }

    #[test]
    fn reset_is_steady_state() {
        let tf = TransferFunction::new(Poly::new(&[900.0]), Poly::new(&[900.0, 60.0, 1.0]));
        let mut sys = DiscreteLti::new(&tf, 1e-3);
        sys.reset(0.3);
        for _ in 0..10 {
            let y = sys.step(0.3);
            assert!((y - 0.3).abs() < 1e-12);
        }
    }

    #[test]
    fn poly_ops() {
        let p = Poly::new(&[1.0, 1.0]).mul(&Poly::new(&[-1.0, 1.0]));
        assert_eq!(p, Poly::new(&[-1.0, 0.0, 1.0]));
        let s = Complex64::new(0.0, 2.0);
        assert!((p.eval(s) - Complex64::new(-5.0, 0.0)).norm() < 1e-15);
    }
}
