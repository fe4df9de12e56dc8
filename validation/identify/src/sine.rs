//! Per-record signal analysis: the harmonic sine fit by variable projection (linear in the
//! harmonic amplitudes, a 1-D refinement of the frequency), after the windowed FFT first
//! estimate (`sine/fft.rs`).

#![allow(clippy::needless_range_loop)]

mod fft;
mod normal;

pub(crate) use fft::fft_estimate;
use normal::{geometric_sums, regressor_matrix};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Resynchronisation period of the sin/cos recurrences (exact `sin_cos` every this many samples).
const RESYNC: usize = 1024;

/// Harmonic least-squares fit of `S` signals at one frequency.
#[derive(Debug, Clone)]
pub(crate) struct HarmonicFit<const S: usize> {
    /// Phasors of harmonics 1..=K per signal (`[signal][k-1]`).
    pub harmonics: [Vec<Complex64>; S],
    /// Residual variance per signal.
    pub noise_var: [f64; S],
    /// Residual sum of squares per signal.
    pub rss: [f64; S],
    /// Sum of squares of the centred signal.
    pub yy: [f64; S],
    /// Constant term per signal: the value at the middle of the slice with the trend column,
    /// the mean level without it.
    pub dc: [f64; S],
    /// Linear trend per signal, units per second (0 unless fitted with the trend column).
    pub trend: [f64; S],
    /// Diagonal of the inverse normal matrix at the fundamental's sin and cos columns and at
    /// the trend column (per s², 0 without it): a coefficient's variance is the noise
    /// variance times its entry.
    pub inv_diag_h1: [f64; 2],
    pub inv_diag_trend: f64,
    /// Samples fitted.
    pub n: usize,
}

impl<const S: usize> HarmonicFit<S> {
    /// The fit of the signals `which` (in that order) alone: each signal's fit is its own.
    pub(crate) fn pick<const P: usize>(&self, which: [usize; P]) -> HarmonicFit<P> {
        HarmonicFit {
            harmonics: which.map(|j| self.harmonics[j].clone()),
            noise_var: which.map(|j| self.noise_var[j]),
            rss: which.map(|j| self.rss[j]),
            yy: which.map(|j| self.yy[j]),
            dc: which.map(|j| self.dc[j]),
            trend: which.map(|j| self.trend[j]),
            inv_diag_h1: self.inv_diag_h1,
            inv_diag_trend: self.inv_diag_trend,
            n: self.n,
        }
    }

    /// The summed normalised residual that the frequency refinement minimises.
    fn cost(&self) -> f64 {
        (0..S).map(|j| self.rss[j] / self.yy[j].max(1e-300)).sum()
    }
}

/// Largest regressor count: DC and seven harmonics.
const MAX_COLS: usize = 15;

/// Fits DC + `k_max` harmonics of `omega` to each signal (centred), time from sample 0 of the
/// slice. The data enter through one pass of sums, sin/cos by recurrence; the normal matrix is
/// in closed form (see [`geometric_sums`]).
/// (Only the tests' reference now: identification fits with the trend column.)
#[cfg(test)]
pub(crate) fn harmonic_fit<const S: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
    k_max: usize,
) -> Option<HarmonicFit<S>> {
    dispatch(signals, omega, dt, k_max, Mode::Plain, None).map(|p| p.fit)
}

/// [`harmonic_fit`] with a linear trend column besides DC (`[1, t, sin k w t, cos k w t]`):
/// a drifting sensor's ramp does not leak into the harmonics. The one harmonic regression of
/// the crate: identification and the diagnosis's observations both use it.
pub(crate) fn harmonic_fit_trend<const S: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
    k_max: usize,
) -> Option<HarmonicFit<S>> {
    dispatch(signals, omega, dt, k_max, Mode::Trend, None).map(|p| p.fit)
}

/// What [`fit_k`] computes besides the harmonics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    #[cfg(test)]
    Plain,
    /// The first and second derivative of the cost in the frequency.
    FrequencySlope,
    /// A linear trend column.
    Trend,
}

/// What one pass of [`fit_k`] returns: the fit, the cost's first and second derivative in the
/// frequency ([`Mode::FrequencySlope`], else 0) and, with [`Mode::Trend`] and slopes given,
/// the cost of the plain fit of the signals with those ramps taken out.
struct Pass<const S: usize> {
    fit: HarmonicFit<S>,
    d1: f64,
    d2: f64,
    detrended_cost: Option<f64>,
}

fn dispatch<const S: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
    k_max: usize,
    mode: Mode,
    ramps: Option<[f64; S]>,
) -> Option<Pass<S>> {
    // Dispatch on the harmonic count so the accumulation loops unroll.
    match k_max {
        1 => fit_k::<S, 1>(signals, omega, dt, mode, ramps),
        2 => fit_k::<S, 2>(signals, omega, dt, mode, ramps),
        3 => fit_k::<S, 3>(signals, omega, dt, mode, ramps),
        4 => fit_k::<S, 4>(signals, omega, dt, mode, ramps),
        5 => fit_k::<S, 5>(signals, omega, dt, mode, ramps),
        6 => fit_k::<S, 6>(signals, omega, dt, mode, ramps),
        _ => fit_k::<S, 7>(signals, omega, dt, mode, ramps),
    }
}

/// [`harmonic_fit`] of the signals less the ramps `ramps[j] (k - (n-1)/2)` (per sample, `None`:
/// none) and the first and second derivatives of its cost ([`HarmonicFit::cost`]) with
/// respect to `omega`, exactly (variable projection).
fn harmonic_fit_with_slope<const S: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
    k_max: usize,
    ramps: Option<[f64; S]>,
) -> Option<(HarmonicFit<S>, f64, f64)> {
    dispatch(signals, omega, dt, k_max, Mode::FrequencySlope, ramps).map(|p| (p.fit, p.d1, p.d2))
}

/// One pass of sums and the fit at `omega`; with [`Mode::FrequencySlope`], also the first and
/// second derivative of the cost in `omega` (returned as 0 otherwise); with [`Mode::Trend`] a
/// centred linear trend column `k - (n-1)/2` joins the regressors (its normal-matrix entries
/// are the same geometric sums).
///
/// `ramps` (per sample, per signal): with [`Mode::FrequencySlope`] the signals are fitted less
/// `ramps[j] (k - (n-1)/2)`, taken out on the fly; with [`Mode::Trend`] the signals are fitted
/// as they are and the pass also returns the cost of the plain fit of the signals less the
/// ramps (from the same sums: the ramp is the trend column); ignored with [`Mode::Plain`].
fn fit_k<const S: usize, const K: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
    mode: Mode,
    ramps: Option<[f64; S]>,
) -> Option<Pass<S>> {
    let slope = mode == Mode::FrequencySlope;
    let trend = mode == Mode::Trend;
    let n = signals.iter().map(|s| s.len()).min().unwrap_or(0);
    let m = 1 + 2 * K;
    let sums = Sums::<S>::of::<K>(
        signals,
        n,
        omega,
        dt,
        mode,
        if slope { ramps } else { None },
    );
    let theta = omega * dt;
    let g: Vec<[Complex64; 3]> = (0..=2 * K).map(|q| geometric_sums(n, theta, q)).collect();
    let (normal, r_trend) = normal_equations::<S, K>(&g, n, &sums, trend);
    let detrended_cost = match ramps {
        Some(ramps) if trend => detrended_cost::<S>(&normal, m, &sums.r, &r_trend, &sums.yy, ramps),
        _ => None,
    };
    let chol = normal.cholesky()?;
    let (fit, xs) = solve_harmonics::<S, K>(&chol, &sums, &r_trend, n, dt, trend);
    if !slope {
        return Some(Pass {
            fit,
            d1: 0.0,
            d2: 0.0,
            detrended_cost,
        });
    }
    let (d1, d2) = frequency_slopes::<S, K>(&g, dt, &sums, &xs, &chol);
    Some(Pass {
        fit,
        d1,
        d2,
        detrended_cost: None,
    })
}

/// The sums one pass over the samples accumulates: `r[j][a] = sum phi_a y_j`; with the
/// frequency slope also `u = sum t phi_a y_j` and `v = sum t^2 phi_a y_j` (signal-major, so
/// the per-sample updates run over contiguous regressors); with the trend column
/// `ky[j] = sum k y_j`; and `yy[j] = sum y_j^2`.
struct Sums<const S: usize> {
    r: [[f64; MAX_COLS]; S],
    u: [[f64; MAX_COLS]; S],
    v: [[f64; MAX_COLS]; S],
    yy: [f64; S],
    ky: [f64; S],
}

impl<const S: usize> Sums<S> {
    /// The sums over the first `n` samples of `signals` for `K` harmonics of `omega` (rad/s),
    /// sample interval `dt` (s), less `taken_out` ramps (per sample) when given.
    fn of<const K: usize>(
        signals: [&[f64]; S],
        n: usize,
        omega: f64,
        dt: f64,
        mode: Mode,
        taken_out: Option<[f64; S]>,
    ) -> Sums<S> {
        let mut s = Sums {
            r: [[0.0f64; MAX_COLS]; S],
            u: [[0.0f64; MAX_COLS]; S],
            v: [[0.0f64; MAX_COLS]; S],
            yy: [0.0; S],
            ky: [0.0; S],
        };
        let (r, u, v, yy, ky) = (&mut s.r, &mut s.u, &mut s.v, &mut s.yy, &mut s.ky);
        match (mode == Mode::FrequencySlope, mode == Mode::Trend) {
            (true, _) => {
                accumulate::<S, K, true, false>(signals, n, omega, dt, taken_out, r, u, v, yy, ky)
            }
            (false, true) => {
                accumulate::<S, K, false, true>(signals, n, omega, dt, None, r, u, v, yy, ky)
            }
            (false, false) => {
                accumulate::<S, K, false, false>(signals, n, omega, dt, None, r, u, v, yy, ky)
            }
        }
        s
    }
}

/// The normal matrix of DC and `K` harmonics over `n` samples from the geometric sums `g`
/// and, with `trend`, the centred trend column `k - (n-1)/2` joined to it, with that
/// column's right-hand sides `r_trend[j] = sum (k - c) y_j[k]` (zero without a trend).
fn normal_equations<const S: usize, const K: usize>(
    g: &[[Complex64; 3]],
    n: usize,
    sums: &Sums<S>,
    trend: bool,
) -> (nalgebra::DMatrix<f64>, [f64; S]) {
    let m = 1 + 2 * K;
    let e0: Vec<Complex64> = g.iter().map(|g| g[0]).collect();
    let nf = n as f64;
    let c = (nf - 1.0) / 2.0;
    let mut normal = regressor_matrix(&e0, K);
    let mut r_trend = [0.0; S];
    if trend {
        let mm = m + 1;
        normal = normal.resize(mm, mm, 0.0);
        normal[(m, m)] = nf * (nf * nf - 1.0) / 12.0;
        for h in 1..=K {
            let z = g[h][1] - c * g[h][0];
            normal[(m, 2 * h - 1)] = z.im;
            normal[(2 * h - 1, m)] = z.im;
            normal[(m, 2 * h)] = z.re;
            normal[(2 * h, m)] = z.re;
        }
        for j in 0..S {
            r_trend[j] = sums.ky[j] - c * sums.r[j][0];
        }
    }
    (normal, r_trend)
}

/// Solves the normal equations (factored in `chol`) for every signal: the fit, and each
/// signal's coefficient vector (DC, then sin and cos of each harmonic, then the trend).
fn solve_harmonics<const S: usize, const K: usize>(
    chol: &nalgebra::Cholesky<f64, nalgebra::Dyn>,
    sums: &Sums<S>,
    r_trend: &[f64; S],
    n: usize,
    dt: f64,
    trend: bool,
) -> (HarmonicFit<S>, Vec<nalgebra::DVector<f64>>) {
    let m = 1 + 2 * K;
    let nf = n as f64;
    let cols = chol.l_dirty().nrows();
    let unit = |a: usize| {
        let mut e = nalgebra::DVector::zeros(cols);
        e[a] = 1.0;
        chol.solve(&e)[a]
    };
    let inv_diag_h1 = [unit(1), unit(2)];
    let inv_diag_trend = if trend { unit(m) / (dt * dt) } else { 0.0 };
    let mut harmonics: [Vec<Complex64>; S] = std::array::from_fn(|_| Vec::new());
    let mut noise_var = [0.0; S];
    let mut rss = [0.0; S];
    let mut trends = [0.0; S];
    let mut dcs = [0.0; S];
    let mut xs = Vec::with_capacity(S);
    for j in 0..S {
        let rj = nalgebra::DVector::from_iterator(
            cols,
            (0..cols).map(|a| if a < m { sums.r[j][a] } else { r_trend[j] }),
        );
        let x = chol.solve(&rj);
        rss[j] = (sums.yy[j] - x.dot(&rj)).max(0.0);
        noise_var[j] = rss[j] / (nf - cols as f64).max(1.0);
        harmonics[j] = (0..K)
            .map(|h| Complex64::new(x[1 + 2 * h], x[2 + 2 * h]))
            .collect();
        dcs[j] = x[0];
        if trend {
            trends[j] = x[m] / dt;
        }
        xs.push(x);
    }
    let fit = HarmonicFit {
        harmonics,
        noise_var,
        rss,
        yy: sums.yy,
        dc: dcs,
        trend: trends,
        inv_diag_h1,
        inv_diag_trend,
        n,
    };
    (fit, xs)
}

/// The first and second derivative in the frequency of the cost summed over the signals
/// (each relative to its `yy`), from the geometric sums `g`, the sums `u`, `v` and the
/// solutions `xs` of the normal equations factored in `chol`.
fn frequency_slopes<const S: usize, const K: usize>(
    g: &[[Complex64; 3]],
    dt: f64,
    sums: &Sums<S>,
    xs: &[nalgebra::DVector<f64>],
    chol: &nalgebra::Cholesky<f64, nalgebra::Dyn>,
) -> (f64, f64) {
    let m = 1 + 2 * K;
    // d/domega of sum_k e^{i q omega dt k} is i q dt G_1(q); the second derivative
    // -(q dt)^2 G_2(q).
    let e1: Vec<Complex64> = (0..=2 * K)
        .map(|q| Complex64::new(0.0, q as f64 * dt) * g[q][1])
        .collect();
    let e2: Vec<Complex64> = (0..=2 * K)
        .map(|q| -(q as f64 * dt).powi(2) * g[q][2])
        .collect();
    let (m1, m2) = (regressor_matrix(&e1, K), regressor_matrix(&e2, K));
    // With f = r^T M^-1 r = yy - rss and x = M^-1 r:
    // f' = 2 r'.x - x^T M' x, f'' = 2 r''.x - x^T M'' x + 2 g^T M^-1 g, g = r' - M' x.
    // d sin(h w t)/dw = h t cos(h w t), d cos(h w t)/dw = -h t sin(h w t).
    let (mut d1, mut d2) = (0.0, 0.0);
    for j in 0..S {
        let x = &xs[j];
        let mut r1 = nalgebra::DVector::zeros(m);
        let mut r2 = nalgebra::DVector::zeros(m);
        for h in 1..=K {
            let (sa, ca) = (2 * h - 1, 2 * h);
            let hf = h as f64;
            r1[sa] = hf * sums.u[j][ca];
            r1[ca] = -hf * sums.u[j][sa];
            r2[sa] = -hf * hf * sums.v[j][sa];
            r2[ca] = -hf * hf * sums.v[j][ca];
        }
        let m1x = &m1 * x;
        let gj = &r1 - &m1x;
        let f1 = 2.0 * r1.dot(x) - x.dot(&m1x);
        let f2 = 2.0 * r2.dot(x) - x.dot(&(&m2 * x)) + 2.0 * gj.dot(&chol.solve(&gj));
        let scale = sums.yy[j].max(1e-300);
        d1 -= f1 / scale;
        d2 -= f2 / scale;
    }
    (d1, d2)
}

/// The cost ([`HarmonicFit::cost`]) of the plain fit of the signals less the ramps
/// `ramps[j] (k - c)`, from the sums of a trend pass over the signals as they are: the ramp is
/// the trend column, so its sums are the trend column's normal-matrix entries (`normal` is the
/// trend fit's, `m` its harmonic block's size).
fn detrended_cost<const S: usize>(
    normal: &nalgebra::DMatrix<f64>,
    m: usize,
    r: &[[f64; MAX_COLS]; S],
    r_trend: &[f64; S],
    yy: &[f64; S],
    ramps: [f64; S],
) -> Option<f64> {
    let chol = normal.view((0, 0), (m, m)).clone_owned().cholesky()?;
    let mut cost = 0.0;
    for j in 0..S {
        let s = ramps[j];
        let rd = nalgebra::DVector::from_fn(m, |a, _| r[j][a] - s * normal[(m, a)]);
        let yyd = yy[j] - 2.0 * s * r_trend[j] + s * s * normal[(m, m)];
        let x = chol.solve(&rd);
        cost += (yyd - x.dot(&rd)).max(0.0) / yyd.max(1e-300);
    }
    Some(cost)
}

/// The data sums of [`fit_k`]: `r[j][a] = sum_k phi_a(k) y_j[k]` and, with `SLOPE`, the same
/// weighted by `t_k` (`u`) and `t_k^2` (`v`), `t_k = k dt`; `yy[j] = sum y_j^2`.
/// With `TREND`, `ky[j] = sum_k k y_j[k]`; with `ramps`, `y_j[k]` is the signal less
/// `ramps[j] (k - (n-1)/2)`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn accumulate<const S: usize, const K: usize, const SLOPE: bool, const TREND: bool>(
    signals: [&[f64]; S],
    n: usize,
    omega: f64,
    dt: f64,
    ramps: Option<[f64; S]>,
    r: &mut [[f64; MAX_COLS]; S],
    u: &mut [[f64; MAX_COLS]; S],
    v: &mut [[f64; MAX_COLS]; S],
    yy: &mut [f64; S],
    ky: &mut [f64; S],
) {
    let mut phi = [0.0f64; MAX_COLS];
    // Sliced to exactly n so that the per-sample reads need no bounds checks.
    let signals = signals.map(|s| &s[..n]);
    let centre = (n as f64 - 1.0) / 2.0;
    let ramps = ramps.unwrap_or([0.0; S]);
    let (ds, dc) = (omega * dt).sin_cos();
    let (mut s1, mut c1) = (0.0f64, 1.0f64);
    for k in 0..n {
        if k % RESYNC == 0 {
            (s1, c1) = (omega * k as f64 * dt).sin_cos();
        }
        let (mut sk, mut ck) = (s1, c1);
        for h in 0..K {
            phi[1 + 2 * h] = sk;
            phi[2 + 2 * h] = ck;
            let ns = sk * c1 + ck * s1;
            ck = ck * c1 - sk * s1;
            sk = ns;
        }
        let t = k as f64 * dt;
        let kf = k as f64;
        for j in 0..S {
            let y = signals[j][k] - ramps[j] * (kf - centre);
            if TREND {
                ky[j] += kf * y;
            }
            yy[j] += y * y;
            r[j][0] += y;
            for a in 1..1 + 2 * K {
                r[j][a] += phi[a] * y;
            }
            if SLOPE {
                let ty = t * y;
                let tty = t * ty;
                for a in 1..1 + 2 * K {
                    u[j][a] += phi[a] * ty;
                    v[j][a] += phi[a] * tty;
                }
            }
        }
        let ns = s1 * dc + c1 * ds;
        c1 = c1 * dc - s1 * ds;
        s1 = ns;
    }
}

/// Variable projection on the frequency: the summed normalised residual of the harmonic fit
/// ([`HarmonicFit::cost`]) is minimised over `omega` by one Newton step from `omega0`, with
/// its exact first and second derivatives from the same pass of sums as the fit at `omega0`
/// (the step is clamped to two tenths of the record's frequency resolution, and kept only if
/// it lowers the residual).
///
/// The cost is that of the signals less the trend `trend` fitted at `omega0` (per second, as
/// in [`HarmonicFit::trend`]; taken out on the fly, around the slice's middle). Returns the
/// frequency and, if it moved, the fit with the trend column of the signals as they are at the
/// new frequency ([`harmonic_fit_trend`], from the same pass as the step's check); `None` means
/// the frequency stayed at `omega0`, whose trend fit the caller has.
pub(crate) fn refine_frequency<const S: usize>(
    signals: [&[f64]; S],
    trend: [f64; S],
    omega0: f64,
    dt: f64,
    k_max: usize,
) -> Option<(f64, Option<HarmonicFit<S>>)> {
    let n = signals[0].len();
    let ramps = trend.map(|r| r * dt);
    let (f0, d1, d2) = harmonic_fit_with_slope(signals, omega0, dt, k_max, Some(ramps))?;
    let span = n as f64 * dt;
    // A tenth of the frequency resolution of the record.
    let delta = 0.1 * 2.0 * PI / span;
    if d2 > 0.0 {
        let step = (-d1 / d2).clamp(-2.0 * delta, 2.0 * delta);
        if step.abs() > 1e-6 * delta {
            let w = omega0 + step;
            let pass = dispatch(signals, w, dt, k_max, Mode::Trend, Some(ramps))?;
            if pass.detrended_cost? < f0.cost() {
                return Some((w, Some(pass.fit)));
            }
        }
    }
    Some((omega0, None))
}

#[cfg(test)]
mod tests;
