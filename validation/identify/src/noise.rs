//! The noise a record's first harmonic and trend actually see: the residual of the harmonic
//! fit, its power in frequency bins beside the excitation and near zero frequency.
//!
//! White noise makes every bin equal to the residual variance, and the usual least-squares
//! variances follow; coloured noise (a sensor filter, vibration, slow creep of the force
//! sensors) puts more power at some frequencies than at others, and a variance computed from
//! the overall residual would be wrong there by the same factor. Each bin's power over its
//! record's residual variance is a sample of the noise's colour **at the bin's own
//! frequency**; [`pool_ratios`] pools these samples over the records of a campaign (one
//! sensor, one noise) by frequency, so that each record's variance is its own residual
//! variance times a smooth, well-determined colour factor at its excitation frequency.
//!
//! The steady state is a whole number of periods, so the fitted harmonics sit on the slice's
//! Fourier bins and the other bins are orthogonal to them: the bins next to the excitation are
//! usable. On a record of two or three periods they are the only bins near its frequency
//! (bins two away from every harmonic, the rule for slices of a fractional number of periods,
//! start above four times the excitation, where a first-order noise is already several times
//! weaker: the first harmonic's standard error came out 2-4 times too small at 0.5-2 rad/s).

use super::sine::HarmonicFit;
use std::f64::consts::PI;

/// Bins on each side of the excitation (and near zero frequency) averaged per record.
pub(crate) const BINS: usize = 8;

/// Mean power per sample of a residual, `|sum_k e_k e^{-i W k dt}|^2 / n`, in bins beside the
/// excitation and near zero frequency (averages, and each bin as `(frequency, power)`); for
/// white noise every bin equals its variance.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LocalNoise {
    pub near_omega: f64,
    pub near_zero: f64,
    pub near_bins: Vec<(f64, f64)>,
    pub zero_bins: Vec<(f64, f64)>,
}

/// The bin frequencies (rad/s) used beside `omega` and near zero for a slice of `n` samples at
/// `dt` fitted with `k_max` harmonics: whole multiples of the slice's resolution `2 pi/(n dt)`
/// above two and a half of it (the trend column leaks into the lowest) and below Nyquist.
/// On a slice of a whole number of periods every bin but the fitted harmonics' own
/// (0, omega, ..., (k_max + 1) omega) is clear; otherwise a bin must be at least one and a
/// half bins from each of them (the fitted columns' leakage is then negligible). Beside
/// `omega`: the [`BINS`] pairs nearest to it.
pub(crate) fn bin_frequencies(n: usize, dt: f64, omega: f64, k_max: usize) -> (Vec<f64>, Vec<f64>) {
    let res = 2.0 * PI / (n as f64 * dt);
    let nyq = PI / dt;
    let p = omega / res;
    let whole = p.round() >= 1.0 && (p - p.round()).abs() < 0.05;
    let gap = if whole { 0.5 } else { 1.5 };
    let clear = |w: f64| {
        w > 2.5 * res
            && w < nyq - res
            && (1..=k_max + 1).all(|h| (w - h as f64 * omega).abs() >= gap * res)
    };
    let first = if whole { 1 } else { 2 };
    let mut near = Vec::new();
    for m in first..(first + 3 * BINS) {
        for w in [omega + m as f64 * res, omega - m as f64 * res] {
            if near.len() < 2 * BINS && clear(w) {
                near.push(w);
            }
        }
    }
    let mut zero = Vec::new();
    for m in 3..(3 + 3 * BINS) {
        let w = m as f64 * res;
        if zero.len() < BINS && clear(w) {
            zero.push(w);
        }
    }
    (near, zero)
}

/// Residual power of each signal of a harmonic fit (with or without trend) in the bins of
/// [`bin_frequencies`]: the residual once per signal (the fit's harmonics by recurrence), then
/// every bin's power by Goertzel's recursion, [`GROUP`] bins per pass.
pub(crate) fn local_noise<const S: usize>(
    signals: [&[f64]; S],
    fit: &HarmonicFit<S>,
    omega: f64,
    dt: f64,
) -> [LocalNoise; S] {
    let n = fit
        .n
        .min(signals.iter().map(|s| s.len()).min().unwrap_or(0));
    let k_max = fit.harmonics[0].len();
    let (near, zero) = bin_frequencies(n, dt, omega, k_max);
    let bins: Vec<f64> = near.iter().chain(zero.iter()).copied().collect();
    let nb = bins.len();
    let mut out: [LocalNoise; S] = std::array::from_fn(|_| LocalNoise {
        near_omega: f64::NAN,
        near_zero: f64::NAN,
        near_bins: Vec::new(),
        zero_bins: Vec::new(),
    });
    if nb == 0 || n == 0 {
        return out;
    }
    let angles: Vec<f64> = bins.iter().map(|w| w * dt).collect();
    let e = residuals(signals, fit, omega, dt, n);
    for (j, o) in out.iter_mut().enumerate() {
        let e = &e[j * n..(j + 1) * n];
        let power: Vec<f64> = angles
            .chunks(GROUP)
            .flat_map(|group| goertzel_power(e, group))
            .map(|p| p / n as f64)
            .collect();
        o.near_bins = (0..near.len()).map(|b| (bins[b], power[b])).collect();
        o.zero_bins = (near.len()..nb).map(|b| (bins[b], power[b])).collect();
        if !near.is_empty() {
            o.near_omega = power[..near.len()].iter().sum::<f64>() / near.len() as f64;
        }
        if !zero.is_empty() {
            o.near_zero = power[near.len()..].iter().sum::<f64>() / zero.len() as f64;
        }
    }
    out
}

/// Harmonics a residual is computed with, at most (harmonic fits have at most seven).
const MAX_HARMONICS: usize = 8;

/// The residual of each signal's fit over its first `n` samples, signal after signal in one
/// vector. Each fitted harmonic `re sin(h w t) + im cos(h w t)` follows the recursion
/// `x_{k+1} = 2 cos(h w dt) x_k - x_{k-1}`, restarted from exact values every 1024 samples;
/// the signals' and harmonics' recursions run side by side.
fn residuals<const S: usize>(
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

/// Bins behind a pooled colour factor, at least (a single bin's power scatters like an
/// exponential variable: 96 of them give the mean to about 10 %).
pub(crate) const POOL_MIN_BINS: usize = 96;

/// One record's colour sample: at `omega` (rad/s), the local power over the residual variance
/// and the number of bins it averages.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ColourSample {
    pub omega: f64,
    pub ratio: f64,
    pub bins: usize,
}

/// Pools colour samples over records by frequency: for each query frequency, the samples within
/// a factor `1.5` in frequency (at least the nearest holding [`POOL_MIN_BINS`] bins),
/// their ratio fitted linearly in the log of the frequency and read at the query. White
/// noise gives about 1 everywhere; a record's variance is its residual variance times the
/// pooled ratio at its frequency. Samples that are not finite are ignored;
/// with none left the factor is 1.
pub(crate) fn pool_ratios(samples: &[ColourSample], queries: &[f64]) -> Vec<f64> {
    // Sorted once by log frequency; each query takes a contiguous run around its position.
    let mut good: Vec<(f64, &ColourSample)> = samples
        .iter()
        .filter(|s| s.ratio.is_finite() && s.ratio > 0.0 && s.omega > 0.0 && s.bins > 0)
        .map(|s| (s.omega.ln(), s))
        .collect();
    good.sort_by(|a, b| a.0.total_cmp(&b.0));
    let window = 1.5f64.ln();
    queries
        .iter()
        .map(|&w| {
            if good.is_empty() || w.is_nan() || w <= 0.0 {
                return 1.0;
            }
            let lw = w.ln();
            let dist = |k: usize| (good[k].0 - lw).abs();
            // [lo, hi): the samples within the window ...
            let mut lo = good.partition_point(|g| g.0 < lw - window);
            let mut hi = good.partition_point(|g| g.0 <= lw + window);
            let mut held: usize = good[lo..hi].iter().map(|g| g.1.bins).sum();
            // ... widened to the nearest until they hold enough bins; samples as far as the
            // last one taken are taken too (the result does not depend on their order).
            while held < POOL_MIN_BINS && (lo > 0 || hi < good.len()) {
                let d = match (lo > 0, hi < good.len()) {
                    (true, true) => dist(lo - 1).min(dist(hi)),
                    (true, false) => dist(lo - 1),
                    _ => dist(hi),
                };
                while lo > 0 && dist(lo - 1) <= d {
                    lo -= 1;
                    held += good[lo].1.bins;
                }
                while hi < good.len() && dist(hi) <= d {
                    held += good[hi].1.bins;
                    hi += 1;
                }
            }
            // Weighted least squares of the ratio on ln(frequency / query): the intercept is
            // the colour at the query even when the samples lie on one side of it (the lowest
            // excitation has bins only above it) and the noise's spectrum slopes there. Kept
            // within half and twice the samples' mean.
            let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for (lg, s) in &good[lo..hi] {
                let (b, xi) = (s.bins as f64, lg - lw);
                sw += b;
                sx += b * xi;
                sy += b * s.ratio;
                sxx += b * xi * xi;
                sxy += b * xi * s.ratio;
            }
            if sw <= 0.0 {
                return 1.0;
            }
            let mean = sy / sw;
            let var_x = sxx / sw - (sx / sw).powi(2);
            if var_x < 1e-4 {
                return mean;
            }
            let slope = (sxy / sw - (sx / sw) * mean) / var_x;
            (mean - slope * sx / sw).clamp(0.5 * mean, 2.0 * mean)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::sine::harmonic_fit_trend;
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    fn noisy(n: usize, omega: f64, dt: f64, std: f64, pole: f64, seed: u64) -> Vec<f64> {
        // First-order filtered (pole in [0, 1): 0 is white) Gaussian noise of the given
        // standard deviation, on a sine with a third harmonic and a ramp.
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let g = Normal::new(0.0, 1.0).unwrap();
        let scale = std * (1.0 - pole * pole).sqrt();
        let mut e = 0.0;
        (0..n)
            .map(|k| {
                let t = k as f64 * dt;
                e = pole * e + scale * g.sample(&mut rng);
                0.004 * (omega * t).sin() + 0.0005 * (3.0 * omega * t).cos() + 2e-4 * t + e
            })
            .collect()
    }

    #[test]
    fn goertzel_power_matches_a_direct_sum() {
        // A slow ramp, an offset and a tone (harder than a residual, whose mean and trend are
        // fitted out); angles from a few bins of a long record up to near Nyquist. A bin's
        // power scatters by 100 % (an exponential variable): 1e-7 is far below what matters.
        for n in [7usize, 3000, 20000] {
            let x: Vec<f64> = (0..n)
                .map(|k| {
                    1e-3 * k as f64 / n as f64
                        + (0.37 * k as f64).sin()
                        + ((k * 7919) % 13) as f64 * 0.01
                })
                .collect();
            let angles: Vec<f64> = [3.0, 4.5, 10.0]
                .iter()
                .map(|m| 2.0 * PI * m / n as f64)
                .chain([0.37, 0.4, 3.1])
                .collect();
            let got: Vec<f64> = angles
                .chunks(GROUP)
                .flat_map(|g| goertzel_power(&x, g))
                .collect();
            for (a, p) in angles.iter().zip(&got) {
                let (mut re, mut im) = (0.0, 0.0);
                for (k, xk) in x.iter().enumerate() {
                    let (s, c) = (a * k as f64).sin_cos();
                    re += xk * c;
                    im -= xk * s;
                }
                let want = re * re + im * im;
                let scale = x.iter().map(|v| v * v).sum::<f64>();
                assert!(
                    (p - want).abs() <= 1e-7 * want + 1e-12 * scale,
                    "n {n} angle {a}: {p} against {want}"
                );
            }
        }
    }

    #[test]
    fn every_bin_matches_the_residual_summed_directly() {
        // The residual evaluated term by term and each bin's sum with exact sines: what the
        // recursions (harmonics, Goertzel) must give, on whole and fractional periods.
        for (n, omega) in [(6000usize, 2.0), (3771, 2.3), (1200, 15.0)] {
            let dt = 0.005;
            let y = noisy(n, omega, dt, 5e-4, 0.6, 7);
            let fit = harmonic_fit_trend([&y[..]], omega, dt, 3).unwrap();
            let [ln] = local_noise([&y[..]], &fit, omega, dt);
            let c = (n as f64 - 1.0) / 2.0;
            let e: Vec<f64> = (0..n)
                .map(|k| {
                    let mut f = fit.dc[0] + fit.trend[0] * (k as f64 - c) * dt;
                    for (h, p) in fit.harmonics[0].iter().enumerate() {
                        let (sn, cs) = ((h + 1) as f64 * omega * k as f64 * dt).sin_cos();
                        f += p.re * sn + p.im * cs;
                    }
                    y[k] - f
                })
                .collect();
            for &(w, p) in ln.near_bins.iter().chain(&ln.zero_bins) {
                let (mut re, mut im) = (0.0, 0.0);
                for (k, ek) in e.iter().enumerate() {
                    let (sn, cs) = (w * k as f64 * dt).sin_cos();
                    re += ek * cs;
                    im -= ek * sn;
                }
                let want = (re * re + im * im) / n as f64;
                assert!(
                    (p - want).abs() <= 1e-6 * want,
                    "n {n} omega {omega} bin {w}: {p:e} against {want:e}"
                );
            }
        }
    }

    #[test]
    fn white_noise_has_equal_power_in_every_bin() {
        let (dt, omega, n) = (0.005, 2.0, 6000);
        let mut r_near = Vec::new();
        let mut r_zero = Vec::new();
        for seed in 0..40 {
            let y = noisy(n, omega, dt, 5e-4, 0.0, seed);
            let fit = harmonic_fit_trend([&y[..]], omega, dt, 3).unwrap();
            let [ln] = local_noise([&y[..]], &fit, omega, dt);
            r_near.push(ln.near_omega / fit.noise_var[0]);
            r_zero.push(ln.near_zero / fit.noise_var[0]);
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        // 40 records x 16 (8) bins of exponential power: the mean is within a few percent.
        assert!((mean(&r_near) - 1.0).abs() < 0.08, "{}", mean(&r_near));
        assert!((mean(&r_zero) - 1.0).abs() < 0.12, "{}", mean(&r_zero));
    }

    #[test]
    fn coloured_noise_is_seen_where_it_is() {
        // AR(1) with pole 0.95 at 200 Hz: a corner near 10 rad/s; at 2 rad/s the power per
        // unit frequency is (1 + p)/(1 - p) = 39 times the white level of the same variance.
        let (dt, omega, n) = (0.005, 2.0, 8000);
        let pole: f64 = 0.95;
        let y = noisy(n, omega, dt, 5e-4, pole, 7);
        let fit = harmonic_fit_trend([&y[..]], omega, dt, 3).unwrap();
        let [ln] = local_noise([&y[..]], &fit, omega, dt);
        let theory = {
            let x = omega * dt;
            (1.0 - pole * pole) / (1.0 - 2.0 * pole * x.cos() + pole * pole)
        };
        let ratio = ln.near_omega / fit.noise_var[0];
        assert!(
            ratio > 0.6 * theory && ratio < 1.6 * theory,
            "{ratio} vs {theory}"
        );
        // And the coefficient scatter over many records follows the local power, not the
        // variance: the white formula would be off by the colour factor.
        let mut re = Vec::new();
        let mut predicted = Vec::new();
        for seed in 100..300 {
            let y = noisy(n, omega, dt, 5e-4, pole, seed);
            let fit = harmonic_fit_trend([&y[..]], omega, dt, 3).unwrap();
            let [ln] = local_noise([&y[..]], &fit, omega, dt);
            re.push(fit.harmonics[0][0].re);
            predicted.push(ln.near_omega * fit.inv_diag_h1[0]);
        }
        let m = re.iter().sum::<f64>() / re.len() as f64;
        let var = re.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (re.len() - 1) as f64;
        let pred = predicted.iter().sum::<f64>() / predicted.len() as f64;
        assert!(
            var > 0.7 * pred && var < 1.4 * pred,
            "scatter {var} vs {pred}"
        );
    }

    #[test]
    fn a_record_of_few_periods_sees_the_noise_at_its_own_frequency() {
        // Three whole periods at 0.5 rad/s in first-order noise of correlation time 0.8 s
        // (corner 1.25 rad/s, a slow creep of force sensors): the bins two away from every
        // harmonic start above 4.5 omega, where the noise is 3.6 times weaker than at omega.
        // Pooled over records, the bins (next to the excitation included) must give the
        // colour at omega itself.
        let (dt, omega) = (0.005, 0.5);
        let n = (3.0 * 2.0 * PI / omega / dt).round() as usize;
        let pole: f64 = (-dt / 0.8f64).exp();
        let theory = {
            let x = omega * dt;
            (1.0 - pole * pole) / (1.0 - 2.0 * pole * x.cos() + pole * pole)
        };
        let mut samples = Vec::new();
        let mut raw = Vec::new();
        for seed in 0..40 {
            let y = noisy(n, omega, dt, 5e-4, pole, 500 + seed);
            let fit = harmonic_fit_trend([&y[..]], omega, dt, 3).unwrap();
            let [ln] = local_noise([&y[..]], &fit, omega, dt);
            // The residual variance of a record is a poor estimate of the process variance
            // (38 s of a 0.8 s process); the colour is relative to it, as in identification.
            let v = fit.noise_var[0];
            assert!(
                ln.near_bins.iter().any(|b| b.0 < 2.0 * omega),
                "{:?}",
                ln.near_bins
            );
            for &(w, p) in ln.near_bins.iter().chain(ln.zero_bins.iter()) {
                samples.push(ColourSample {
                    omega: w,
                    ratio: p / v,
                    bins: 1,
                });
            }
            raw.push(v);
        }
        let pooled = pool_ratios(&samples, &[omega])[0];
        let v_mean = raw.iter().sum::<f64>() / raw.len() as f64;
        // The power at omega over the mean residual variance, against the process's own.
        let process_var = (5e-4f64).powi(2);
        let expected = theory * process_var / v_mean;
        assert!(
            pooled > 0.75 * expected && pooled < 1.3 * expected,
            "pooled {pooled} expected {expected}"
        );
    }

    #[test]
    fn pooling_smooths_by_frequency() {
        let samples: Vec<ColourSample> = (0..30)
            .map(|k| {
                let w = 0.5 * 1.2f64.powi(k);
                ColourSample {
                    omega: w,
                    ratio: if w < 3.0 { 4.0 } else { 1.0 } * if k % 2 == 0 { 1.2 } else { 0.8 },
                    bins: 16,
                }
            })
            .collect();
        let r = pool_ratios(&samples, &[0.7, 50.0]);
        assert!((r[0] - 4.0).abs() < 0.5, "{r:?}");
        assert!((r[1] - 1.0).abs() < 0.15, "{r:?}");
        assert_eq!(pool_ratios(&[], &[1.0]), vec![1.0]);
    }
}
