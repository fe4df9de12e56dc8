//! The residual of a record's harmonic fit and its power in frequency bins near zero
//! frequency: the noise a fitted trend sees (its standard error, `noise` step 3).
//!
//! The steady state is a whole number of periods, so every harmonic of the excitation sits on
//! a Fourier bin of the slice and the other bins are orthogonal to all of them: a bin clear of
//! every harmonic (not only of the fitted ones) holds noise alone, however distorted the
//! response. Its power per sample, `|sum_k e_k e^{-i W k dt}|^2 / n`, is the noise's power
//! per sample at `W` (for white noise of variance `s^2`, `s^2` in every bin), with two
//! degrees of freedom.

use super::super::sine::HarmonicFit;
use std::f64::consts::PI;

/// Bins near zero frequency taken per record.
pub(crate) const BINS: usize = 8;

/// The bin frequencies (rad/s) near zero frequency for a slice of `n` samples at `dt` with the
/// excitation at `omega`: whole multiples of the slice's resolution `2 pi/(n dt)` from three
/// of it (the trend column leaks into the lowest two), below Nyquist, clear of every harmonic
/// of `omega` (on a slice of a whole number of periods a bin is clear when it is not the
/// harmonic's own; otherwise it must be at least one and a half bins from it, where the
/// harmonic's leakage is negligible); the first [`BINS`] of them.
pub(crate) fn zero_bin_frequencies(n: usize, dt: f64, omega: f64) -> Vec<f64> {
    let res = 2.0 * PI / (n as f64 * dt);
    let nyq = PI / dt;
    let p = omega / res;
    let whole = p.round() >= 1.0 && (p - p.round()).abs() < 0.05;
    let gap = if whole { 0.5 } else { 1.5 };
    let clear = |w: f64| {
        // The nearest harmonic (every one, up to Nyquist), not only the fitted ones.
        let h = (w / omega).round().max(1.0);
        w > 2.5 * res && w < nyq - res && (w - h * omega).abs() >= gap * res
    };
    (3..)
        .take(8 * BINS)
        .map(|m| m as f64 * res)
        .filter(|&w| clear(w))
        .take(BINS)
        .collect()
}

/// Power per sample of each of the `S` residuals (signal after signal in `e`, `n` samples
/// each) at each bin frequency `bins` (rad/s): Goertzel's recursion, [`GROUP`] bins per pass.
pub(crate) fn bin_powers<const S: usize>(
    e: &[f64],
    n: usize,
    bins: &[f64],
    dt: f64,
) -> [Vec<f64>; S] {
    let angles: Vec<f64> = bins.iter().map(|w| w * dt).collect();
    std::array::from_fn(|j| {
        let e = &e[j * n..(j + 1) * n];
        angles
            .chunks(GROUP)
            .flat_map(|group| goertzel_power(e, group))
            .map(|p| p / n as f64)
            .collect()
    })
}

/// Harmonics a residual is computed with, at most (harmonic fits have at most seven).
const MAX_HARMONICS: usize = 8;

/// The residual of each signal's fit over its first `n` samples, signal after signal in one
/// vector. Each fitted harmonic `re sin(h w t) + im cos(h w t)` follows the recursion
/// `x_{k+1} = 2 cos(h w dt) x_k - x_{k-1}`, restarted from exact values every 1024 samples;
/// the signals' and harmonics' recursions run side by side.
pub(crate) fn residuals<const S: usize>(
    signals: [&[f64]; S],
    fit: &HarmonicFit<S>,
    omega: f64,
    dt: f64,
    n: usize,
) -> Vec<f64> {
    // Dispatch on the harmonic count so the per-sample loops unroll.
    match fit.harmonics[0].len() {
        0 => residuals_k::<S, 0>(signals, fit, omega, dt, n),
        1 => residuals_k::<S, 1>(signals, fit, omega, dt, n),
        2 => residuals_k::<S, 2>(signals, fit, omega, dt, n),
        3 => residuals_k::<S, 3>(signals, fit, omega, dt, n),
        4 => residuals_k::<S, 4>(signals, fit, omega, dt, n),
        5 => residuals_k::<S, 5>(signals, fit, omega, dt, n),
        6 => residuals_k::<S, 6>(signals, fit, omega, dt, n),
        7 => residuals_k::<S, 7>(signals, fit, omega, dt, n),
        _ => residuals_k::<S, MAX_HARMONICS>(signals, fit, omega, dt, n),
    }
}

fn residuals_k<const S: usize, const K: usize>(
    signals: [&[f64]; S],
    fit: &HarmonicFit<S>,
    omega: f64,
    dt: f64,
    n: usize,
) -> Vec<f64> {
    let c = (n as f64 - 1.0) / 2.0;
    let theta = omega * dt;
    let mut coef = [0.0f64; K];
    for (h, co) in coef.iter_mut().enumerate() {
        *co = 2.0 * ((h + 1) as f64 * theta).cos();
    }
    let value = |j: usize, h: usize, k: f64| {
        let (sn, cs) = ((h + 1) as f64 * theta * k).sin_cos();
        let p = fit.harmonics[j][h];
        p.re * sn + p.im * cs
    };
    let mut e = vec![0.0f64; S * n];
    let mut x = [[0.0f64; K]; S];
    let mut xp = [[0.0f64; K]; S];
    let signals = signals.map(|s| &s[..n]);
    for from in (0..n).step_by(1024) {
        for j in 0..S {
            for h in 0..K {
                x[j][h] = value(j, h, from as f64);
                xp[j][h] = value(j, h, from as f64 - 1.0);
            }
        }
        for k in from..n.min(from + 1024) {
            let t = (k as f64 - c) * dt;
            for j in 0..S {
                let mut f = fit.dc[j] + fit.trend[j] * t;
                for h in 0..K {
                    f += x[j][h];
                    let next = coef[h] * x[j][h] - xp[j][h];
                    xp[j][h] = x[j][h];
                    x[j][h] = next;
                }
                e[j * n + k] = signals[j][k] - f;
            }
        }
    }
    e
}

/// Bins whose Goertzel recursions run side by side in one pass over a residual (independent
/// chains: the pass is bound by throughput, not by the latency of one recursion).
const GROUP: usize = 8;

/// `|sum_k x_k e^{-i a k}|^2` for each angle `a` of `angles` (at most [`GROUP`]), by
/// Goertzel's recursion `s_k = x_k + 2 cos(a) s_{k-1} - s_{k-2}`; the power from the last two
/// states as `(s1 - s2)^2 + 4 sin^2(a/2) s1 s2`, which keeps its precision at small angles.
fn goertzel_power(x: &[f64], angles: &[f64]) -> Vec<f64> {
    debug_assert!(angles.len() <= GROUP);
    let mut coef = [0.0f64; GROUP];
    for (c, a) in coef.iter_mut().zip(angles) {
        *c = 2.0 * a.cos();
    }
    let mut s1 = [0.0f64; GROUP];
    let mut s2 = [0.0f64; GROUP];
    // Two samples per step, so the states trade places without copies.
    let mut pairs = x.chunks_exact(2);
    for pair in &mut pairs {
        let (xa, xb) = (pair[0], pair[1]);
        for g in 0..GROUP {
            let sa = xa + coef[g] * s1[g] - s2[g];
            s2[g] = xb + coef[g] * sa - s1[g];
            s1[g] = sa;
        }
        std::mem::swap(&mut s1, &mut s2);
    }
    for &xk in pairs.remainder() {
        for g in 0..GROUP {
            let s0 = xk + coef[g] * s1[g] - s2[g];
            s2[g] = s1[g];
            s1[g] = s0;
        }
    }
    angles
        .iter()
        .enumerate()
        .map(|(g, a)| {
            let h = (0.5 * a).sin();
            (s1[g] - s2[g]).powi(2) + 4.0 * h * h * s1[g] * s2[g]
        })
        .collect()
}

/// Highest harmonic taken out of a residual before its noise is read ([`remove_harmonics`]).
pub(crate) const CLEAN_HARMONICS: usize = 15;

/// Takes harmonics `from..=to` of `omega` (those below nine tenths of Nyquist) out of each of
/// the `S` residuals in `e` (`n` samples each, phase zero at the first): each harmonic's sine
/// and cosine coefficient by projection, `(2/n) sum e_k sin(h omega k dt)` (the least-squares
/// value over whole periods, where the columns are orthogonal), then subtracted. A distorted
/// response (a play's flanks, a clamped acceleration) keeps harmonics far above the fitted
/// ones in the residual; over a period that is not a whole number of samples they leak into
/// each period's phasor differently from period to period (the first harmonic's own leakage
/// was 3-100 times the noise on the clamped records at 15 rad/s of the independent
/// simulator's clean robots) and, through the window's few samples beyond whole periods,
/// into the bins near zero frequency.
pub(crate) fn remove_harmonics<const S: usize>(
    e: &mut [f64],
    n: usize,
    omega: f64,
    dt: f64,
    from: usize,
    to: usize,
) {
    let top = ((0.9 * PI / dt) / omega).floor() as usize;
    let to = to.min(top);
    if from > to || n == 0 {
        return;
    }
    let hs: Vec<usize> = (from..=to).collect();
    let mut coef = vec![[(0.0f64, 0.0f64); S]; hs.len()];
    harmonic_pass(n, omega, dt, &hs, |k, h, s, c| {
        for (j, cj) in coef[h].iter_mut().enumerate() {
            let v = e[j * n + k];
            cj.0 += v * s;
            cj.1 += v * c;
        }
    });
    let scale = 2.0 / n as f64;
    for c in coef.iter_mut().flatten() {
        c.0 *= scale;
        c.1 *= scale;
    }
    harmonic_pass(n, omega, dt, &hs, |k, h, s, c| {
        for (j, cj) in coef[h].iter().enumerate() {
            e[j * n + k] -= cj.0 * s + cj.1 * c;
        }
    });
}

/// Calls `f(k, index, sin(h omega k dt), cos(h omega k dt))` for every sample `k < n` and every
/// harmonic `hs[index]`, the sines by rotation, exact every 1024 samples.
fn harmonic_pass(
    n: usize,
    omega: f64,
    dt: f64,
    hs: &[usize],
    mut f: impl FnMut(usize, usize, f64, f64),
) {
    let steps: Vec<(f64, f64)> = hs
        .iter()
        .map(|&h| (h as f64 * omega * dt).sin_cos())
        .collect();
    let mut state = vec![(0.0f64, 1.0f64); hs.len()];
    for k in 0..n {
        if k % 1024 == 0 {
            for (st, &h) in state.iter_mut().zip(hs) {
                *st = (h as f64 * omega * k as f64 * dt).sin_cos();
            }
        }
        for (i, (st, &(ds, dc))) in state.iter_mut().zip(&steps).enumerate() {
            f(k, i, st.0, st.1);
            *st = (st.0 * dc + st.1 * ds, st.1 * dc - st.0 * ds);
        }
    }
}

#[cfg(test)]
mod tests;
