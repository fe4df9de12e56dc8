//! Evidence in physical terms: what the measurements show against the model the diagnosis
//! started from, in the words of the effect that explains it.

use super::measure::Prediction;
use super::observe::Observation;
use num_complex::Complex64;
use std::collections::BTreeMap;
use std::fmt::Write;

/// Measured over modelled first harmonic of the excited input's own output, per record.
fn ratios(obs: &[&Observation], base: &[Prediction]) -> Vec<(usize, Complex64)> {
    obs.iter()
        .zip(base)
        .enumerate()
        .filter_map(|(k, (o, p))| {
            let j = o.excited.index();
            let m = p.g[j] * o.u1;
            (m.norm() > 0.0).then(|| (k, o.y1[j] / m))
        })
        .collect()
}

/// Least-squares slope through the origin of `y` on `x`, and its R².
pub fn slope_through_origin(x: &[f64], y: &[f64]) -> (f64, f64) {
    let sxx: f64 = x.iter().map(|v| v * v).sum();
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| a * b).sum();
    let s = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let ss_res: f64 = x.iter().zip(y).map(|(a, b)| (b - s * a).powi(2)).sum();
    let ss_tot: f64 = y.iter().map(|b| b * b).sum();
    (
        s,
        if ss_tot > 0.0 {
            1.0 - ss_res / ss_tot
        } else {
            0.0
        },
    )
}

/// The phases ordered by frequency and unwrapped (each within pi of the previous one), with
/// their frequencies.
pub fn unwrapped_phase(w: &[f64], ph: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut order: Vec<usize> = (0..w.len()).collect();
    order.sort_by(|&a, &b| w[a].total_cmp(&w[b]));
    let mut out_w = Vec::with_capacity(w.len());
    let mut out_p: Vec<f64> = Vec::with_capacity(w.len());
    for k in order {
        let mut p = ph[k];
        if let Some(&prev) = out_p.last() {
            while p - prev > std::f64::consts::PI {
                p -= 2.0 * std::f64::consts::PI;
            }
            while p - prev < -std::f64::consts::PI {
                p += 2.0 * std::f64::consts::PI;
            }
        }
        out_w.push(w[k]);
        out_p.push(p);
    }
    (out_w, out_p)
}

/// How a phase follows frequency, in words decided by the sign of its slope and its R^2.
pub fn phase_words(slope: f64, r2: f64) -> &'static str {
    match (slope < 0.0, r2 >= 0.9, r2 >= 0.5) {
        (true, true, _) => "falls linearly with omega",
        (true, false, true) => "falls with omega, but not linearly",
        (true, false, false) => "shows no clear trend with omega",
        (false, _, true) => "rises with omega (no delay lags like this)",
        (false, _, false) => "shows no clear trend with omega",
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Pairs of records that differ only in amplitude (the campaign's smallest and largest, same
/// axis, frequency and operating point): `(small, its ratio, large, its ratio)` from the
/// measured-over-model ratios `r`; empty when the campaign has one amplitude.
fn amplitude_pairs(
    obs: &[&Observation],
    r: &[(usize, Complex64)],
) -> Vec<(usize, Complex64, usize, Complex64)> {
    let amps: Vec<f64> = obs.iter().map(|o| o.nominal_amplitude).collect();
    let lo = amps.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = amps.iter().copied().fold(0.0, f64::max);
    if hi <= lo * 1.01 {
        return Vec::new();
    }
    let mut out = Vec::new();
    for &(k, rk) in r {
        let o = obs[k];
        if (o.nominal_amplitude - lo).abs() > 1e-12 {
            continue;
        }
        if let Some(&(m, rh)) = r.iter().find(|(m, _)| {
            let p = obs[*m];
            p.excited == o.excited
                && (p.omega - o.omega).abs() <= 1e-9 * o.omega
                && p.operating_point == o.operating_point
                && (p.nominal_amplitude - hi).abs() <= 1e-12
        }) {
            out.push((k, rk, m, rh));
        }
    }
    out
}

/// Mean gain of the smallest amplitude over the largest, for records that differ only in
/// amplitude, and the mean extra phase lag (deg); `None` without such pairs.
fn amplitude_contrast(obs: &[&Observation], r: &[(usize, Complex64)]) -> Option<(f64, f64, f64)> {
    let pairs = amplitude_pairs(obs, r);
    if pairs.is_empty() {
        return None;
    }
    let mut gains = Vec::new();
    let mut phases = Vec::new();
    let mut low_w = Vec::new();
    for &(k, rk, _, rh) in &pairs {
        let q = rk / rh;
        gains.push(q.norm());
        phases.push(q.arg().to_degrees());
        low_w.push((obs[k].omega, q.norm()));
    }
    low_w.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = gains.len() as f64;
    let lowest = low_w
        .iter()
        .take((low_w.len() / 3).max(1))
        .map(|x| x.1)
        .sum::<f64>()
        / (low_w.len() / 3).max(1) as f64;
    Some((
        gains.iter().sum::<f64>() / n,
        phases.iter().sum::<f64>() / n,
        lowest,
    ))
}

/// How the smallest amplitude's response compares with the largest's at the same frequency,
/// axis and operating point, against a model (`base`): `gain` the small one's over the large
/// one's and `lag` the small one's extra phase lag (rad), as inverse-variance weighted means
/// of the log-ratio over the pairs (each record's first-harmonic noise), with their standard
/// errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AmplitudeDependence {
    pub pairs: usize,
    /// Weighted mean of `ln |q|` (negative: the small amplitude responds less).
    pub log_gain: f64,
    /// Weighted mean of the extra lag, rad (positive: the small amplitude lags more).
    pub lag: f64,
    /// Standard error of either (the same for the log-magnitude and the phase).
    pub std_error: f64,
}

/// Standard errors an amplitude dependence must reach to be taken as shown by the data (five:
/// the standard error counts the noise only, and the models' own small misfits, not noise,
/// decide such contrasts in low-noise records).
pub const AMPLITUDE_Z: f64 = 5.0;

impl AmplitudeDependence {
    /// Whether the data show the small amplitude responding less or later than the large one
    /// (what play and friction do) beyond [`AMPLITUDE_Z`] standard errors.
    pub fn shown(&self) -> bool {
        -self.log_gain >= AMPLITUDE_Z * self.std_error || self.lag >= AMPLITUDE_Z * self.std_error
    }
}

/// The [`AmplitudeDependence`] of the measurements against `base`, per excited axis (play
/// and friction can sit in one joint: the other axis's pairs would dilute its contrast);
/// `None` for an axis without a pair of records that differ only in amplitude.
pub fn amplitude_dependence(
    obs: &[&Observation],
    base: &[Prediction],
) -> [Option<AmplitudeDependence>; 2] {
    let rel_var = |o: &Observation| {
        let j = o.excited.index();
        o.y1_var[j] / o.y1[j].norm_sqr().max(1e-300)
    };
    // Per axis: sum of weights, weighted log-gain, weighted lag, pairs.
    let mut acc = [(0.0, 0.0, 0.0, 0usize); 2];
    for (k, rk, m, rh) in amplitude_pairs(obs, &ratios(obs, base)) {
        let q = (rk / rh).ln();
        let var = rel_var(obs[k]) + rel_var(obs[m]);
        if !(var > 0.0 && q.re.is_finite() && q.im.is_finite()) {
            continue;
        }
        let a = &mut acc[obs[k].excited.index()];
        a.0 += 1.0 / var;
        a.1 += q.re / var;
        a.2 += -q.im / var;
        a.3 += 1;
    }
    acc.map(|(sw, sg, sp, n)| {
        (n > 0).then(|| AmplitudeDependence {
            pairs: n,
            log_gain: sg / sw,
            lag: sp / sw,
            std_error: sw.sqrt().recip(),
        })
    })
}

/// Whether any axis shows an amplitude dependence (`None` when no axis can: no pairs).
pub fn amplitude_dependence_shown(d: &[Option<AmplitudeDependence>; 2]) -> Option<bool> {
    let known: Vec<&AmplitudeDependence> = d.iter().flatten().collect();
    (!known.is_empty()).then(|| known.iter().any(|a| a.shown()))
}

fn axes_of(params: &BTreeMap<String, (f64, f64)>) -> String {
    let mut v: Vec<String> = params
        .iter()
        .map(|(k, (val, err))| {
            let short = k.split_once('.').map_or(k.as_str(), |x| x.1);
            if err.is_finite() {
                format!("{short} = {} ± {:.2e}", sig(*val), err)
            } else {
                format!("{short} = {}", sig(*val))
            }
        })
        .collect();
    v.dedup();
    v.join(", ")
}

/// The unit direction of the line the campaign's operating points lie on, when there are at
/// least two distinct ones and all lie on one line (within 1 % of their spread); `None` when
/// they span the plane (then the x and y slopes are determined apart).
fn op_line(obs: &[&Observation]) -> Option<[f64; 2]> {
    let first = obs.first()?.operating_point;
    let d: Vec<[f64; 2]> = obs
        .iter()
        .map(|o| {
            [
                o.operating_point[0] - first[0],
                o.operating_point[1] - first[1],
            ]
        })
        .collect();
    let far = d
        .iter()
        .copied()
        .max_by(|a, b| a[0].hypot(a[1]).total_cmp(&b[0].hypot(b[1])))?;
    let len = far[0].hypot(far[1]);
    if len <= 0.0 {
        return None;
    }
    let u = [far[0] / len, far[1] / len];
    let off_line = d
        .iter()
        .any(|p| (p[0] * u[1] - p[1] * u[0]).abs() > 0.01 * len);
    // Point the direction into the positive quadrant's half-plane, for a stable sign.
    let sign = if u[0] + u[1] < 0.0 { -1.0 } else { 1.0 };
    (!off_line).then(|| [sign * u[0], sign * u[1]])
}

/// `(frequency, median of values)` per distinct frequency (within 1e-9 relative), ascending.
fn median_by_frequency(w: &[f64], v: &[f64]) -> Vec<(f64, f64)> {
    let mut idx: Vec<usize> = (0..w.len().min(v.len())).collect();
    idx.sort_by(|&a, &b| w[a].total_cmp(&w[b]));
    let mut out = Vec::new();
    let mut k = 0;
    while k < idx.len() {
        let w0 = w[idx[k]];
        let group: Vec<f64> = idx[k..]
            .iter()
            .take_while(|&&i| (w[i] - w0).abs() <= 1e-9 * w0.abs())
            .map(|&i| v[i])
            .collect();
        k += group.len();
        out.push((w0, median(group)));
    }
    out
}

/// Four significant digits, plain.
pub fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    if v.abs() < 1e-3 || v.abs() >= 1e6 {
        return format!("{v:.3e}");
    }
    let d = (3 - v.abs().log10().floor() as i32).max(0) as usize;
    format!("{v:.d$}")
}

/// The evidence sentence for a fitted effect. `base` holds the starting model's predictions,
/// `after` the ones with the effect; `params` its fitted parameters (name, value, s.e.).
pub fn sentence(
    effect: &str,
    obs: &[&Observation],
    base: &[Prediction],
    params: &BTreeMap<String, (f64, f64)>,
    error_before: f64,
    error_after: f64,
    floor: f64,
) -> String {
    let r = ratios(obs, base);
    let w: Vec<f64> = r.iter().map(|(k, _)| obs[*k].omega).collect();
    let ph: Vec<f64> = r.iter().map(|(_, q)| q.arg()).collect();
    let mag: Vec<f64> = r.iter().map(|(_, q)| q.norm()).collect();
    let mut s = String::new();
    let fell = format!(
        "; with it the held-out error falls from {:.1}x to {:.1}x the noise floor",
        error_before / floor,
        error_after / floor
    );
    match effect {
        "time_delay" => {
            let (wu, phu) = unwrapped_phase(&w, &ph);
            let (slope, r2) = slope_through_origin(&wu, &phu);
            let dev = median(mag.iter().map(|m| (m - 1.0).abs()).collect());
            let shape = phase_words(slope, r2);
            let _ = write!(
                s,
                "phase of measured/model {shape} (slope {:.4} s, R^2 {:.3}) while the magnitude \
                 stays within {:.1} %{}",
                slope,
                r2,
                100.0 * dev,
                if slope < 0.0 && r2 >= 0.9 && dev < 0.05 {
                    format!(": a pure delay ({})", axes_of(params))
                } else {
                    format!(
                        "; the fitted delay ({}) explains what the other parameters do not",
                        axes_of(params)
                    )
                }
            );
        }
        "sensor_lowpass" | "structural_mode" => {
            if effect == "structural_mode" {
                // Per frequency, the median over its records (records of one frequency are
                // not a peak and a dip of the response).
                let prof = median_by_frequency(&w, &mag);
                let by_value = |a: &(f64, f64), b: &(f64, f64)| a.1.total_cmp(&b.1);
                let peak = prof
                    .iter()
                    .copied()
                    .max_by(by_value)
                    .unwrap_or((f64::NAN, 0.0));
                let dip = prof
                    .iter()
                    .copied()
                    .min_by(by_value)
                    .unwrap_or((f64::NAN, f64::INFINITY));
                let db = |m: f64| 20.0 * m.max(1e-12).log10();
                if db(peak.1) >= 1.0 && peak.0 != dip.0 {
                    let _ = write!(
                        s,
                        "measured/model magnitude peaks at {:+.1} dB near {:.2} rad/s and dips \
                         to {:+.1} dB near {:.2} rad/s (medians per frequency): a lightly damped \
                         structural mode ({})",
                        db(peak.1),
                        peak.0,
                        db(dip.1),
                        dip.0,
                        axes_of(params)
                    );
                } else {
                    let _ = write!(
                        s,
                        "measured/model magnitude shows no clear resonance in the band (medians \
                         per frequency within {:+.1} to {:+.1} dB); the fitted mode ({}) bends \
                         the response where the other parameters cannot",
                        db(dip.1),
                        db(peak.1),
                        axes_of(params)
                    );
                }
            } else {
                let hi = w.iter().copied().fold(0.0, f64::max);
                let top: Vec<usize> = (0..w.len()).filter(|&k| w[k] >= 0.99 * hi).collect();
                let m = top.iter().map(|&k| mag[k]).sum::<f64>() / top.len().max(1) as f64;
                let p = top.iter().map(|&k| ph[k]).sum::<f64>() / top.len().max(1) as f64;
                let _ = write!(
                    s,
                    "magnitude of measured/model falls to {:+.1} dB and the phase lags {:.1} deg \
                     at {:.1} rad/s, both growing with omega like a first-order filter on the \
                     ZMP measurement ({})",
                    20.0 * m.max(1e-12).log10(),
                    -p.to_degrees(),
                    hi,
                    axes_of(params)
                );
            }
        }
        "backlash" | "coulomb_friction" => {
            let what = if effect == "backlash" {
                "a play the drive must cross before the CoM moves (backlash)"
            } else {
                "Coulomb friction decelerating the CoM"
            };
            let dep = amplitude_dependence(obs, base);
            match (
                amplitude_contrast(obs, &r),
                amplitude_dependence_shown(&dep),
            ) {
                (Some((g, p, low)), Some(shown)) => {
                    let words = if shown {
                        format!("the response depends on amplitude, as with {what}")
                    } else {
                        let per_axis: Vec<String> = dep
                            .iter()
                            .zip(["x", "y"])
                            .filter_map(|(d, ax)| {
                                d.map(|d| {
                                    format!(
                                        "{ax}: gain {:+.2} %, lag {:+.2} deg, +- {:.2} % / {:.2} deg",
                                        100.0 * d.log_gain,
                                        d.lag.to_degrees(),
                                        100.0 * d.std_error,
                                        d.std_error.to_degrees()
                                    )
                                })
                            })
                            .collect();
                        format!(
                            "within the noise the response does not depend on amplitude as \
                             with {what} (weighted by the records' noise, {})",
                            per_axis.join("; ")
                        )
                    };
                    let _ = write!(
                        s,
                        "the smallest amplitude's gain is {:.1} % below the largest's at the same \
                         frequencies ({:.1} % at the lowest third), with {:.1} deg more phase lag: \
                         {words} ({})",
                        100.0 * (1.0 - g),
                        100.0 * (1.0 - low),
                        -p,
                        axes_of(params)
                    );
                }
                _ => {
                    let _ = write!(
                        s,
                        "gain below the model by {:.1} % (median): {what} ({})",
                        100.0 * median(mag.iter().map(|m| 1.0 - m).collect()),
                        axes_of(params)
                    );
                }
            }
        }
        "acceleration_saturation" => {
            let h3 = obs
                .iter()
                .map(|o| {
                    let j = o.excited.index();
                    o.y3[j].norm() / o.y1[j].norm().max(1e-300)
                })
                .fold(0.0, f64::max);
            let loss = mag.iter().map(|m| 1.0 - m).fold(0.0, f64::max);
            let _ = write!(
                s,
                "records with large amplitude x omega^2 lose up to {:.1} % of gain and carry a \
                 third harmonic of up to {:.1} % of the fundamental, small ones do not: the \
                 servo's acceleration is limited ({})",
                100.0 * loss,
                100.0 * h3,
                axes_of(params)
            );
        }
        "operating_point_dependence" => {
            let mut spread = 0.0f64;
            for &(k, q) in &r {
                for &(m, p) in &r {
                    let (a, b) = (obs[k], obs[m]);
                    if a.excited == b.excited
                        && (a.omega - b.omega).abs() <= 1e-9 * a.omega
                        && a.nominal_amplitude == b.nominal_amplitude
                        && a.operating_point != b.operating_point
                    {
                        spread = spread.max((q.norm() / p.norm() - 1.0).abs());
                    }
                }
            }
            let _ = write!(
                s,
                "the same sine gives gains up to {:.1} % apart at different operating points: \
                 the pendulum's a and b move with the CoM position ({})",
                100.0 * spread,
                axes_of(params)
            );
            if let Some(u) = op_line(obs) {
                let get = |k: &str| {
                    params
                        .iter()
                        .find(|(n, _)| n.ends_with(k))
                        .map_or(0.0, |(_, v)| v.0)
                };
                let _ = write!(
                    s,
                    "; the operating points lie on one line (direction x {:.2}, y {:.2}), so \
                     only the slopes along it are determined, not the x and y ones apart: da = \
                     {} and db = {} per m along the line",
                    u[0],
                    u[1],
                    sig(u[0] * get("da_dx") + u[1] * get("da_dy")),
                    sig(u[0] * get("db_dx") + u[1] * get("db_dy"))
                );
            }
        }
        "sensor_drift" => {
            let mut sl = [0.0f64; 2];
            let mut t = [0.0f64; 2];
            for o in obs {
                for i in 0..2 {
                    sl[i] += o.slope[i] / obs.len() as f64;
                    t[i] += (o.slope[i] / o.slope_var[i].sqrt().max(1e-300)) / obs.len() as f64;
                }
            }
            let _ = write!(
                s,
                "the measured ZMP drifts linearly through every record (x {:+.3} mm/s, y {:+.3} \
                 mm/s; mean {:.0} and {:.0} standard errors) where the model is periodic: a \
                 drifting ZMP sensor offset ({})",
                sl[0] * 1e3,
                sl[1] * 1e3,
                t[0],
                t[1],
                axes_of(params)
            );
        }
        "cross_coupling" => {
            let mut peak = [0.0f64; 2];
            for (o, p) in obs.iter().zip(base) {
                let j = o.excited.index();
                let i = 1 - j;
                if p.g[i].norm() == 0.0 {
                    peak[j] = peak[j].max(o.g(i).norm());
                }
            }
            let _ = write!(
                s,
                "the unexcited ZMP axis responds (|G21| up to {:.3}, |G12| up to {:.3}) where the \
                 model has no coupling ({})",
                peak[0],
                peak[1],
                axes_of(params)
            );
        }
        other => {
            let _ = write!(s, "{other} ({})", axes_of(params));
        }
    }
    s.push_str(&fell);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unwrapping_keeps_a_long_delay_linear() {
        // 150 ms from 0.5 to 15 rad/s: 2.25 rad of lag, wrapped at +-pi.
        let w: Vec<f64> = (0..12).map(|k| 0.5 + 1.3 * k as f64).collect();
        let tau = 0.3;
        let wrapped: Vec<f64> = w
            .iter()
            .map(|w| {
                let p = -w * tau;
                (p + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
                    - std::f64::consts::PI
            })
            .collect();
        // Shuffled order: unwrapping sorts by frequency first.
        let mut idx: Vec<usize> = (0..w.len()).collect();
        idx.reverse();
        let ws: Vec<f64> = idx.iter().map(|&k| w[k]).collect();
        let ps: Vec<f64> = idx.iter().map(|&k| wrapped[k]).collect();
        let (wu, pu) = unwrapped_phase(&ws, &ps);
        let (slope, r2) = slope_through_origin(&wu, &pu);
        assert!((slope + tau).abs() < 1e-9, "{slope}");
        assert!(r2 > 0.999);
        assert_eq!(phase_words(slope, r2), "falls linearly with omega");
        // Without unwrapping the wrapped phase is not a line.
        let (_, r2w) = slope_through_origin(&ws, &ps);
        assert!(r2w < 0.9, "{r2w}");
    }

    #[test]
    fn the_words_follow_the_data() {
        assert_eq!(
            phase_words(0.02, 0.95),
            "rises with omega (no delay lags like this)"
        );
        assert_eq!(
            phase_words(-0.02, 0.6),
            "falls with omega, but not linearly"
        );
        assert_eq!(phase_words(-0.02, 0.1), "shows no clear trend with omega");
    }

    #[test]
    fn medians_per_frequency_do_not_set_records_of_one_frequency_against_each_other() {
        // Two records at 0.76 rad/s, one high and one low: no peak and dip there.
        let w = [0.76, 0.76, 0.76, 3.0, 3.0, 10.0];
        let v = [1.06, 0.94, 1.0, 1.30, 1.20, 0.99];
        let m = median_by_frequency(&w, &v);
        assert_eq!(m.len(), 3);
        assert_eq!(m[0], (0.76, 1.0));
        assert_eq!(m[1], (3.0, 1.30)); // the upper median of an even count, as `median`
        assert_eq!(m[2], (10.0, 0.99));
    }

    #[test]
    fn operating_points_on_a_line_are_said_to_determine_only_the_slope_along_it() {
        let at = |op: [f64; 2]| Observation {
            index: 0,
            excited: zmp_models::Axis::X,
            omega: 1.0,
            operating_point: op,
            nominal_amplitude: 0.003,
            t0: 0.0,
            t1: 1.0,
            u1: Complex64::new(0.0, 0.003),
            y1: [Complex64::new(0.0, 0.003); 2],
            y1_var: [1e-10; 2],
            y3: [Complex64::new(0.0, 0.0); 2],
            y3_var: [1e-12; 2],
            third_band: false,
            slope: [0.0; 2],
            slope_var: [1e-12; 2],
            noise_std: [1e-4; 2],
            samples: 100,
        };
        // The blind suite's design: (0, 0), (0.03, 0.02), (-0.03, -0.02).
        let line = [at([0.0, 0.0]), at([0.03, 0.02]), at([-0.03, -0.02])];
        let refs: Vec<&Observation> = line.iter().collect();
        let u = op_line(&refs).expect("on a line");
        let n = 0.03f64.hypot(0.02);
        assert!((u[0] - 0.03 / n).abs() < 1e-12 && (u[1] - 0.02 / n).abs() < 1e-12);
        // The reference design's: (0, 0), (0.02, 0), (0, 0.02) span the plane.
        let plane = [at([0.0, 0.0]), at([0.02, 0.0]), at([0.0, 0.02])];
        let refs: Vec<&Observation> = plane.iter().collect();
        assert_eq!(op_line(&refs), None);
        // One operating point: no line either.
        let one = [at([0.01, 0.0]), at([0.01, 0.0])];
        let refs: Vec<&Observation> = one.iter().collect();
        assert_eq!(op_line(&refs), None);
    }

    #[test]
    fn amplitude_dependence_is_shown_only_when_the_small_sines_respond_less_or_later() {
        // Pairs of records at five frequencies: 3 mm and 8 mm, the model the identity.
        let rec = |omega: f64, amp: f64, g: Complex64, var: f64| Observation {
            index: 0,
            excited: zmp_models::Axis::X,
            omega,
            operating_point: [0.0, 0.0],
            nominal_amplitude: amp,
            t0: 0.0,
            t1: 10.0,
            u1: Complex64::new(amp, 0.0),
            y1: [g * amp, Complex64::new(0.0, 0.0)],
            y1_var: [var * amp * amp, 1e-12],
            y3: [Complex64::new(0.0, 0.0); 2],
            y3_var: [1e-12; 2],
            third_band: false,
            slope: [0.0; 2],
            slope_var: [1e-12; 2],
            noise_std: [1e-4; 2],
            samples: 100,
        };
        let pred = Prediction {
            g: [Complex64::new(1.0, 0.0), Complex64::new(0.0, 0.0)],
            g3: [Complex64::new(0.0, 0.0); 2],
            slope: [0.0; 2],
        };
        let campaign = |small: Complex64, rel_sd: f64| -> Option<AmplitudeDependence> {
            let mut v = Vec::new();
            for w in [0.5, 1.0, 2.0, 4.0, 8.0] {
                v.push(rec(w, 0.003, small, rel_sd * rel_sd));
                v.push(rec(w, 0.008, Complex64::new(1.0, 0.0), rel_sd * rel_sd));
            }
            let refs: Vec<&Observation> = v.iter().collect();
            amplitude_dependence(&refs, &vec![pred; refs.len()])[0]
        };
        // A play: the 3 mm sines 2 % smaller and 1 degree later, 0.1 % noise per record.
        let play = Complex64::from_polar(0.98, -1f64.to_radians());
        let d = campaign(play, 1e-3).unwrap();
        assert_eq!(d.pairs, 5);
        assert!((d.log_gain - 0.98f64.ln()).abs() < 1e-9, "{d:?}");
        assert!((d.lag - 1f64.to_radians()).abs() < 1e-9, "{d:?}");
        // Standard error: the two records' relative variances per pair (0.1 % of each one's
        // own response), over five pairs.
        let pair_var = 1e-6 * (1.0 / (0.98f64 * 0.98) + 1.0);
        assert!(
            (d.std_error - (pair_var / 5.0).sqrt()).abs() < 1e-12,
            "{d:?}"
        );
        assert!(d.shown());
        // The same contrast in 5 % noise per record is not shown (0.7 standard errors).
        assert!(!campaign(play, 0.05).unwrap().shown());
        // Small sines responding more and earlier: not what play or friction do.
        let opposite = Complex64::from_polar(1.02, 1f64.to_radians());
        assert!(!campaign(opposite, 1e-3).unwrap().shown());
        // Play in the y joint only, and x pairs with a hundredth of its noise and no
        // contrast: pooled, the x pairs would bury it; per axis it shows.
        let mut v = Vec::new();
        for w in [0.5, 1.0, 2.0, 4.0, 8.0] {
            for (amp, g) in [(0.003, play), (0.008, Complex64::new(1.0, 0.0))] {
                let mut y = rec(w, amp, g, 1e-6);
                y.excited = zmp_models::Axis::Y;
                y.y1 = [Complex64::new(0.0, 0.0), g * amp];
                y.y1_var = [1e-12, 1e-6 * amp * amp];
                v.push(y);
                v.push(rec(w, amp, Complex64::new(1.0, 0.0), 1e-10));
            }
        }
        let refs: Vec<&Observation> = v.iter().collect();
        let preds: Vec<Prediction> = refs
            .iter()
            .map(|o| Prediction {
                g: if o.excited == zmp_models::Axis::Y {
                    [Complex64::new(0.0, 0.0), Complex64::new(1.0, 0.0)]
                } else {
                    pred.g
                },
                g3: [Complex64::new(0.0, 0.0); 2],
                slope: [0.0; 2],
            })
            .collect();
        let d = amplitude_dependence(&refs, &preds);
        assert!(!d[0].unwrap().shown() && d[1].unwrap().shown(), "{d:?}");
        assert_eq!(amplitude_dependence_shown(&d), Some(true));
        // One amplitude only: nothing to compare.
        let one: Vec<Observation> = (0..3)
            .map(|k| rec(1.0 + k as f64, 0.003, play, 1e-6))
            .collect();
        let refs: Vec<&Observation> = one.iter().collect();
        assert_eq!(amplitude_dependence(&refs, &[pred; 3]), [None, None]);
    }
}
