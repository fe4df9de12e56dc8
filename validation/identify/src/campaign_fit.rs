//! Steps 4-8 over the whole campaign: from the records' analyses to the identification
//! (exclusions, frequency span, saturation detection, pendulum fit, delay alternative).

use super::fit::{self, Point};
use super::model_file::build_model;
use super::pendulum::{delay_alternative_fit, pendulum_fit, points, start_factors};
use super::saturation_limit::estimate_limit;
use super::uncertainty::uncertainty_database;
use super::{
    name_records, reason, worker_count, Bandwidth, Identification, IdentifyError, IdentifyOptions,
    Parameter, RecordFit, Saturation, POOR_FIT, SEED_BANDWIDTH,
};
use num_complex::Complex64;
use std::collections::BTreeMap;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, ModelSpec};

/// The identification from the records' analyses ([`analyse_records`](super::analyse_records)
/// or [`analyse_folder`](super::analyse_folder)), in record order, of the campaign named
/// `campaign_name` (`name` in its manifest).
pub fn identify_analysed(
    mut records: Vec<RecordFit>,
    campaign_name: Option<String>,
    opts: &IdentifyOptions,
) -> Result<Identification, IdentifyError> {
    if records.is_empty() {
        return Err(IdentifyError::Empty);
    }
    let mut warnings = exclusion_warnings(&records);
    if records.iter().all(|r| r.excluded.is_some()) {
        return Err(IdentifyError::NoUsableRecords(warnings.join("; ")));
    }
    warnings.extend(period_variation_warning(&records));
    check_frequency_span(&records)?;
    let factors = start_factors(opts.start_model.as_ref(), &records);
    let ctx = FitContext {
        factors: &factors,
        start: start_bandwidth(opts),
        opts,
    };
    let candidates = saturation_candidates(&records, opts, ctx.start);
    let mut linear = ctx.fit(&records, &candidates)?;
    let (mut saturated, mut harmonic_only) =
        classify_candidates(&records, &ctx, &linear.lm, &candidates);
    let linear_tops = keep_non_monotone(
        &records,
        &linear.lm,
        &mut saturated,
        &mut harmonic_only,
        &mut warnings,
    );
    if !harmonic_only.is_empty() {
        linear = ctx.fit(&records, &saturated)?;
        warnings.push(format!(
            "{}: significant odd harmonics without gain compression; kept in the fit",
            name_records(&harmonic_only)
        ));
    }
    for &c in &saturated {
        records[c].excluded = Some(reason::SATURATED.to_string());
    }
    let saturation = Saturation {
        records: saturated,
        harmonic_only,
        limit: None,
        limit_stderr: None,
        demanded_acceleration: Vec::new(),
    };
    let saturation = estimate_saturation(
        &mut records,
        &ctx,
        saturation,
        linear_tops,
        &mut linear,
        &mut warnings,
    )?;
    let delay_alternative =
        misfit_warnings(&records, &ctx, &saturation.records, &linear, &mut warnings);
    let LinearFit {
        lm,
        bw_est,
        bw_note,
    } = linear;
    if !bw_est {
        warnings.push(bw_note.clone());
    }
    let (a, b) = pendulum_parameters(&lm);
    let bandwidth = fitted_bandwidth(&lm, bw_est, bw_note);
    let p = lm.params;
    let uncertainty = uncertainty_database(&records, &p, &factors);
    let mut ident = Identification {
        campaign_name,
        records,
        a,
        b,
        bandwidth,
        saturation,
        uncertainty,
        reduced_chi2: if lm.dof > 0 {
            lm.chi2 / lm.dof as f64
        } else {
            f64::NAN
        },
        warnings,
        delay_alternative,
        model: ModelSpec {
            name: None,
            description: None,
            effects: Vec::new(),
            provenance: toml::Table::new(),
            stderr: toml::Table::new(),
        },
    };
    ident.model = build_model(&ident, opts)?;
    Ok(ident)
}

/// The warning naming the records whose first harmonic varies from period to period beyond
/// the campaign's noise (their standard errors are their own), if any.
fn period_variation_warning(records: &[RecordFit]) -> Option<String> {
    let own: Vec<usize> = records
        .iter()
        .filter(|r| {
            r.components.as_ref().is_some_and(|c| {
                c.noise
                    .iter()
                    .any(|n| n.first.source == crate::NoiseSource::Inconsistent)
            })
        })
        .map(|r| r.index)
        .collect();
    (!own.is_empty()).then(|| {
        format!(
            "{}: the first harmonic varies from period to period beyond the campaign's noise \
             (a response that does not quite repeat: a transient left in the steady state, \
             impacts, a drift); their standard errors are their own, larger",
            name_records(&own)
        )
    })
}

/// The tracking low-pass of the fit (`omega_n` rad/s and `zeta`, parameters 8 and 9), with
/// standard errors when the data determine it (`estimated`), else zero and the note why.
fn fitted_bandwidth(lm: &fit::LmResult, estimated: bool, note: String) -> Bandwidth {
    Bandwidth {
        omega_n: lm.params[8],
        zeta: lm.params[9],
        omega_n_stderr: if estimated { lm.stderr[8] } else { 0.0 },
        zeta_stderr: if estimated { lm.stderr[9] } else { 0.0 },
        estimated,
        note,
    }
}

/// One warning per exclusion reason, naming the records it excluded.
fn exclusion_warnings(records: &[RecordFit]) -> Vec<String> {
    let mut by_reason: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for r in records {
        if let Some(why) = &r.excluded {
            by_reason.entry(why.clone()).or_default().push(r.index);
        }
    }
    by_reason
        .iter()
        .map(|(why, ix)| format!("{}: excluded: {why}", name_records(ix)))
        .collect()
}

/// The tracking low-pass `(omega_n rad/s, zeta)` the fit starts from: given, else the start
/// model's, else the seed's.
fn start_bandwidth(opts: &IdentifyOptions) -> (f64, f64) {
    opts.given_bandwidth
        .or_else(|| {
            opts.start_model.as_ref().and_then(|m| {
                Some((
                    m.value(
                        EffectKind::TrackingLowpass,
                        Binding::Axis(Axis::X),
                        "omega_n",
                    )?,
                    m.value(EffectKind::TrackingLowpass, Binding::Axis(Axis::X), "zeta")?,
                ))
            })
        })
        .unwrap_or(SEED_BANDWIDTH)
}

/// What every pendulum fit of the campaign shares: the start model's factors per record,
/// the start bandwidth and the options.
struct FitContext<'a> {
    factors: &'a [[Complex64; 2]],
    start: (f64, f64),
    opts: &'a IdentifyOptions,
}

/// A pendulum fit and whether the bandwidth was estimated (else why not).
struct LinearFit {
    lm: fit::LmResult,
    bw_est: bool,
    bw_note: String,
}

impl FitContext<'_> {
    /// The pendulum fit over the usable records less `skip`.
    fn fit(&self, records: &[RecordFit], skip: &[usize]) -> Result<LinearFit, IdentifyError> {
        let pts = points(records, self.factors, skip);
        let (lm, bw_est, bw_note) = pendulum_fit(&pts, self.start, self.opts.fix_bandwidth)?;
        Ok(LinearFit {
            lm,
            bw_est,
            bw_note,
        })
    }
}

/// Saturation candidates: records with a significant third harmonic in the directly excited
/// output among the upper half of their axis's acceleration demands (with the start
/// bandwidth `(wn0, z0)`).
fn saturation_candidates(
    records: &[RecordFit],
    opts: &IdentifyOptions,
    (wn0, z0): (f64, f64),
) -> Vec<usize> {
    if !(opts.detect_saturation && opts.harmonics >= 3) {
        return Vec::new();
    }
    records
        .iter()
        .filter(|r| r.excluded.is_none())
        .filter(|r| r.third_harmonic_snr[r.excited.index()] > 6.0)
        .filter(|r| {
            // Saturation acts on the largest acceleration demands of an axis: odd
            // harmonics at small demands come from something else (friction, backlash).
            let demand = |q: &RecordFit| {
                q.amplitude * q.omega * q.omega * fit::lowpass(q.omega, wn0, z0).norm()
            };
            let mut d: Vec<f64> = records
                .iter()
                .filter(|q| q.excluded.is_none() && q.excited == r.excited)
                .map(demand)
                .collect();
            d.sort_by(f64::total_cmp);
            demand(r) >= d[d.len() / 2]
        })
        .map(|r| r.index)
        .collect()
}

/// Splits the `candidates` into those whose directly excited gain leaves the linear fit
/// `lm` (saturated) and those with odd harmonics only.
fn classify_candidates(
    records: &[RecordFit],
    ctx: &FitContext,
    lm: &fit::LmResult,
    candidates: &[usize],
) -> (Vec<usize>, Vec<usize>) {
    let mut saturated = Vec::new();
    let mut harmonic_only = Vec::new();
    for &c in candidates {
        let r = &records[c];
        let j = r.excited.index();
        let gm = fit::model(
            &lm.params,
            &Point {
                i: j,
                j,
                omega: r.omega_fit,
                g: r.g[j],
                sigma: r.sigma[j],
                factor: ctx.factors[c][j],
            },
        );
        // Saturation changes the first harmonic: compressed when the clipping is mild relative
        // to the phase lag it adds, expanded towards 4/pi of the limit when the clipped
        // acceleration turns square; either way the gain leaves the linear model's.
        let dev = (r.g[j] - gm).norm() / gm.norm();
        let rel_sigma = r.sigma[j] / gm.norm();
        if dev > (4.0 * rel_sigma).max(0.005) {
            saturated.push(c);
        } else {
            harmonic_only.push(c);
        }
    }
    (saturated, harmonic_only)
}

/// Moves the saturated records that are not monotone in the acceleration demand back to
/// `harmonic_only`, and returns each axis's largest demand among its linear records
/// (m/s², with the bandwidth of `lm`).
///
/// Saturation is monotone in the acceleration demand: a record that deviates from the
/// linear model while a record of its axis with a larger demand does not is not saturated
/// (a misfit of the seed's structure, e.g. a delay swallowed by the low-pass, deviates
/// anywhere). Such records (below 70 % of the largest linear demand: a mild clip hides in
/// the noise) stay in the fit.
fn keep_non_monotone(
    records: &[RecordFit],
    lm: &fit::LmResult,
    saturated: &mut Vec<usize>,
    harmonic_only: &mut Vec<usize>,
    warnings: &mut Vec<String>,
) -> [f64; 2] {
    let demand_of = |q: &RecordFit| {
        q.amplitude * q.omega * q.omega * fit::lowpass(q.omega, lm.params[8], lm.params[9]).norm()
    };
    let linear_top = |axis: Axis| -> f64 {
        records
            .iter()
            .filter(|q| q.excluded.is_none() && q.excited == axis && !saturated.contains(&q.index))
            .map(demand_of)
            .fold(0.0, f64::max)
    };
    let linear_tops = [linear_top(Axis::X), linear_top(Axis::Y)];
    let (kept, not_monotone): (Vec<usize>, Vec<usize>) = saturated
        .iter()
        .partition(|&&c| demand_of(&records[c]) > 0.7 * linear_tops[records[c].excited.index()]);
    if !not_monotone.is_empty() {
        warnings.push(format!(
            "{}: off the linear model but with smaller acceleration demands than linear records \
             of their axis: not saturation; kept in the fit",
            name_records(&not_monotone)
        ));
        harmonic_only.extend(not_monotone);
        *saturated = kept;
    }
    linear_tops
}

/// The acceleration limit of the saturated records (left out of `linear`): each record's
/// demanded acceleration and the limit whose describing function reproduces them, no lower
/// than the largest linear demands `linear_tops`. A limit that would have to go below them
/// is not saturation as the seed's structure has it: the records go back into the fit,
/// which is redone into `linear`.
fn estimate_saturation(
    records: &mut [RecordFit],
    ctx: &FitContext,
    mut saturation: Saturation,
    linear_tops: [f64; 2],
    linear: &mut LinearFit,
    warnings: &mut Vec<String>,
) -> Result<Saturation, IdentifyError> {
    let saturated = saturation.records.clone();
    if saturated.is_empty() {
        return Ok(saturation);
    }
    let p = linear.lm.params;
    for &c in &saturated {
        let r = &records[c];
        let h = fit::lowpass(r.omega, p[8], p[9]).norm();
        saturation
            .demanded_acceleration
            .push((c, r.amplitude * r.omega * r.omega * h));
    }
    let floor = saturated
        .iter()
        .map(|&c| linear_tops[records[c].excited.index()])
        .fold(f64::INFINITY, f64::min);
    let (limit, se, at_floor) = estimate_limit(
        records,
        &saturated,
        &p,
        ctx.factors,
        floor,
        worker_count(ctx.opts),
    );
    if at_floor {
        // The limit's describing function does not reproduce these records' change: it
        // would need a limit below the demands of records that stay linear. Not
        // saturation as the seed's structure has it; the records go back into the fit.
        warnings.push(format!(
            "{}: odd harmonics and a gain change that an acceleration limit does not \
             reproduce (it would need a limit below the demands of linear records); kept \
             in the fit, no limit estimated",
            name_records(&saturated)
        ));
        for &c in &saturated {
            records[c].excluded = None;
        }
        saturation.harmonic_only.extend(saturated.iter().copied());
        saturation.records.clear();
        saturation.demanded_acceleration.clear();
        *linear = ctx.fit(records, &[])?;
    } else {
        saturation.limit = limit;
        saturation.limit_stderr = se;
        warnings.push(format!(
            "{}: acceleration saturation detected{}; left out of the linear fit",
            name_records(&saturated),
            match limit {
                Some(l) => format!(" (limit about {l:.3} m/s2)"),
                None => String::new(),
            }
        ));
    }
    Ok(saturation)
}

/// When the pendulum model misfits the data (reduced chi-square above [`POOR_FIT`]): the
/// warning, and with an estimated bandwidth the fit of the low-pass with a pure delay, with a
/// warning when it fits much better.
fn misfit_warnings(
    records: &[RecordFit],
    ctx: &FitContext,
    saturated: &[usize],
    linear: &LinearFit,
    warnings: &mut Vec<String>,
) -> Option<super::DelayAlternative> {
    let lm = &linear.lm;
    if !(lm.dof > 0 && lm.chi2 / lm.dof as f64 > POOR_FIT) {
        return None;
    }
    warnings.push(format!(
        "the pendulum model misfits the data: reduced chi-square {:.1} (about 1 when the \
         model is right). A physical effect the seed's model lacks is likely acting: `cargo \
         xtask diagnose CAMPAIGN --model MODEL` names it with evidence, `cargo xtask loop \
         CAMPAIGN` adds it; until then the standard errors are inflated by the misfit and \
         the uncertainty weights carry it",
        lm.chi2 / lm.dof as f64
    ));
    if !linear.bw_est {
        return None;
    }
    let pts = points(records, ctx.factors, saturated);
    let alt = delay_alternative_fit(&pts, ctx.start, lm.params[8])?;
    if alt.reduced_chi2 < 0.5 * lm.chi2 / lm.dof as f64 {
        warnings.push(format!(
            "the tracking low-pass may be absorbing a delay: alone it fits omega_n = \
             {:.2} rad/s, zeta = {:.3} (reduced chi-square {:.1}); with a pure delay of \
             {:.1} ms it fits omega_n = {:.2} rad/s, zeta = {:.3} (reduced chi-square \
             {:.1}). The model file keeps the seed's structure (low-pass only); the \
             diagnosis tests the delay on held-out records",
            lm.params[8],
            lm.params[9],
            lm.chi2 / lm.dof as f64,
            alt.delay_s * 1e3,
            alt.omega_n,
            alt.zeta,
            alt.reduced_chi2
        ));
    }
    Some(alt)
}

/// The fitted pendulum coefficients `a` (dimensionless) and `b` (s²) with their standard
/// errors, named by their model-file keys.
fn pendulum_parameters(lm: &fit::LmResult) -> ([[Parameter; 2]; 2], [[Parameter; 2]; 2]) {
    let param = |name: String, k: usize| Parameter {
        name,
        value: lm.params[k],
        stderr: lm.stderr[k],
        estimated: true,
    };
    let names = ["11", "12", "21", "22"];
    let a = [
        [
            param(format!("pendulum.a{}", names[0]), 0),
            param(format!("pendulum.a{}", names[1]), 1),
        ],
        [
            param(format!("pendulum.a{}", names[2]), 2),
            param(format!("pendulum.a{}", names[3]), 3),
        ],
    ];
    let b = [
        [
            param(format!("pendulum.b{}", names[0]), 4),
            param(format!("pendulum.b{}", names[1]), 5),
        ],
        [
            param(format!("pendulum.b{}", names[2]), 6),
            param(format!("pendulum.b{}", names[3]), 7),
        ],
    ];
    (a, b)
}

fn check_frequency_span(records: &[RecordFit]) -> Result<(), IdentifyError> {
    let mut problems = Vec::new();
    for axis in Axis::BOTH {
        let recs: Vec<&RecordFit> = records
            .iter()
            .filter(|r| r.excluded.is_none() && r.excited == axis)
            .collect();
        if recs.is_empty() {
            problems.push(format!(
                "no usable record excites {axis}_cr, so G1{0} and G2{0} cannot be identified",
                axis.index() + 1
            ));
            continue;
        }
        let mut w: Vec<f64> = recs.iter().map(|r| r.omega).collect();
        w.sort_by(|a, b| a.total_cmp(b));
        w.dedup_by(|a, b| (*a / *b - 1.0).abs() < 1e-6);
        let span = w[w.len() - 1] / w[0];
        if w.len() < 3 || span < 2.0 {
            let ix: Vec<usize> = recs.iter().map(|r| r.index).collect();
            problems.push(format!(
                "the usable records exciting {axis}_cr ({}) span {} distinct frequencies over a \
                 factor {span:.2} ({:.3}..{:.3} rad/s): a and b of G1{n} and G2{n} cannot be \
                 separated; at least 3 frequencies spanning a factor 2 are needed, ideally up to \
                 where b w^2 dominates a",
                name_records(&ix),
                w.len(),
                w[0],
                w[w.len() - 1],
                n = axis.index() + 1
            ));
        }
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(IdentifyError::FrequencySpan(problems.join("; ")))
    }
}
