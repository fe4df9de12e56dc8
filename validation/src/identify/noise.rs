//! The noise a record's first harmonic and trend actually see: the residual of the harmonic
//! fit, its power in a few frequency bins beside the excitation and near zero frequency.
//!
//! White noise makes every bin equal to the residual variance, and the usual least-squares
//! variances follow; coloured noise (a sensor filter, vibration, drift that is not a straight
//! line) puts more power at some frequencies than at others, and a variance computed from
//! the overall residual would be wrong there by the same factor. The bins are averaged per
//! record; [`pool_ratios`] then pools the ratio `bin power / residual variance` over the
//! records of a campaign by frequency, so that each record's variance is its own residual
//! variance times a smooth, well-determined colour factor.

use super::sine::HarmonicFit;
use std::f64::consts::PI;

/// Bins on each side of the excitation (and near zero frequency) averaged per record.
pub(crate) const BINS: usize = 8;

/// Mean power per sample of a residual, `|sum_k e_k e^{-i W k dt}|^2 / n`, in bins beside the
/// excitation and near zero frequency; for white noise both equal its variance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LocalNoise {
    pub near_omega: f64,
    pub near_zero: f64,
}

/// The bin frequencies (rad/s) used beside `omega` and near zero for a slice of `n` samples at
/// `dt` fitted with `k_max` harmonics: whole multiples of the slice's resolution `2 pi/(n dt)`,
/// at least two bins from every fitted frequency (0, omega, ..., (k_max + 1) omega; the
/// fitted columns' leakage into them is then negligible) and below Nyquist.
pub(crate) fn bin_frequencies(n: usize, dt: f64, omega: f64, k_max: usize) -> (Vec<f64>, Vec<f64>) {
    let res = 2.0 * PI / (n as f64 * dt);
    let nyq = PI / dt;
    let clear = |w: f64| {
        w > 2.5 * res
            && w < nyq - res
            && (1..=k_max + 1).all(|h| (w - h as f64 * omega).abs() >= 1.5 * res)
    };
    let mut near = Vec::new();
    for m in 2..(2 + 3 * BINS) {
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
/// [`bin_frequencies`]; one pass, rotations by recurrence.
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
    let mut out = [LocalNoise {
        near_omega: f64::NAN,
        near_zero: f64::NAN,
    }; S];
    if nb == 0 || n == 0 {
        return out;
    }
    let c = (n as f64 - 1.0) / 2.0;
    // Bin rotations and the fundamental's rotation, by recurrence resynchronised every 1024.
    let rot: Vec<(f64, f64)> = bins.iter().map(|w| (w * dt).sin_cos()).collect();
    let (ds, dc) = (omega * dt).sin_cos();
    let mut acc = vec![[(0.0f64, 0.0f64); S]; nb];
    let mut z: Vec<(f64, f64)> = vec![(0.0, 1.0); nb];
    let (mut s1, mut c1) = (0.0f64, 1.0f64);
    for k in 0..n {
        if k % 1024 == 0 {
            for (b, w) in bins.iter().enumerate() {
                z[b] = (w * k as f64 * dt).sin_cos();
            }
            (s1, c1) = (omega * k as f64 * dt).sin_cos();
        }
        let t = (k as f64 - c) * dt;
        for j in 0..S {
            let mut f = fit.dc[j] + fit.trend[j] * t;
            let (mut sh, mut ch) = (s1, c1);
            for p in &fit.harmonics[j] {
                f += p.re * sh + p.im * ch;
                let ns = sh * c1 + ch * s1;
                ch = ch * c1 - sh * s1;
                sh = ns;
            }
            let e = signals[j][k] - f;
            for b in 0..nb {
                acc[b][j].0 += e * z[b].1;
                acc[b][j].1 -= e * z[b].0;
            }
        }
        for b in 0..nb {
            let (sb, cb) = z[b];
            z[b] = (sb * rot[b].1 + cb * rot[b].0, cb * rot[b].1 - sb * rot[b].0);
        }
        let ns = s1 * dc + c1 * ds;
        c1 = c1 * dc - s1 * ds;
        s1 = ns;
    }
    let power = |b: usize, j: usize| (acc[b][j].0.powi(2) + acc[b][j].1.powi(2)) / n as f64;
    for (j, o) in out.iter_mut().enumerate() {
        if !near.is_empty() {
            o.near_omega = (0..near.len()).map(|b| power(b, j)).sum::<f64>() / near.len() as f64;
        }
        if !zero.is_empty() {
            o.near_zero = (near.len()..nb).map(|b| power(b, j)).sum::<f64>() / zero.len() as f64;
        }
    }
    out
}

/// One record's colour sample: at `omega` (rad/s), the local power over the residual variance
/// and the number of bins it averages.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ColourSample {
    pub omega: f64,
    pub ratio: f64,
    pub bins: usize,
}

/// Pools colour samples over records by frequency: for each query frequency, the bin-weighted
/// mean ratio of the samples within a factor `1.5` in frequency (at least the nearest 6
/// samples). White noise gives about 1 everywhere; a record's variance is its residual
/// variance times the pooled ratio at its frequency. Samples that are not finite are ignored;
/// with none left the factor is 1.
pub(crate) fn pool_ratios(samples: &[ColourSample], queries: &[f64]) -> Vec<f64> {
    let good: Vec<&ColourSample> = samples
        .iter()
        .filter(|s| s.ratio.is_finite() && s.ratio > 0.0 && s.omega > 0.0 && s.bins > 0)
        .collect();
    queries
        .iter()
        .map(|&w| {
            if good.is_empty() || w.is_nan() || w <= 0.0 {
                return 1.0;
            }
            let mut by_dist: Vec<(f64, &ColourSample)> = good
                .iter()
                .map(|s| ((s.omega / w).ln().abs(), *s))
                .collect();
            by_dist.sort_by(|a, b| a.0.total_cmp(&b.0));
            let within = by_dist.iter().filter(|(d, _)| *d <= 1.5f64.ln()).count();
            let take = within.max(6).min(by_dist.len());
            let (num, den) = by_dist[..take].iter().fold((0.0, 0.0), |(a, b), (_, s)| {
                (a + s.ratio * s.bins as f64, b + s.bins as f64)
            });
            if den > 0.0 {
                num / den
            } else {
                1.0
            }
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
