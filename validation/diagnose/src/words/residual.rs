//! What a model leaves unexplained, in words: features of the residual computed against the
//! final model, each tested at the diagnosis's significance level (shared over the five
//! features: [`ALPHA`]` / 5`). Amplitude dependence, a resonance or a misfit growing with
//! frequency, a trend in the records (common or record by record), odd harmonics growing with
//! amplitude, and a gain that moves with the operating point.

use crate::criterion::{chi2_quantile, distinct_omegas, z_one_sided, ALPHA};
use crate::measure::{whitened, Prediction, FIRST_COMPONENTS};
use crate::observe::Observation;
use num_complex::Complex64;
use serde::Serialize;

/// One feature of the residual.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ResidualFeature {
    /// `amplitude_dependence`, `resonance`, `growing_with_frequency`, `trend`,
    /// `odd_harmonics`, `operating_point`.
    pub feature: &'static str,
    /// How far beyond the noise: a standard normal deviate (or its chi-square equivalent).
    pub z: f64,
    /// The feature in words, for the report.
    pub words: String,
}

const FEATURES: f64 = 5.0;

/// The significant features of the residual of `preds` on `obs`, strongest first.
pub fn describe_residual(obs: &[&Observation], preds: &[Prediction]) -> Vec<ResidualFeature> {
    let mut out: Vec<ResidualFeature> = [
        amplitude(obs, preds),
        frequency(obs, preds),
        trend(obs, preds),
        harmonics(obs, preds),
        operating_point(obs, preds),
    ]
    .into_iter()
    .flatten()
    .collect();
    out.sort_by(|a, b| b.z.total_cmp(&a.z));
    out
}

/// The level each feature is tested at (two-sided for a signed contrast).
fn z_crit() -> f64 {
    z_one_sided(ALPHA / FEATURES / 2.0)
}

/// A chi-square of `nu` components as a standard normal deviate (Wilson-Hilferty).
fn chi2_z(chi2: f64, nu: f64) -> f64 {
    let h = 2.0 / (9.0 * nu);
    ((chi2 / nu).cbrt() - (1.0 - h)) / h.sqrt()
}

/// Measured over modelled response of a record's excited output, and its relative variance.
fn ratio(o: &Observation, p: &Prediction) -> Option<(Complex64, f64)> {
    let j = o.excited.index();
    let m = p.g[j] * o.u1;
    (m.norm() > 0.0).then(|| (o.y1[j] / m, o.y1_var[j] / o.y1[j].norm_sqr().max(1e-300)))
}

/// Inverse-variance weighted mean of the log-ratios of pairs, with its standard error.
fn weighted(pairs: &[(Complex64, f64)]) -> Option<(Complex64, f64)> {
    let sw: f64 = pairs.iter().map(|(_, v)| 1.0 / v).sum();
    (sw > 0.0 && !pairs.is_empty()).then(|| {
        let m = pairs.iter().map(|(q, v)| q / v).sum::<Complex64>() / sw;
        (m, sw.sqrt().recip())
    })
}

/// The large sines against the small ones at the same axis, frequency and operating point,
/// per third of the band; the strongest third.
fn amplitude(obs: &[&Observation], preds: &[Prediction]) -> Option<ResidualFeature> {
    let amps: Vec<f64> = obs.iter().map(|o| o.nominal_amplitude).collect();
    let lo = amps.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = amps.iter().copied().fold(0.0, f64::max);
    if hi <= lo * 1.01 {
        return None;
    }
    let w = distinct_omegas(obs);
    let third =
        |om: f64| (3 * w.iter().position(|x| *x >= om * (1.0 - 1e-9)).unwrap_or(0)) / w.len();
    let mut by_third: [Vec<(Complex64, f64)>; 3] = Default::default();
    for (k, o) in obs.iter().enumerate() {
        if (o.nominal_amplitude - hi).abs() > 1e-12 {
            continue;
        }
        let small = obs.iter().position(|p| {
            p.excited == o.excited
                && (p.omega - o.omega).abs() <= 1e-9 * o.omega
                && p.operating_point == o.operating_point
                && (p.nominal_amplitude - lo).abs() <= 1e-12
        });
        let (Some(m), Some((rl, vl))) = (small, ratio(o, &preds[k])) else {
            continue;
        };
        if let Some((rs, vs)) = ratio(obs[m], &preds[m]) {
            by_third[third(o.omega).min(2)].push(((rl / rs).ln(), vl + vs));
        }
    }
    let (k, (m, se)) = by_third
        .iter()
        .enumerate()
        .filter_map(|(k, p)| Some((k, weighted(p)?)))
        .max_by(|a, b| a.1 .0.norm().total_cmp(&b.1 .0.norm()))?;
    let z = m.re.abs().max(m.im.abs()) / se;
    (z > z_crit()).then(|| {
        let better = m.re > 0.0 || m.im > 0.0;
        let band = ["lowest", "middle", "highest"][k];
        ResidualFeature {
            feature: "amplitude_dependence",
            z,
            words: format!(
                "amplitude-dependent {}: in the {band} third of the band the {:.0} mm sines \
                 respond {:+.1} % in gain and {:+.1} deg in phase against the {:.0} mm ones, \
                 beyond what the model predicts ({z:.1} standard errors)",
                if better {
                    "stiffening (or a dead band): the large sines follow better than the small"
                } else {
                    "softening (or clipping): the large sines follow worse than the small"
                },
                hi * 1e3,
                100.0 * m.re,
                m.im.to_degrees(),
                lo * 1e3
            ),
        }
    })
}

/// The first-harmonic misfit by frequency: the frequency with the largest excess; a resonance
/// where the measured/model gain peaks or dips there, a misfit growing with frequency where it
/// is the top of the band.
fn frequency(obs: &[&Observation], preds: &[Prediction]) -> Option<ResidualFeature> {
    let w = distinct_omegas(obs);
    let mut rows = Vec::new();
    let mut r = Vec::new();
    for om in &w {
        let (mut chi2, mut nu, mut gains) = (0.0, 0.0, Vec::new());
        for (o, p) in obs.iter().zip(preds) {
            if (o.omega - om).abs() > 1e-9 * om {
                continue;
            }
            r.clear();
            whitened(o, p, &mut r);
            // Real and imaginary first harmonic of both outputs (not the trends).
            chi2 += [0, 1, 3, 4].iter().map(|&i| r[i] * r[i]).sum::<f64>();
            nu += (FIRST_COMPONENTS - 2) as f64;
            if let Some((q, _)) = ratio(o, p) {
                gains.push(q);
            }
        }
        let mean = gains.iter().sum::<Complex64>() / gains.len().max(1) as f64;
        rows.push((*om, chi2, nu, mean));
    }
    let n = rows.len();
    let (k, &(om, chi2, nu, q)) = rows
        .iter()
        .enumerate()
        .max_by(|a, b| (a.1 .1 - a.1 .2).total_cmp(&(b.1 .1 - b.1 .2)))?;
    let level = ALPHA / FEATURES / n as f64;
    if chi2 <= chi2_quantile(nu, level) {
        return None;
    }
    let db = 20.0 * q.norm().max(1e-12).log10();
    let deg = q.arg().to_degrees();
    let mag = |i: usize| rows[i].3.norm();
    let peak = (k == 0 || mag(k) > mag(k - 1)) && (k + 1 == n || mag(k) > mag(k + 1));
    let dip = (k == 0 || mag(k) < mag(k - 1)) && (k + 1 == n || mag(k) < mag(k + 1));
    let (feature, what) = if k + 1 == n && n > 2 {
        (
            "growing_with_frequency",
            format!("a misfit growing towards the top of the band (a resonance or a lag above {om:.1} rad/s?)"),
        )
    } else if peak || dip {
        ("resonance", format!("a resonance near {om:.1} rad/s"))
    } else {
        (
            "resonance",
            format!("a misfit concentrated near {om:.1} rad/s"),
        )
    };
    Some(ResidualFeature {
        feature,
        z: chi2_z(chi2, nu),
        words: format!(
            "{what}: measured/model {db:+.1} dB and {deg:+.1} deg there, {:.1} times the \
             first harmonic's noise per component",
            (chi2 / nu).sqrt()
        ),
    })
}

/// The trend of each output against the model: common to the records (a drift) or different
/// from record to record (a sensor re-zeroed at every record, drifting at its own rate).
fn trend(obs: &[&Observation], preds: &[Prediction]) -> Option<ResidualFeature> {
    let mut best: Option<ResidualFeature> = None;
    for i in 0..2 {
        let d: Vec<(f64, f64)> = obs
            .iter()
            .zip(preds)
            .map(|(o, p)| (o.slope[i] - p.slope[i], o.slope_var[i].max(1e-300)))
            .collect();
        let n = d.len() as f64;
        let chi2: f64 = d.iter().map(|(x, v)| x * x / v).sum();
        if n < 2.0 || chi2 <= chi2_quantile(n, ALPHA / FEATURES / 2.0) {
            continue;
        }
        let sw: f64 = d.iter().map(|(_, v)| 1.0 / v).sum();
        let mean = d.iter().map(|(x, v)| x / v).sum::<f64>() / sw;
        let scatter: f64 = d.iter().map(|(x, v)| (x - mean).powi(2) / v).sum();
        let varying = scatter > chi2_quantile(n - 1.0, ALPHA / FEATURES / 2.0);
        let sd = (d.iter().map(|(x, _)| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let z = chi2_z(chi2, n);
        if best.as_ref().is_some_and(|b| b.z >= z) {
            continue;
        }
        let axis = ["x", "y"][i];
        best = Some(ResidualFeature {
            feature: "trend",
            z,
            words: if varying {
                format!(
                    "a trend in every record the model lacks on the {axis} ZMP, changing from \
                     record to record: mean {:+.3} mm/s, spread {:.3} mm/s between records \
                     (a sensor re-zeroed at each record with its own drift?)",
                    mean * 1e3,
                    sd * 1e3
                )
            } else {
                format!(
                    "a trend common to the records on the {axis} ZMP: {:+.3} mm/s (a drifting \
                     sensor)",
                    mean * 1e3
                )
            },
        });
    }
    best
}

/// Third harmonics the model does not predict (where compared), and how they grow with
/// amplitude.
fn harmonics(obs: &[&Observation], preds: &[Prediction]) -> Option<ResidualFeature> {
    let (mut chi2, mut nu) = (0.0, 0.0);
    let lo = obs
        .iter()
        .map(|o| o.nominal_amplitude)
        .fold(f64::INFINITY, f64::min);
    let mut rel = [(0.0, 0usize); 2];
    let mut r = Vec::new();
    for (o, p) in obs.iter().zip(preds).filter(|(o, _)| o.third_band) {
        r.clear();
        whitened(o, p, &mut r);
        chi2 += r[FIRST_COMPONENTS..].iter().map(|x| x * x).sum::<f64>();
        nu += (r.len() - FIRST_COMPONENTS) as f64;
        let j = o.excited.index();
        let miss = (o.y3[j] - o.third(p.g3[j])).norm() / o.y1[j].norm().max(1e-300);
        let big = usize::from(o.nominal_amplitude > lo * 1.01);
        rel[big].0 += miss;
        rel[big].1 += 1;
    }
    if nu < 1.0 || chi2 <= chi2_quantile(nu, ALPHA / FEATURES) {
        return None;
    }
    let mean = |k: usize| rel[k].0 / rel[k].1.max(1) as f64;
    let growth = if rel[0].1 > 0 && rel[1].1 > 0 {
        format!(
            ", {:.1} % of the fundamental at the large amplitude against {:.1} % at the small",
            100.0 * mean(1),
            100.0 * mean(0)
        )
    } else {
        String::new()
    };
    Some(ResidualFeature {
        feature: "odd_harmonics",
        z: chi2_z(chi2, nu),
        words: format!(
            "odd harmonics the model lacks: the third harmonic misses by {:.1} times its noise \
             per component{growth}",
            (chi2 / nu).sqrt()
        ),
    })
}

/// The gain against the model at each operating point, for sines alike otherwise: its spread
/// beyond the noise, per excited axis.
fn operating_point(obs: &[&Observation], preds: &[Prediction]) -> Option<ResidualFeature> {
    let mut ops: Vec<[f64; 2]> = obs.iter().map(|o| o.operating_point).collect();
    ops.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    ops.dedup();
    if ops.len() < 2 {
        return None;
    }
    let mut best: Option<ResidualFeature> = None;
    for axis in zmp_models::Axis::BOTH {
        let per_op: Vec<(Complex64, f64)> = ops
            .iter()
            .filter_map(|op| {
                let v: Vec<(Complex64, f64)> = obs
                    .iter()
                    .zip(preds)
                    .filter(|(o, _)| o.excited == axis && o.operating_point == *op)
                    .filter_map(|(o, p)| ratio(o, p).map(|(q, v)| (q.ln(), v)))
                    .collect();
                weighted(&v)
            })
            .collect();
        if per_op.len() < 2 {
            continue;
        }
        let Some((m, _)) = weighted(&per_op.iter().map(|(q, s)| (*q, s * s)).collect::<Vec<_>>())
        else {
            continue;
        };
        let chi2: f64 = per_op
            .iter()
            .map(|(q, s)| (q.re - m.re).powi(2) / (s * s))
            .sum();
        let nu = (per_op.len() - 1) as f64;
        if chi2 <= chi2_quantile(nu, ALPHA / FEATURES / 2.0) {
            continue;
        }
        let spread = per_op
            .iter()
            .map(|(q, _)| q.re)
            .fold(f64::NEG_INFINITY, f64::max)
            - per_op
                .iter()
                .map(|(q, _)| q.re)
                .fold(f64::INFINITY, f64::min);
        let z = chi2_z(chi2, nu);
        if best.as_ref().is_none_or(|b| z > b.z) {
            let ch = zmp_models::Channel::new(axis, axis);
            best = Some(ResidualFeature {
                feature: "operating_point",
                z,
                words: format!(
                    "the gain of {} against the model changes with the operating point by \
                     {:.1} % across the campaign's points, beyond the noise",
                    ch.name(),
                    100.0 * spread
                ),
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::criterion::tests::normals;
    use zmp_models::Axis;

    /// The model's response on both outputs: 0.5 on the excited one, 0.05 across.
    const G: f64 = 0.5;
    /// Noise of a first or third harmonic, and of a trend (m, m/s): a 1 % first harmonic
    /// of the small sine, as in the virtual robot's campaigns.
    const SIGMA: f64 = 2e-5;
    const SIGMA_SLOPE: f64 = 1e-6;

    /// A campaign on both axes, six frequencies, 3 and 8 mm, whose measurements are the
    /// model's plus noise plus what `change(record, &mut observation)` adds; and the model's
    /// predictions.
    fn campaign(change: impl Fn(usize, &mut Observation)) -> (Vec<Observation>, Vec<Prediction>) {
        let omegas = [1.0, 2.0, 4.0, 8.0, 12.0, 16.0];
        let mut obs = Vec::new();
        let mut e = normals(24 * 12, 3).into_iter();
        let mut e = move || e.next().unwrap();
        for axis in Axis::BOTH {
            for &omega in &omegas {
                for amp in [0.003, 0.008] {
                    let j = axis.index();
                    let mut y1 = [Complex64::new(0.0, 0.0); 2];
                    for (i, y) in y1.iter_mut().enumerate() {
                        let g = if i == j { G } else { 0.1 * G };
                        *y = Complex64::new(g * amp + SIGMA * e(), SIGMA * e());
                    }
                    let mut o = Observation {
                        index: obs.len(),
                        excited: axis,
                        omega,
                        operating_point: [0.0; 2],
                        nominal_amplitude: amp,
                        t0: 0.0,
                        t1: 60.0,
                        u1: Complex64::new(amp, 0.0),
                        y1,
                        y1_var: [SIGMA * SIGMA; 2],
                        y3: [
                            Complex64::new(SIGMA * e(), SIGMA * e()),
                            Complex64::new(SIGMA * e(), SIGMA * e()),
                        ],
                        y3_var: [SIGMA * SIGMA; 2],
                        third_band: true,
                        slope: [SIGMA_SLOPE * e(), SIGMA_SLOPE * e()],
                        slope_var: [SIGMA_SLOPE * SIGMA_SLOPE; 2],
                        noise_std: [1e-4; 2],
                        samples: 12_000,
                    };
                    change(obs.len(), &mut o);
                    obs.push(o);
                }
            }
        }
        let preds = obs
            .iter()
            .map(|o| {
                let j = o.excited.index();
                let mut g = [Complex64::new(0.1 * G, 0.0); 2];
                g[j] = Complex64::new(G, 0.0);
                Prediction {
                    g,
                    g3: [Complex64::new(0.0, 0.0); 2],
                    slope: [0.0; 2],
                }
            })
            .collect();
        (obs, preds)
    }

    fn features(change: impl Fn(usize, &mut Observation)) -> Vec<ResidualFeature> {
        let (obs, preds) = campaign(change);
        let refs: Vec<&Observation> = obs.iter().collect();
        describe_residual(&refs, &preds)
    }

    fn names(f: &[ResidualFeature]) -> Vec<&'static str> {
        f.iter().map(|f| f.feature).collect()
    }

    /// A model right to the noise leaves nothing to describe (each feature is tested at
    /// 1 % / 5 on 48 records of Gaussian noise).
    #[test]
    fn a_right_model_leaves_no_words() {
        assert_eq!(features(|_, _| {}), Vec::new());
    }

    /// A sensor re-zeroed at every record, drifting at its own rate (between -1 and +1
    /// mm/s, 1000 standard errors): a trend changing from record to record, and nothing
    /// else; a drift common to the records is said to be common.
    #[test]
    fn a_per_record_drift_is_named_as_one() {
        let f = features(|k, o| o.slope[0] += 1e-3 * ((k % 3) as f64 - 1.0));
        assert_eq!(names(&f), vec!["trend"], "{f:?}");
        assert!(
            f[0].words.contains("changing from record to record"),
            "{}",
            f[0].words
        );
        let f = features(|_, o| o.slope[1] += 2e-5);
        assert_eq!(names(&f), vec!["trend"], "{f:?}");
        assert!(
            f[0].words.contains("common to the records on the y ZMP"),
            "{}",
            f[0].words
        );
    }

    /// A third harmonic growing with the square of the amplitude (2 % of the fundamental at
    /// 3 mm, 14 % at 8 mm): odd harmonics growing with amplitude.
    #[test]
    fn odd_harmonics_growing_with_amplitude_are_named() {
        let f = features(|_, o| {
            let j = o.excited.index();
            o.y3[j] += o.y1[j] * 0.02 * (o.nominal_amplitude / 0.003).powi(2);
        });
        assert_eq!(names(&f), vec!["odd_harmonics"], "{f:?}");
        let w = &f[0].words;
        assert!(w.contains("at the large amplitude against"), "{w}");
    }

    /// A gain 10 % above the model's at 4 rad/s only, on both amplitudes and axes (20
    /// standard deviations of one record): a resonance near 4 rad/s, no amplitude dependence.
    #[test]
    fn a_resonance_is_placed_at_its_frequency() {
        let f = features(|_, o| {
            if o.omega == 4.0 {
                let j = o.excited.index();
                o.y1[j] *= 1.1;
            }
        });
        assert_eq!(names(&f), vec!["resonance"], "{f:?}");
        assert!(
            f[0].words.contains("a resonance near 4.0 rad/s"),
            "{}",
            f[0].words
        );
    }

    /// The small sines responding 10 % less than the model and the large ones as it says
    /// (a dead band the large sines cross): amplitude-dependent stiffening.
    #[test]
    fn amplitude_dependent_stiffening_is_named() {
        let f = features(|_, o| {
            if o.nominal_amplitude < 0.005 {
                let j = o.excited.index();
                o.y1[j] *= 0.9;
            }
        });
        let a = f.iter().find(|f| f.feature == "amplitude_dependence");
        let a = a.unwrap_or_else(|| panic!("no amplitude dependence in {f:?}"));
        assert!(a.words.contains("stiffening"), "{}", a.words);
        assert!(!names(&f).contains(&"odd_harmonics") && !names(&f).contains(&"trend"));
    }
}
