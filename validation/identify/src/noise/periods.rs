//! The noise of a record from its period-to-period variation (Pintelon and Schoukens, System
//! Identification: A Frequency Domain Approach, the sample variance over periods): over the
//! `P` whole periods of a stepped sine's steady state the response (every harmonic, any
//! distortion) repeats, the noise does not.
//!
//! Per record and output: the residual of the record's harmonic fit (its DC, trend and fitted
//! harmonics taken out: a drifting sensor's ramp does not enter), less its moving average
//! over exactly one period, is split into its periods; each period's phasor at the excitation
//! and at three times it is projected, `X_p = (2/N_p) sum_{k in p} h_k e^{-i m omega t_k}`.
//! What repeats gives every period the same phasor (the moving average of a periodic signal is
//! periodic, so the filtered response still repeats); the sample variance of the `X_p` over
//! the periods is noise.
//!
//! **Why the moving average.** A window of one period is a broad filter: its sine column
//! leaks a slope within the period, and a noise correlated over longer than a period (a
//! force sensor's slow creep) is, at the scale of one period, mostly slope. The record's own
//! estimate over `P` periods with its trend column is blind to that slope; each period's is
//! not: without the filter the sample variance came out up to twice the record's variance at
//! 4-15 rad/s under a first-order noise of 0.8 s. The centred moving average over exactly one
//! period has a zero at every harmonic (so the response passes unchanged) and takes out what
//! varies slower than a period. At the two ends of the slice it is held at its first and last
//! full window.
//!
//! **A line over the periods, not their mean.** What repeats gives every period the same
//! phasor only at the true frequency. The residual is taken at the refined frequency, whose
//! error (its one Newton step is pulled by the outputs' noise) leaves the response's phasor
//! turning by `A dw T` per period: a linear drift over the periods, as a transient's last tail
//! or a slow change of gain is. On the golden campaign of `xtask/tests/golden_json.rs` (SILO2
//! with a delay, white noise 0.5 mm) frequencies refined 0.9-1.6e-3 rad/s off, on outputs of
//! 22-69 mm, put the sample variance about the mean of three records at 4-7 times the noise,
//! and those records were left out of the pool. The period phasors are therefore compared
//! with a straight line through them (least squares over the period index), not with their
//! mean: a drift linear in time is taken out, at the price of one degree of freedom per real
//! component; a record of two periods measures nothing (and takes the pooled noise).
//!
//! **From the sample variance to the noise's power.** Everything above is linear in the
//! residual: `X_p = v_p . e` with `v_p = (I - M)^T u_p` (`u_p` the projection's weights, `M`
//! the moving average). Under a noise of power `S` per sample near the frequency the residual
//! sum of squares about the line of one real component, over `P - 2`, has expectation `S F`,
//! `F = tr(R G)/(P - 2)` with `G_pq = v_p . v_q` (neighbouring periods share the filter's
//! window, so `G` is not diagonal) and `R = I - Q Q'` the projection off the line (`Q` the
//! orthonormal constant and centred index over the periods); `S` is the summed sample
//! variances of the sine and cosine parts over their summed `F`. Its degrees of freedom
//! (Satterthwaite) are `(sum F)^2 / sum tr((A G)^2)`, `A = R/(P - 2)`: `2(P - 2)` when the
//! periods are independent, somewhat fewer here.

use std::f64::consts::PI;

/// Whole periods a record needs to measure its own noise: a line through the periods' phasors
/// takes two of them.
pub(crate) const MIN_PERIODS: usize = 3;

/// The noise one record's periods measure, per output: its power per sample (m^2) at the
/// excitation and at three times it, with their degrees of freedom (the same for every output:
/// they depend on the slice alone).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PeriodNoise<const S: usize> {
    pub first: [f64; S],
    pub third: [f64; S],
    pub first_dof: f64,
    pub third_dof: f64,
}

/// The period-to-period noise of `S` residuals (signal after signal in `e`, `n` samples each,
/// the slice's first sample at phase zero) of a record whose steady state, sampled at `dt`,
/// is `periods` whole periods: each of `n / periods` samples, at the frequency
/// [`window_frequency`]. `None` below three periods (two periods and a line through them
/// leave no variation to measure) or when a period is too short to hold its phasors.
pub(crate) fn period_noise<const S: usize>(
    e: &[f64],
    n: usize,
    dt: f64,
    periods: usize,
) -> Option<PeriodNoise<S>> {
    if periods < MIN_PERIODS || e.len() < S * n {
        return None;
    }
    let per = n as f64 / periods as f64;
    let omega = window_frequency(n, dt, periods);
    if per < 8.0 {
        return None;
    }
    let bounds = period_bounds(n, per, periods);
    // The projections' weights, shared by every output: [sin w, cos w, sin 3w, cos 3w].
    let weights = projection_weights(&bounds, omega, dt);
    let mut first = [f64::NAN; S];
    let mut third = [f64::NAN; S];
    let mut h = vec![0.0; n];
    for j in 0..S {
        high_pass(&e[j * n..(j + 1) * n], per, &mut h);
        let s2 = sample_variances(&h, &bounds, &weights);
        first[j] = s2[0] + s2[1];
        third[j] = s2[2] + s2[3];
    }
    let factors: Vec<Factor> = weights.iter().map(|u| factor(u, &bounds, per)).collect();
    let f1 = factors[0].mean + factors[1].mean;
    let f3 = factors[2].mean + factors[3].mean;
    if !(f1 > 0.0 && f3 > 0.0) {
        return None;
    }
    Some(PeriodNoise {
        first: first.map(|v| v / f1),
        third: third.map(|v| v / f3),
        first_dof: f1 * f1 / (factors[0].spread + factors[1].spread),
        third_dof: f3 * f3 / (factors[2].spread + factors[3].spread),
    })
}

/// The frequency (rad/s) whose `periods` periods fill `n` samples at `dt`: the excitation's,
/// as the steady-state window was cut (the refined frequency of a record of two or three
/// periods moves with the noise by a good part of a Fourier bin, and would cut periods that
/// do not fit the window).
pub(crate) fn window_frequency(n: usize, dt: f64, periods: usize) -> f64 {
    2.0 * PI * periods as f64 / (n as f64 * dt)
}

/// Sample boundaries of the periods: `round(p per)`, the last at `n`.
fn period_bounds(n: usize, per: f64, periods: usize) -> Vec<usize> {
    let mut b: Vec<usize> = (0..periods)
        .map(|p| ((p as f64 * per).round() as usize).min(n))
        .collect();
    b.push(n);
    b
}

/// Per period, the projection weights `(2/N_p) sin(m omega t_k)` and `(2/N_p) cos(m omega t_k)`
/// for `m = 1, 3` over the period's samples (`t_k = k dt` from the slice's start): four
/// vectors over the whole slice, each period's part between its bounds.
fn projection_weights(bounds: &[usize], omega: f64, dt: f64) -> [Vec<f64>; 4] {
    let n = *bounds.last().expect("at least one bound");
    let mut w: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; n]);
    // sin and cos of omega t by rotation, exact every RESYNC samples; the third harmonic's from
    // them (sin 3x = 3 sin x - 4 sin^3 x, cos 3x = 4 cos^3 x - 3 cos x).
    const RESYNC: usize = 1024;
    let (ds, dc) = (omega * dt).sin_cos();
    let (mut s, mut c) = (0.0f64, 1.0f64);
    let mut scale = 0.0;
    let mut next_bound = 0;
    let mut p = 0;
    for k in 0..n {
        if k == next_bound {
            scale = 2.0 / (bounds[p + 1] - bounds[p]).max(1) as f64;
            next_bound = bounds[p + 1];
            p += 1;
        }
        if k % RESYNC == 0 {
            (s, c) = (omega * k as f64 * dt).sin_cos();
        }
        w[0][k] = scale * s;
        w[1][k] = scale * c;
        w[2][k] = scale * s * (3.0 - 4.0 * s * s);
        w[3][k] = scale * c * (4.0 * c * c - 3.0);
        (s, c) = (s * dc + c * ds, c * dc - s * ds);
    }
    w
}

/// The four real components' sample variances about a straight line over the periods of `h`
/// (residual sum of squares over `P - 2`).
fn sample_variances(h: &[f64], bounds: &[usize], weights: &[Vec<f64>; 4]) -> [f64; 4] {
    let periods = bounds.len() - 1;
    let mut x = vec![[0.0f64; 4]; periods];
    for (p, b) in bounds.windows(2).enumerate() {
        for k in b[0]..b[1] {
            let v = h[k];
            for c in 0..4 {
                x[p][c] += weights[c][k] * v;
            }
        }
    }
    let q = line_basis(periods);
    std::array::from_fn(|c| {
        let total: f64 = x.iter().map(|v| v[c] * v[c]).sum();
        let fitted: f64 = q
            .iter()
            .map(|col| {
                col.iter()
                    .zip(&x)
                    .map(|(a, v)| a * v[c])
                    .sum::<f64>()
                    .powi(2)
            })
            .sum();
        (total - fitted).max(0.0) / (periods - 2) as f64
    })
}

/// The orthonormal basis of a straight line over `periods` periods: the constant and the
/// centred period index, each of unit norm.
pub(crate) fn line_basis(periods: usize) -> [Vec<f64>; 2] {
    let pf = periods as f64;
    let mid = (pf - 1.0) / 2.0;
    let norm = (0..periods)
        .map(|p| (p as f64 - mid).powi(2))
        .sum::<f64>()
        .sqrt()
        .max(1e-300);
    [
        vec![1.0 / pf.sqrt(); periods],
        (0..periods).map(|p| (p as f64 - mid) / norm).collect(),
    ]
}

/// The moving average over exactly `per` samples (fractional at its ends), centred, held at
/// its first and last full window near the slice's ends: for sample `k` the window is
/// `[k + 1/2 - per/2, k + 1/2 + per/2)` in units where sample `j` covers `[j, j + 1)`.
struct Window {
    per: f64,
    n: usize,
}

impl Window {
    /// Start of row `k`'s window (clamped so that the window lies within the slice).
    fn start(&self, k: usize) -> f64 {
        (k as f64 + 0.5 - 0.5 * self.per).clamp(0.0, self.n as f64 - self.per)
    }
}

/// `out = x - M x`, `M` the moving average of [`Window`], by prefix sums.
pub(crate) fn high_pass(x: &[f64], per: f64, out: &mut [f64]) {
    let n = x.len();
    let mut c = Vec::with_capacity(n + 1);
    c.push(0.0);
    let mut acc = 0.0;
    for &v in x {
        acc += v;
        c.push(acc);
    }
    // Integral of the piecewise-constant x over [0, a).
    let integral = |a: f64| {
        let i = (a.floor() as usize).min(n);
        if i >= n {
            c[n]
        } else {
            c[i] + (a - i as f64) * x[i]
        }
    };
    let w = Window { per, n };
    for (k, o) in out.iter_mut().enumerate().take(n) {
        let a = w.start(k);
        *o = x[k] - (integral(a + per) - integral(a)) / per;
    }
}

/// `M^T u` for `u` nonzero only on `[a, b)`: what the moving average's rows `a..b` spread over
/// the samples, returned on `[lo, hi)` with `lo`.
fn spread(u: &[f64], a: usize, b: usize, per: f64) -> (usize, Vec<f64>) {
    let n = u.len();
    let w = Window { per, n };
    let reach = per.ceil() as usize + 1;
    let lo = a.saturating_sub(reach);
    let hi = (b + reach).min(n);
    let mut out = vec![0.0; hi - lo];
    // Row k adds u_k / per over [s, s + per): a box, added as a difference of two ramps
    // (of the integrated box) evaluated cell by cell through a second difference.
    let mut d = vec![0.0; hi - lo + 2];
    let mut add_box = |s: f64, weight: f64| {
        let e = s + per;
        for (x, sign) in [(s, 1.0), (e, -1.0)] {
            // The box's edge at x: cell floor(x) gets (1 - frac) of it, the next the rest.
            let i = x.floor() as usize;
            let f = x - i as f64;
            if i >= lo && i < hi + 1 {
                d[i - lo] += sign * weight * (1.0 - f);
            }
            if i + 1 >= lo && i + 1 < hi + 1 {
                d[i + 1 - lo] += sign * weight * f;
            }
        }
    };
    for (k, &uk) in u.iter().enumerate().take(b).skip(a) {
        if uk != 0.0 {
            add_box(w.start(k), uk / per);
        }
    }
    let mut acc = 0.0;
    for (o, dv) in out.iter_mut().zip(&d) {
        acc += dv;
        *o = acc;
    }
    (lo, out)
}

/// The white-noise expectation and spread of one real component's sample variance, per unit
/// noise power: `F = tr(R G)/(P - 2)` and `tr((A G)^2)`, `A = R/(P - 2)` (see the module
/// docs).
#[derive(Debug, Clone, Copy)]
struct Factor {
    mean: f64,
    spread: f64,
}

/// [`Factor`] of the projection weights `u` (one vector over the slice, each period's part
/// between its bounds).
fn factor(u: &[f64], bounds: &[usize], per: f64) -> Factor {
    let periods = bounds.len() - 1;
    // v_p = u_p - M^T u_p on a range around period p.
    let v: Vec<(usize, Vec<f64>)> = bounds
        .windows(2)
        .map(|b| {
            let (lo, mut s) = spread(u, b[0], b[1], per);
            for (i, sv) in s.iter_mut().enumerate() {
                let k = lo + i;
                let own = if k >= b[0] && k < b[1] { u[k] } else { 0.0 };
                *sv = own - *sv;
            }
            (lo, s)
        })
        .collect();
    let dot = |p: usize, q: usize| {
        let ((lp, vp), (lq, vq)) = (&v[p], &v[q]);
        let from = (*lp).max(*lq);
        let to = (lp + vp.len()).min(lq + vq.len());
        (from..to).map(|k| vp[k - lp] * vq[k - lq]).sum::<f64>()
    };
    // G is banded: a period's filtered weights reach half a period (and a sample) beyond it.
    const BAND: usize = 2;
    let mut g = vec![[0.0f64; BAND + 1]; periods];
    for p in 0..periods {
        for d in 0..=BAND.min(periods - 1 - p) {
            g[p][d] = dot(p, p + d);
        }
    }
    let entry = |p: usize, q: usize| {
        let (a, b) = if p <= q { (p, q) } else { (q, p) };
        if b - a <= BAND {
            g[a][b - a]
        } else {
            0.0
        }
    };
    // With R = I - Q Q': tr(R G) = tr G - sum_k q_k' G q_k and
    // tr((R G)^2) = tr(G^2) - 2 sum_k |G q_k|^2 + sum_kl (q_k' G q_l)^2.
    let mul = |x: &[f64]| -> Vec<f64> {
        (0..periods)
            .map(|p| {
                (p.saturating_sub(BAND)..(p + BAND + 1).min(periods))
                    .map(|q| entry(p, q) * x[q])
                    .sum()
            })
            .collect()
    };
    let dotv = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let basis = line_basis(periods);
    let gq: Vec<Vec<f64>> = basis.iter().map(|q| mul(q)).collect();
    let qgq: Vec<Vec<f64>> = basis
        .iter()
        .map(|q| gq.iter().map(|g| dotv(q, g)).collect())
        .collect();
    let trace: f64 = (0..periods).map(|p| g[p][0]).sum();
    let frob: f64 = (0..periods)
        .flat_map(|p| (p.saturating_sub(BAND)..(p + BAND + 1).min(periods)).map(move |q| (p, q)))
        .map(|(p, q)| entry(p, q).powi(2))
        .sum();
    let projected: f64 = (0..2).map(|k| qgq[k][k]).sum();
    let leaked: f64 = gq.iter().map(|g| dotv(g, g)).sum();
    let inner: f64 = qgq.iter().flatten().map(|v| v * v).sum();
    let dof = (periods - 2) as f64;
    Factor {
        mean: (trace - projected) / dof,
        spread: (frob - 2.0 * leaked + inner) / (dof * dof),
    }
}

#[cfg(test)]
mod tests;
