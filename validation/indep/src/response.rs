//! Frequency-domain tools: the small-signal response of a robot, the first harmonic of a
//! sampled record, and the noise of that first harmonic.
//!
//! Phasor convention (as for a sine input): a signal `S sin ωt + C cos ωt` has the phasor
//! `S + jC`, so an input `A sin ωt` has phasor `A` and a response `|G| A sin(ωt + φ)` has phasor
//! `G A` with `G = |G| e^{jφ}`.

use crate::design::{Design, RecordSpec};
use crate::mechanics::{AxisModel, Plant};
use crate::robot::{Noise, Robot};

/// A complex number (this crate keeps its arithmetic to itself).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Complex {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl Complex {
    /// `re + j im`.
    pub const fn new(re: f64, im: f64) -> Self {
        Complex { re, im }
    }
    /// `e^{jφ}`.
    pub fn cis(phi: f64) -> Self {
        let (s, c) = phi.sin_cos();
        Complex::new(c, s)
    }
    /// Modulus.
    pub fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }
    /// Argument, rad.
    pub fn arg(self) -> f64 {
        self.im.atan2(self.re)
    }
    /// Multiplication by a real.
    pub fn scale(self, k: f64) -> Self {
        Complex::new(self.re * k, self.im * k)
    }
}

impl std::ops::Add for Complex {
    type Output = Complex;
    fn add(self, o: Complex) -> Complex {
        Complex::new(self.re + o.re, self.im + o.im)
    }
}
impl std::ops::Sub for Complex {
    type Output = Complex;
    fn sub(self, o: Complex) -> Complex {
        Complex::new(self.re - o.re, self.im - o.im)
    }
}
impl std::ops::Mul for Complex {
    type Output = Complex;
    fn mul(self, o: Complex) -> Complex {
        Complex::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
}
impl std::ops::Div for Complex {
    type Output = Complex;
    fn div(self, o: Complex) -> Complex {
        let d = o.re * o.re + o.im * o.im;
        Complex::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
}
impl std::ops::Neg for Complex {
    type Output = Complex;
    fn neg(self) -> Complex {
        Complex::new(-self.re, -self.im)
    }
}

/// The CoM responses of one axis chain at `s = jω`: to its reference (`to_reference`, with the
/// command latency) and to a force on its joint node (`to_joint_force`), both in m per unit.
fn chain_response(ax: &AxisModel, omega: f64) -> (Complex, Complex) {
    let n = ax.n;
    let s = Complex::new(0.0, omega);
    let s2 = s * s;
    let z: Vec<Complex> = (0..n.saturating_sub(1))
        .map(|l| Complex::new(ax.link_kc[l].0, omega * ax.link_kc[l].1))
        .collect();
    // Tridiagonal matrix: diagonal d, off-diagonal -z.
    let mut d = vec![Complex::default(); n];
    for k in 0..n {
        d[k] = s2.scale(ax.mass[k]);
        if k > 0 {
            d[k] = d[k] + z[k - 1];
        }
        if k + 1 < n {
            d[k] = d[k] + z[k];
        }
    }
    d[ax.joint] = d[ax.joint] + Complex::new(0.0, omega * ax.joint_drag);
    let wn2 = ax.kp * ax.kv;
    d[0] = d[0] + Complex::new(wn2, omega * ax.kv);
    let solve = |rhs: Vec<Complex>| -> Complex {
        // Thomas algorithm on (d, -z).
        let mut dd = d.clone();
        let mut r = rhs;
        for k in 1..n {
            let m = (-z[k - 1]) / dd[k - 1];
            dd[k] = dd[k] - m * (-z[k - 1]);
            r[k] = r[k] - m * r[k - 1];
        }
        let mut q = vec![Complex::default(); n];
        q[n - 1] = r[n - 1] / dd[n - 1];
        for k in (0..n - 1).rev() {
            q[k] = (r[k] - (-z[k]) * q[k + 1]) / dd[k];
        }
        (0..n).fold(Complex::default(), |acc, k| {
            acc + q[k].scale(ax.com_weight[k])
        })
    };
    let mut rhs = vec![Complex::default(); n];
    rhs[0] = Complex::cis(-omega * ax.delay).scale(wn2);
    let to_ref = solve(rhs);
    let mut rhs = vec![Complex::default(); n];
    rhs[ax.joint] = Complex::new(1.0, 0.0);
    let to_force = solve(rhs);
    (to_ref, to_force)
}

/// The small-signal frequency response `G[i][j](jω)` (ZMP `i` per CoM reference `j`) of the
/// robot around the operating point `op`: servo unsaturated, no velocity limit, transmission
/// and flexible links linear (at zero deflection), pendulum linearised at `op` (exact for the
/// first harmonic: the map is quadratic), sensor low-pass in, drift and noise out.
///
/// `None` when the robot has play or friction (no small-signal response).
pub fn small_signal_response(robot: &Robot, op: [f64; 2], omega: f64) -> Option<[[Complex; 2]; 2]> {
    let plant = Plant::new(robot);
    if !plant.axes.iter().all(|a| a.is_smooth) {
        return None;
    }
    let s = Complex::new(0.0, omega);
    let s2 = s * s;
    let resp = [
        chain_response(&plant.axes[0], omega),
        chain_response(&plant.axes[1], omega),
    ];
    // CoM phasors xc[k] for a unit reference on axis j.
    let kappa = plant.kappa.unwrap_or([0.0; 2]);
    let (ga, gb, sa) = match plant.op_dep {
        None => (1.0, 1.0, [0.0; 2]),
        Some((sa, sb)) => (
            1.0 + sa[0] * op[0] + sa[1] * op[1],
            1.0 + sb[0] * op[0] + sb[1] * op[1],
            sa,
        ),
    };
    let mut g = [[Complex::default(); 2]; 2];
    for j in 0..2 {
        let mut xc = [Complex::default(); 2];
        let i = 1 - j;
        // Inertial loads: ext_i = -kappa_i s² X_j, ext_j = -kappa_j s² X_i, X = T R + C ext.
        let loop_gain = (s2 * s2 * resp[i].1 * resp[j].1).scale(kappa[i] * kappa[j]);
        xc[j] = resp[j].0 / (Complex::new(1.0, 0.0) - loop_gain);
        xc[i] = resp[i].1 * (s2 * xc[j]).scale(-kappa[i]);
        for i in 0..2 {
            let static_row = plant.a[i][0] * op[0] + plant.a[i][1] * op[1];
            let mut z = Complex::default();
            for (k, xk) in xc.iter().enumerate() {
                let (a_lin, b_op) = match &plant.op_channel {
                    None => (plant.a[i][k] * ga + static_row * sa[k], plant.b[i][k] * gb),
                    Some(pc) => channel_gains(&plant, pc, op, i, k),
                };
                let lin = Complex::new(a_lin, 0.0) - s2.scale(b_op);
                z = z + lin * *xk;
            }
            if let Some(wc) = plant.lowpass {
                z = z * (Complex::new(wc[i], 0.0) / (s + Complex::new(wc[i], 0.0)));
            }
            g[i][j] = z;
        }
    }
    Some(g)
}

/// The small-signal gains `(a, b)` of channel `ik` at `op` with slopes per channel: the
/// static map `zmp_i = Σ_j g_ij(x) a_ij x_j`, `g_ij = (1 + s·x)(1 + s_ij·x)` (the common and
/// the channel's own factor), has the slope `a_ik g_ik(op) + Σ_j a_ij op_j ∂g_ij/∂x_k`; `b`
/// multiplies the acceleration, zero at rest: `b_ik` times its factor at `op`.
fn channel_gains(
    plant: &Plant,
    (pa, pb): &crate::mechanics::ChannelSlopes,
    op: [f64; 2],
    i: usize,
    k: usize,
) -> (f64, f64) {
    let (ca, cb) = plant.op_dep.unwrap_or(([0.0; 2], [0.0; 2]));
    let at = |s: &[f64; 2]| 1.0 + s[0] * op[0] + s[1] * op[1];
    let g = |j: usize| at(&ca) * at(&pa[i][j]);
    let dg = |j: usize| ca[k] * at(&pa[i][j]) + at(&ca) * pa[i][j][k];
    let slope: f64 = (0..2).map(|j| plant.a[i][j] * op[j] * dg(j)).sum();
    (
        plant.a[i][k] * g(k) + slope,
        plant.b[i][k] * at(&cb) * at(&pb[i][k]),
    )
}

/// Gain of the sample averaging of the measurement at `omega` (rad/s) and `sample_rate_hz`:
/// `sin(ωΔ/2) / (ωΔ/2)`, `Δ = 1/sample_rate_hz` (no phase: the average is centred).
pub fn sample_average_gain(omega: f64, sample_rate_hz: f64) -> f64 {
    let x = 0.5 * omega / sample_rate_hz;
    if x == 0.0 {
        1.0
    } else {
        x.sin() / x
    }
}

/// What the recorded first harmonics follow: [`small_signal_response`] times
/// [`sample_average_gain`].
pub fn measured_response(
    robot: &Robot,
    op: [f64; 2],
    omega: f64,
    sample_rate_hz: f64,
) -> Option<[[Complex; 2]; 2]> {
    let k = sample_average_gain(omega, sample_rate_hz);
    small_signal_response(robot, op, omega).map(|g| g.map(|row| row.map(|c| c.scale(k))))
}

/// Least-squares fit of `c0 + S sin ωt + C cos ωt` to the samples with `t_from ≤ t < t_to`;
/// returns the phasor `S + jC` and the offset `c0`.
pub fn first_harmonic(t: &[f64], y: &[f64], omega: f64, t_from: f64, t_to: f64) -> (Complex, f64) {
    // Normal equations of the three regressors (1, sin, cos).
    let mut m = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for (&tk, &yk) in t.iter().zip(y) {
        if tk < t_from - 1e-9 || tk >= t_to - 1e-9 {
            continue;
        }
        let (s, c) = (omega * tk).sin_cos();
        let r = [1.0, s, c];
        for p in 0..3 {
            b[p] += r[p] * yk;
            for q in 0..3 {
                m[p][q] += r[p] * r[q];
            }
        }
    }
    let x = solve3(m, b);
    (Complex::new(x[1], x[2]), x[0])
}

/// The first harmonic of a record's column over its steady window.
pub fn steady_harmonic(spec: &RecordSpec, t: &[f64], y: &[f64]) -> Complex {
    first_harmonic(t, y, spec.omega, spec.steady_start_s, spec.steady_end_s()).0
}

fn solve3(mut m: [[f64; 3]; 3], mut b: [f64; 3]) -> [f64; 3] {
    for c in 0..3 {
        let p = (c..3)
            .max_by(|&i, &j| m[i][c].abs().total_cmp(&m[j][c].abs()))
            .unwrap_or(c);
        m.swap(c, p);
        b.swap(c, p);
        let piv = m[c][c];
        if piv == 0.0 {
            return [0.0; 3];
        }
        for r in c + 1..3 {
            let f = m[r][c] / piv;
            let pivot_row = m[c];
            for (dst, src) in m[r][c..].iter_mut().zip(&pivot_row[c..]) {
                *dst -= f * src;
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = [0.0; 3];
    for c in (0..3).rev() {
        let mut s = b[c];
        for k in c + 1..3 {
            s -= m[c][k] * x[k];
        }
        x[c] = s / m[c][c];
    }
    x
}

/// Standard deviation of each component (sine and cosine coefficient) of the first harmonic
/// estimated from `n` samples over whole periods, for a noise of the given law plus a uniform
/// quantisation error: `sqrt(2 S(ω) / n)`, with `S(ω)` the noise's spectral level at `ω`
/// normalised so that white noise of variance σ² has `S = σ²` (for the AR(1) part
/// `S = σ_c² (1 − φ²) / |1 − φ e^{−jωΔ}|²`, `Δ` the sample step).
pub fn harmonic_noise_std(
    noise: &Noise,
    quantisation: f64,
    sample_rate_hz: f64,
    omega: f64,
    n: usize,
) -> f64 {
    let dt = 1.0 / sample_rate_hz;
    let phi = (-dt / noise.coloured_tau).exp();
    let den = Complex::new(1.0, 0.0) - Complex::cis(-omega * dt).scale(phi);
    let coloured =
        noise.coloured_std.powi(2) * (1.0 - phi * phi) / (den.re * den.re + den.im * den.im);
    let level = noise.white_std.powi(2) + quantisation.powi(2) / 12.0 + coloured;
    (2.0 * level / n.max(1) as f64).sqrt()
}

/// The first-harmonic noise of a design record for a robot: [`harmonic_noise_std`] with the
/// design's noise law for the robot and the record's steady sample count.
pub fn record_noise_std(robot: &Robot, design: &Design, spec: &RecordSpec) -> f64 {
    let noise = design.noise_for(&robot.sensor.noise);
    harmonic_noise_std(
        &noise,
        design.quantisation,
        design.sample_rate_hz,
        spec.omega,
        spec.steady_samples(design.sample_rate_hz),
    )
}
