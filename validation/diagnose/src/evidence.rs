//! Evidence in physical terms: what the measurements show against the model the diagnosis
//! started from, in the words of the effect that explains it.

use super::measure::Prediction;
use super::observe::Observation;
use std::collections::BTreeMap;
use std::fmt::Write;
use zmp_models::ModelSpec;

mod features;

use features::{amplitude_contrast, axes_of, median, median_by_frequency, op_line, ratios};
pub use features::{
    amplitude_dependence, amplitude_dependence_shown, phase_words, sig, slope_through_origin,
    unwrapped_phase, AmplitudeDependence, AMPLITUDE_Z,
};

/// The evidence sentence for a fitted effect. `base` holds the starting model's (`base_spec`)
/// predictions; `params` the effect's fitted parameters (name, value, s.e.).
#[allow(clippy::too_many_arguments)]
pub fn sentence(
    effect: &str,
    obs: &[&Observation],
    base_spec: &ModelSpec,
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
            let dep = amplitude_dependence(obs, base, base_spec);
            match (
                amplitude_contrast(obs, &r, base_spec),
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
