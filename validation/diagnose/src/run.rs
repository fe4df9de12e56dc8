//! The diagnosis of a campaign against a model: observations, the baseline error and its noise
//! floor, where the model fails, the search (`search`) and what it concludes: the verdict, the
//! findings with their evidence, the structures the data cannot decide between and the words
//! for what is left.

use crate::cells::{cells, channel_summary, Cell};
use crate::criterion::distinct_omegas;
use crate::fit::Fit;
use crate::measure::{aggregate, chi2_parts, predict, score, Prediction};
use crate::observe::{observe, Observation};
use crate::profiles::profile;
pub use crate::search::MAX_EFFECTS;
use crate::search::{fit_all, search, Search};
use crate::structure::{Candidate, Structure, Verdict};
use crate::words::{describe_residual, distinguish, Evidence, ResidualFeature};
use std::collections::BTreeMap;
use zmp_campaign::Campaign;
use zmp_identify::{analyse_records, reason, IdentifyOptions, RecordFit};
use zmp_models::{Axis, Binding, Channel, EffectKind, ModelSpec};

mod findings;
mod output;

pub use findings::{Alternative, Finding, Parted, Subject, Tried};

/// Format name of the JSON report.
pub const DIAGNOSIS_FORMAT: &str = "zmp-diagnosis/1";

/// Error above the noise floor, as a multiple of it, within which a model explains the data.
pub const EXPLAINED_RATIO: f64 = 1.5;

/// Chi-square per residual component (about 1 each for a right model with exact noise) above
/// which a model does not explain the data, whatever its error: an average misfit of more than
/// about 2.2 standard errors per component. The error measure is an RMS over the records'
/// normalisation, so an effect that moves a few quiet records by tens of standard errors can
/// sit near the noise floor in error; the slack over 1 is the per-record noise estimate's own
/// accuracy and the catalogue's laws being approximations of a robot's physics.
pub const EXPLAINED_CHI2_PER_COMPONENT: f64 = 5.0;

/// Why a diagnosis could not run, naming the input at fault.
#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    /// The campaign cannot be diagnosed (no usable record, no noise estimate, ...).
    #[error("{campaign}: {message}")]
    Campaign {
        /// The campaign's name as given.
        campaign: String,
        /// What is wrong with it.
        message: String,
    },
    /// The model does not describe the campaign or cannot be evaluated or fitted.
    #[error("{model}: {message}")]
    Model {
        /// The model's name as given.
        model: String,
        /// What is wrong with it.
        message: String,
    },
}

/// Options of a diagnosis.
#[derive(Debug, Clone)]
pub struct DiagnoseOptions {
    /// Shown in the report as given.
    pub campaign_path: String,
    /// The model's name, shown in the report and errors as given.
    pub model_path: String,
    /// Worker threads for the fits and predictions.
    pub threads: usize,
    /// Refuse a model off by 10x or more on a diagonal channel (another robot, units, swapped
    /// axes). Off only where the model was just identified from this very campaign (the loop).
    pub scale_check: bool,
    /// Wall-clock limit of the diagnosis (and of the loop): past it no fit evaluates its model
    /// again, each ends with its best parameters so far, and the search ends with the
    /// structures it scored ([`Diagnosis::time_limit_reached`] says so). `None`: no limit.
    pub time_limit: Option<std::time::Duration>,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            campaign_path: "campaign".into(),
            model_path: "model.toml".into(),
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            scale_check: true,
            time_limit: None,
        }
    }
}

/// The whole diagnosis.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// The campaign's name as given.
    pub campaign: String,
    /// The model's name as given.
    pub model: String,
    /// How many records the diagnosis compared.
    pub records: usize,
    /// Records left out: their index and why (no steady state, ...).
    pub skipped: Vec<(usize, String)>,
    /// The campaign's noise floor: the error a perfect model would still show.
    pub noise_floor: f64,
    /// The model's error as given, before any refit.
    pub baseline_error: f64,
    /// Held-out error of the model's own structure with every parameter refitted.
    pub refit_error: f64,
    /// What the search concluded: no effect missing, effects found, or an undecided set.
    pub verdict: Verdict,
    /// Whether the final model explains the data ([`explains`]).
    pub explained: bool,
    /// The report's findings, in the order it prints them.
    pub findings: Vec<Finding>,
    /// Effects of the best structure in the order of its chain, and the held-out error after
    /// each.
    pub selected: Vec<(Candidate, f64)>,
    /// The best structure fitted on every record (the model as given when the verdict is
    /// `none`).
    pub final_model: ModelSpec,
    /// The best structure's chain from the root, each step fitted on every record.
    pub chain: Vec<(Structure, Fit)>,
    /// The structures the data cannot decide between, best first (one when they can).
    pub alternatives: Vec<Alternative>,
    /// Structures the records part from a member of the set yet fit about as well (neither
    /// is the whole truth).
    pub parted: Vec<Parted>,
    /// The model's own structure refitted on every record.
    pub refit: Option<Fit>,
    /// The final model's error on every record (the diagnosis measure).
    pub final_error: f64,
    /// Cells of the starting model, worst first.
    pub cells: Vec<Cell>,
    /// `(channel, error, floor)` of the starting model.
    pub channels: Vec<(String, f64, f64)>,
    /// The records compared, as steady-state observations.
    pub observations: Vec<Observation>,
    /// The starting model's prediction of each observation.
    pub base_predictions: Vec<Prediction>,
    /// The final model's prediction of each observation.
    pub final_predictions: Vec<Prediction>,
    /// Every single candidate, scored.
    pub tried: Vec<Tried>,
    /// What the final model leaves, in words (empty when it explains the data).
    pub residual: Vec<ResidualFeature>,
    /// The criterion's threshold, a standard normal deviate.
    pub z_crit: f64,
    /// The criterion's mismatch factor: the best structure's held-out chi-square per
    /// component, at least 1.
    pub mismatch: f64,
    /// How many structures the search compared.
    pub compared: usize,
    /// Whether the time limit passed before the search ended.
    pub time_limit_reached: bool,
}

/// Steady-state observations of every usable record (the identification's per-record
/// analysis: steady state, harmonic fit with trend, noise from the periods), and the records left out
/// with why.
pub fn observe_campaign(
    campaign: &Campaign,
    threads: usize,
) -> (Vec<Observation>, Vec<(usize, String)>) {
    let opts = IdentifyOptions {
        threads: Some(threads),
        ..IdentifyOptions::default()
    };
    observations_of(&analyse_records(campaign, &opts, &|_| {}))
}

/// Observations from record analyses already made, and the records left out with why.
/// Saturated records are kept: the diagnosis models saturation.
pub fn observations_of(fits: &[RecordFit]) -> (Vec<Observation>, Vec<(usize, String)>) {
    let mut obs = Vec::new();
    let mut skipped = Vec::new();
    for f in fits {
        match &f.excluded {
            Some(r) if r != reason::SATURATED => skipped.push((f.index, r.clone())),
            _ => match observe(f) {
                Some(o) => obs.push(o),
                None => skipped.push((f.index, reason::NO_STEADY.to_string())),
            },
        }
    }
    crate::observe::mark_third_band(&mut obs);
    (obs, skipped)
}

/// Checks that the model describes the campaign's channels; returns its predictions.
pub fn check_inputs(
    obs: &[&Observation],
    model: &ModelSpec,
    opts: &DiagnoseOptions,
) -> Result<Vec<Prediction>, DiagnoseError> {
    let camp = |message: String| DiagnoseError::Campaign {
        campaign: opts.campaign_path.clone(),
        message,
    };
    let bad_model = |message: String| DiagnoseError::Model {
        model: opts.model_path.clone(),
        message,
    };
    if obs.is_empty() {
        return Err(camp("no usable record".into()));
    }
    for axis in Axis::BOTH {
        let mine: Vec<&Observation> = obs.iter().copied().filter(|o| o.excited == axis).collect();
        if mine.is_empty() {
            continue;
        }
        let omegas = distinct_omegas(&mine);
        if omegas.len() < 3 {
            return Err(camp(format!(
                "the records exciting {axis} cover {} frequenc{} ({}): the diagnosis needs at \
                 least 3 to fit on some and score on the others",
                omegas.len(),
                if omegas.len() == 1 { "y" } else { "ies" },
                omegas
                    .iter()
                    .map(|w| format!("{w} rad/s"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        let ch = Channel::new(axis, axis);
        let coef = |p: &str| {
            model
                .value(
                    EffectKind::Pendulum,
                    Binding::Global,
                    &format!("{p}{}", ch.suffix()),
                )
                .unwrap_or(0.0)
        };
        if coef("a") == 0.0 && coef("b") == 0.0 {
            return Err(bad_model(format!(
                "pendulum.a{0} and pendulum.b{0} are both zero: the model has no {1} channel, \
                 but the campaign excites {axis}",
                ch.suffix(),
                ch.name()
            )));
        }
    }
    // A factor of ten (in median) on a diagonal channel: another robot, units or swapped axes.
    let preds = predict(model, obs).map_err(|e| bad_model(e.to_string()))?;
    for axis in Axis::BOTH.into_iter().filter(|_| opts.scale_check) {
        let j = axis.index();
        let mut q: Vec<f64> = obs
            .iter()
            .zip(&preds)
            .filter(|(o, _)| o.excited == axis)
            .map(|(o, p)| o.g(j).norm() / p.g[j].norm().max(1e-300))
            .collect();
        if q.is_empty() {
            continue;
        }
        q.sort_by(f64::total_cmp);
        let m = q[q.len() / 2];
        if !(0.1..=10.0).contains(&m) {
            return Err(bad_model(format!(
                "the measured {0} is {m:.3} times the model's (median over records): the model \
                 does not describe this campaign's channels (other robot, units or swapped \
                 axes?)",
                Channel::new(axis, axis).name()
            )));
        }
    }
    Ok(preds)
}

/// Whether `preds` explain the observations: error within [`EXPLAINED_RATIO`] of the noise
/// floor, chi-square within [`EXPLAINED_CHI2_PER_COMPONENT`] per residual component (the first
/// harmonic and trend, and the third harmonic, each on its own: see [`chi2_parts`]), and no
/// cell significantly above its floor.
pub fn explains(obs: &[&Observation], preds: &[Prediction]) -> bool {
    let (e, f) = error_and_floor(obs, preds);
    e <= EXPLAINED_RATIO * f
        && chi2_parts(obs, preds)
            .iter()
            .all(|&(chi2, n)| chi2 <= EXPLAINED_CHI2_PER_COMPONENT * n as f64)
        && !cells(obs, preds).iter().any(|c| c.significant)
}

/// The campaign's error and noise floor under `preds`.
pub fn error_and_floor(obs: &[&Observation], preds: &[Prediction]) -> (f64, f64) {
    let scores: Vec<_> = obs.iter().zip(preds).map(|(o, p)| score(o, p)).collect();
    aggregate(&scores)
}

/// Runs the diagnosis. `progress(what)` reports each structure as it is scored.
pub fn diagnose(
    campaign: &Campaign,
    model: &ModelSpec,
    opts: &DiagnoseOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Diagnosis, DiagnoseError> {
    let (observations, skipped) = observe_campaign(campaign, opts.threads);
    diagnose_observations(observations, skipped, model, opts, progress)
}

/// [`diagnose`] on observations already made (the identification's record analyses).
pub fn diagnose_observations(
    observations: Vec<Observation>,
    skipped: Vec<(usize, String)>,
    model: &ModelSpec,
    opts: &DiagnoseOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Diagnosis, DiagnoseError> {
    let deadline = opts.time_limit.map(|d| std::time::Instant::now() + d);
    zmp_campaign::par::with_threads(opts.threads, || {
        zmp_campaign::par::with_deadline(deadline, || {
            run(observations, skipped, model, opts, progress)
        })
    })
}

/// [`diagnose_observations`] once its thread budget and deadline are set.
fn run(
    observations: Vec<Observation>,
    skipped: Vec<(usize, String)>,
    model: &ModelSpec,
    opts: &DiagnoseOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Diagnosis, DiagnoseError> {
    zmp_models::effects::servo::clear_describing_function_cache();
    let obs: Vec<&Observation> = observations.iter().collect();
    let base_predictions = check_inputs(&obs, model, opts)?;
    let model_err = |message: String| DiagnoseError::Model {
        model: opts.model_path.clone(),
        message,
    };
    let (baseline, floor) = error_and_floor(&obs, &base_predictions);
    progress("baseline");
    let s = search(model, &obs, opts.threads, progress).ok_or_else(|| {
        model_err("the model's own parameters could not be refitted on this campaign".into())
    })?;
    let mut all = BTreeMap::new();
    let best = s.best.clone();
    let final_fit = fit_all(&s, &best, model, &obs, &mut all)
        .ok_or_else(|| model_err(format!("the fit of {best} on every record failed")))?;
    let chain: Vec<(Structure, Fit)> = s
        .chain(&best)
        .into_iter()
        .filter_map(|st| all.get(&st).map(|f| (st, f.clone())))
        .collect();
    let alternatives = alternatives(&s, model, &obs, &mut all);
    let parted = s.parted.iter().map(|(m, p)| Parted::of(m, p, &s)).collect();
    let root = s.node(&Structure::root());
    let refit = all.get(&Structure::root()).cloned();
    let explained_as_is = explains(&obs, &base_predictions);
    let verdict = if s.set.len() > 1 {
        Verdict::Ambiguous(s.set.clone())
    } else if let Some(first) = chain.get(1).and_then(|(st, _)| st.effects().first()) {
        Verdict::Effect(*first)
    } else if explained_as_is {
        Verdict::None
    } else if refit
        .as_ref()
        .and_then(|f| predict(&f.spec, &obs).ok())
        .is_some_and(|p| explains(&obs, &p))
    {
        Verdict::Refit
    } else {
        Verdict::Unexplained
    };
    let final_model = if verdict == Verdict::None {
        model.clone()
    } else {
        final_fit.spec.clone()
    };
    let final_predictions = predict(&final_model, &obs).map_err(|e| model_err(e.to_string()))?;
    let (final_error, _) = error_and_floor(&obs, &final_predictions);
    let explained = explains(&obs, &final_predictions);
    let residual = if explained {
        Vec::new()
    } else {
        describe_residual(&obs, &final_predictions)
    };
    let channels = channel_summary(&obs, &base_predictions);
    let ctx = findings::Context {
        obs: &obs,
        search: &s,
        floor,
        baseline,
        channels: &channels,
    };
    let findings = ctx.findings(&chain, &verdict, explained, final_error, &residual);
    let selected = chain
        .windows(2)
        .filter_map(|w| {
            let added = w[1].0.effects().iter().find(|c| !w[0].0.contains(c))?;
            Some((*added, s.node(&w[1].0).held.error))
        })
        .collect();
    let tried = s
        .nodes
        .values()
        .filter(|n| n.structure.len() == 1)
        .map(|n| Tried::of(n, root, &s))
        .collect();
    Ok(Diagnosis {
        campaign: opts.campaign_path.clone(),
        model: opts.model_path.clone(),
        records: obs.len(),
        skipped,
        noise_floor: floor,
        baseline_error: baseline,
        refit_error: root.held.error,
        verdict,
        explained,
        findings,
        selected,
        final_model,
        chain,
        alternatives,
        parted,
        refit,
        final_error,
        cells: cells(&obs, &base_predictions),
        channels,
        base_predictions,
        final_predictions,
        observations: observations.clone(),
        tried,
        residual,
        z_crit: s.z_crit,
        mismatch: s.mismatch,
        compared: s.compared,
        time_limit_reached: zmp_campaign::par::past_deadline() || s.cut_short,
    })
}

/// The set's structures, each fitted on every record, with what separates it from the best
/// (the best: from the second).
fn alternatives(
    s: &Search,
    model: &ModelSpec,
    obs: &[&Observation],
    all: &mut BTreeMap<Structure, Fit>,
) -> Vec<Alternative> {
    let fits: Vec<(Structure, Fit)> = s
        .set
        .iter()
        .filter_map(|st| Some((st.clone(), fit_all(s, st, model, obs, all)?)))
        .collect();
    (0..fits.len())
        .map(|k| {
            let other = if k == 0 { 1 } else { 0 };
            let words = fits.get(other).and_then(|(o, of)| {
                let (me, mf) = &fits[k];
                distinguish(me, &mf.spec, o, &of.spec, obs)
            });
            Alternative::of(&fits[k].0, &fits[k].1, s, words)
        })
        .collect()
}

/// The evidence context of effect `c` in `fit`: the model without it and its predictions.
pub(crate) fn without(fit: &Fit, c: &Candidate) -> ModelSpec {
    let mut spec = fit.spec.clone();
    profile(c.kind).remove(&mut spec, c);
    spec
}

/// The fitted parameters of effect `c` in `fit` (on its plane for a mode).
pub(crate) fn parameters_of(fit: &Fit, c: &Candidate) -> Vec<(String, f64, f64)> {
    let kinds = profile(c.kind).model_kinds();
    let coupling = c.kind == EffectKind::Pendulum;
    fit.frees
        .iter()
        .zip(&fit.std_err)
        .filter(|(f, _)| {
            if coupling {
                ["a12", "a21", "b12", "b21"].contains(&f.param)
            } else {
                kinds.contains(&f.kind) && c.plane.is_none_or(|p| f.bindings == [Binding::Axis(p)])
            }
        })
        .map(|(f, e)| (f.name(), f.bounds.value, *e))
        .collect()
}

/// The evidence sentence of `c` as fitted in `fit`, with the criterion's threshold `z_crit`.
pub(crate) fn evidence_of(obs: &[&Observation], fit: &Fit, c: &Candidate, z_crit: f64) -> String {
    let base_spec = without(fit, c);
    let base = predict(&base_spec, obs).unwrap_or_default();
    let params = parameters_of(fit, c);
    if base.len() != obs.len() {
        return String::new();
    }
    profile(c.kind).evidence(
        c,
        &Evidence {
            obs,
            base_spec: &base_spec,
            base: &base,
            params: &params,
            z_crit,
        },
    )
}
