//! What the measurements show, as numbers the evidence sentence puts into words: measured over
//! modelled response per record, phase slopes (unwrapped), medians per frequency, the contrast
//! between small and large sines, the line the operating points lie on.

use crate::measure::Prediction;
use crate::observe::Observation;
use crate::profiles::servo_of as servo_params_of;
use num_complex::Complex64;
use zmp_models::effects::tracking_lowpass::TrackingLowpass;
use zmp_models::EffectKind;
use zmp_models::{Binding, ModelSpec};

/// Measured over modelled first harmonic of the excited input's own output, per record.
pub fn ratios(obs: &[&Observation], base: &[Prediction]) -> Vec<(usize, Complex64)> {
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

/// The median of `v` (the upper middle value for an even count); NaN when empty.
pub fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Whether `spec`'s force limit clamps the sine of record `o`: the CoM acceleration it demands,
/// `A w^2 |H(jw)|` (`H` the servo's tracking low-pass), reaches the limit of its axis.
pub fn clamped(spec: &ModelSpec, o: &Observation) -> bool {
    let b = Binding::Axis(o.excited);
    let Some(limit) = spec.value(EffectKind::AccelerationSaturation, b, "limit") else {
        return false;
    };
    let (omega_n, zeta) = servo_params_of(spec, b);
    let h = TrackingLowpass { omega_n, zeta }.freq(o.omega).norm();
    o.nominal_amplitude * o.omega * o.omega * h >= limit
}

/// Pairs of records that differ only in amplitude (the campaign's smallest and largest, same
/// axis, frequency and operating point): `(small, its ratio, large, its ratio)` from the
/// measured-over-model ratios `r`; empty when the campaign has one amplitude. Pairs whose large
/// sine `spec`'s force limit clamps ([`clamped`]) are left out: there the ratio weighs the
/// model's saturation law against the robot's, not the small sine against the large one; and a
/// clamped large sine, with a high response, has a small relative noise, so a few such pairs
/// would outweigh every unclamped pair in the weighted contrast.
fn amplitude_pairs(
    obs: &[&Observation],
    r: &[(usize, Complex64)],
    spec: &ModelSpec,
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
            if !clamped(spec, obs[m]) {
                out.push((k, rk, m, rh));
            }
        }
    }
    out
}

/// Mean gain of the smallest amplitude over the largest, for records that differ only in
/// amplitude (the large one not clamped by `spec`'s force limit), and the mean extra phase lag
/// (deg); `None` without such pairs.
pub fn amplitude_contrast(
    obs: &[&Observation],
    r: &[(usize, Complex64)],
    spec: &ModelSpec,
) -> Option<(f64, f64, f64)> {
    let pairs = amplitude_pairs(obs, r, spec);
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
    /// How many small/large amplitude pairs the means are over.
    pub pairs: usize,
    /// Weighted mean of `ln |q|` (negative: the small amplitude responds less).
    pub log_gain: f64,
    /// Weighted mean of the extra lag, rad (positive: the small amplitude lags more).
    pub lag: f64,
    /// Standard error of either (the same for the log-magnitude and the phase).
    pub std_error: f64,
}

impl AmplitudeDependence {
    /// Whether the data show the small amplitude responding less or later than the large one
    /// (what play and friction do) at the diagnosis's significance level (one-sided, either
    /// the gain or the lag: [`crate::criterion::ALPHA`] shared by the two).
    pub fn shown(&self) -> bool {
        let z = crate::criterion::z_one_sided(crate::criterion::ALPHA / 2.0);
        -self.log_gain >= z * self.std_error || self.lag >= z * self.std_error
    }
}

/// The [`AmplitudeDependence`] of the measurements against `base` (the predictions of `spec`),
/// per excited axis (play and friction can sit in one joint: the other axis's pairs would
/// dilute its contrast); `None` for an axis without a pair of records that differ only in
/// amplitude, the large one not clamped by `spec`'s force limit.
pub fn amplitude_dependence(
    obs: &[&Observation],
    base: &[Prediction],
    spec: &ModelSpec,
) -> [Option<AmplitudeDependence>; 2] {
    let rel_var = |o: &Observation| {
        let j = o.excited.index();
        o.y1_var[j] / o.y1[j].norm_sqr().max(1e-300)
    };
    // Per axis: sum of weights, weighted log-gain, weighted lag, pairs.
    let mut acc = [(0.0, 0.0, 0.0, 0usize); 2];
    for (k, rk, m, rh) in amplitude_pairs(obs, &ratios(obs, base), spec) {
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

pub fn axes_of(params: &[(String, f64, f64)]) -> String {
    let mut v: Vec<String> = params
        .iter()
        .map(|(k, val, err)| {
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
pub fn op_line(obs: &[&Observation]) -> Option<[f64; 2]> {
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
pub fn median_by_frequency(w: &[f64], v: &[f64]) -> Vec<(f64, f64)> {
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

    /// A record of the x axis whose response is `g` times its sine of amplitude `amp`, each
    /// first-harmonic component with variance `rel_var` relative to the response.
    fn rec(omega: f64, amp: f64, g: Complex64, rel_var: f64) -> Observation {
        Observation {
            index: 0,
            excited: zmp_models::Axis::X,
            omega,
            operating_point: [0.0, 0.0],
            nominal_amplitude: amp,
            t0: 0.0,
            t1: 10.0,
            u1: Complex64::new(amp, 0.0),
            y1: [g * amp, Complex64::new(0.0, 0.0)],
            y1_var: [rel_var * amp * amp, 1e-12],
            y3: [Complex64::new(0.0, 0.0); 2],
            y3_var: [1e-12; 2],
            third_band: false,
            slope: [0.0; 2],
            slope_var: [1e-12; 2],
            noise_std: [1e-4; 2],
            samples: 100,
        }
    }

    /// The seed's model, without a force limit.
    fn paper() -> ModelSpec {
        ModelSpec::parse(
            include_str!("../../../../models/params/silo2-paper.toml"),
            "silo2-paper.toml",
        )
        .unwrap()
    }

    /// A pair whose large sine the model's force limit clamps says how the model's saturation
    /// law differs from the robot's, not how the small sine differs from the large one: it is
    /// left out of the contrast.
    #[test]
    fn the_contrast_leaves_out_pairs_whose_large_sine_the_force_limit_clamps() {
        // Below 8 rad/s the 3 mm sines lag 3 degrees (1 % noise); at 8 rad/s, where the
        // 8 mm sine demands 0.48 m/s2 through the seed's 30 rad/s servo, they respond 3 % more
        // with a hundredth of that noise.
        let play = Complex64::from_polar(1.0, -3f64.to_radians());
        let mut v = Vec::new();
        for w in [0.5, 1.0, 2.0, 4.0] {
            v.push(rec(w, 0.003, play, 1e-4));
            v.push(rec(w, 0.008, Complex64::new(1.0, 0.0), 1e-4));
        }
        v.push(rec(8.0, 0.003, Complex64::new(1.03, 0.0), 1e-8));
        v.push(rec(8.0, 0.008, Complex64::new(1.0, 0.0), 1e-8));
        let refs: Vec<&Observation> = v.iter().collect();
        let preds = vec![
            Prediction {
                g: [Complex64::new(1.0, 0.0), Complex64::new(0.0, 0.0)],
                g3: [Complex64::new(0.0, 0.0); 2],
                slope: [0.0; 2],
            };
            refs.len()
        ];
        // Without a limit the quiet pair decides: no play shown.
        let free = paper();
        let d = amplitude_dependence(&refs, &preds, &free)[0].unwrap();
        assert_eq!(d.pairs, 5);
        assert!(!d.shown(), "{d:?}");
        // A limit of 0.3 m/s2 on x clamps the 8 mm sine at 8 rad/s only (0.128 m/s2 at
        // 4 rad/s): the four other pairs show the lag.
        let mut limited = paper();
        crate::profiles::add_effect(
            &mut limited,
            EffectKind::AccelerationSaturation,
            &[zmp_models::Binding::Axis(zmp_models::Axis::X)],
            &[0.3],
        );
        assert!(clamped(&limited, refs[9]) && !clamped(&limited, refs[7]));
        let d = amplitude_dependence(&refs, &preds, &limited)[0].unwrap();
        assert_eq!(d.pairs, 4);
        assert!((d.lag - 3f64.to_radians()).abs() < 1e-9, "{d:?}");
        assert!(d.shown(), "{d:?}");
        // A limit on y leaves the x pairs alone.
        let mut other = paper();
        crate::profiles::add_effect(
            &mut other,
            EffectKind::AccelerationSaturation,
            &[zmp_models::Binding::Axis(zmp_models::Axis::Y)],
            &[0.3],
        );
        assert_eq!(
            amplitude_dependence(&refs, &preds, &other)[0]
                .unwrap()
                .pairs,
            5
        );
    }

    #[test]
    fn amplitude_dependence_is_shown_only_when_the_small_sines_respond_less_or_later() {
        // Pairs of records at five frequencies: 3 mm and 8 mm, the model the identity.
        let pred = Prediction {
            g: [Complex64::new(1.0, 0.0), Complex64::new(0.0, 0.0)],
            g3: [Complex64::new(0.0, 0.0); 2],
            slope: [0.0; 2],
        };
        let spec = paper();
        let campaign = |small: Complex64, rel_sd: f64| -> Option<AmplitudeDependence> {
            let mut v = Vec::new();
            for w in [0.5, 1.0, 2.0, 4.0, 8.0] {
                v.push(rec(w, 0.003, small, rel_sd * rel_sd));
                v.push(rec(w, 0.008, Complex64::new(1.0, 0.0), rel_sd * rel_sd));
            }
            let refs: Vec<&Observation> = v.iter().collect();
            amplitude_dependence(&refs, &vec![pred; refs.len()], &spec)[0]
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
        let d = amplitude_dependence(&refs, &preds, &spec);
        assert!(!d[0].unwrap().shown() && d[1].unwrap().shown(), "{d:?}");
        assert_eq!(amplitude_dependence_shown(&d), Some(true));
        // One amplitude only: nothing to compare.
        let one: Vec<Observation> = (0..3)
            .map(|k| rec(1.0 + k as f64, 0.003, play, 1e-6))
            .collect();
        let refs: Vec<&Observation> = one.iter().collect();
        assert_eq!(amplitude_dependence(&refs, &[pred; 3], &spec), [None, None]);
    }
}
