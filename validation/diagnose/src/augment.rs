//! Adding a catalogue effect to a model (fitted with every parameter on every record), writing
//! a model the diagnosis fitted as a version, and refitting the structure a model file names.

use crate::fit::{all_frees, fit_lm, fit_starts, polish, Fit, DESCENT_FACTOR, ITERS_JOINT};
use crate::measure::predict;
use crate::observe::Observation;
use crate::profiles::{candidates, catalogue_names, kind_named, profile, DataRange};
use crate::run::{check_inputs, error_and_floor, observe_campaign, DiagnoseError, DiagnoseOptions};
use crate::search::fit_root;
use crate::structure::Structure;
use std::collections::BTreeMap;
use zmp_campaign::ledger::utc_now;
use zmp_campaign::Campaign;
use zmp_models::ModelSpec;

/// A model with an effect added or its structure refitted, and its error before and after.
#[derive(Debug, Clone)]
pub struct Augmented {
    /// The new model, with fitted values, standard errors and provenance (ready to write).
    pub spec: ModelSpec,
    /// What changed: `+time_delay`, `refit`.
    pub change: String,
    /// Campaign error (the diagnosis measure) of the model this one follows.
    pub error_before: f64,
    /// Campaign error of the new model on the same records.
    pub error_after: f64,
    /// Noise floor of the same records: the error a perfect model would still show.
    pub noise_floor: f64,
    /// Fitted parameters of every effect beyond the core: value, s.e.
    pub parameters: BTreeMap<String, (f64, f64)>,
    /// How many records the fit and both errors were computed on.
    pub records: usize,
}

fn model_error(opts: &DiagnoseOptions, message: String) -> DiagnoseError {
    DiagnoseError::Model {
        model: opts.model_path.clone(),
        message,
    }
}

fn error_of(
    spec: &ModelSpec,
    obs: &[&Observation],
    opts: &DiagnoseOptions,
) -> Result<(f64, f64), DiagnoseError> {
    let p = predict(spec, obs).map_err(|e| model_error(opts, e.to_string()))?;
    Ok(error_and_floor(obs, &p))
}

/// Writes each fitted parameter's standard error into the model's `stderr` tables.
fn record_stderr(spec: &mut ModelSpec, fit: &Fit) {
    for (f, se) in fit.frees.iter().zip(&fit.std_err) {
        if !se.is_finite() {
            continue;
        }
        let table = spec
            .stderr
            .entry(f.kind.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        let Some(t) = table.as_table_mut() else {
            continue;
        };
        match f.bindings.first().and_then(|b| b.key()) {
            Some(k) if f.bindings.len() == 1 => {
                let sub = t
                    .entry(k.to_string())
                    .or_insert_with(|| toml::Value::Table(toml::Table::new()));
                if let Some(s) = sub.as_table_mut() {
                    s.insert(f.param.to_string(), toml::Value::Float(*se));
                }
            }
            _ => {
                t.insert(f.param.to_string(), toml::Value::Float(*se));
            }
        }
    }
}

fn stamp(spec: &mut ModelSpec, change: &str, campaign: &str, records: usize) {
    let p = &mut spec.provenance;
    let tool = format!("zmp-toolkit {}", env!("CARGO_PKG_VERSION"));
    p.insert("tool".into(), toml::Value::String(tool));
    p.insert("date".into(), toml::Value::String(utc_now()));
    p.insert("campaign".into(), toml::Value::String(campaign.to_string()));
    p.insert("records".into(), toml::Value::Integer(records as i64));
    p.insert("change".into(), toml::Value::String(change.to_string()));
}

/// Adds `effect` (a catalogue name) to `model` and fits it, with every parameter, on every
/// record of `campaign`.
pub fn augment(
    campaign: &Campaign,
    model: &ModelSpec,
    effect: &str,
    opts: &DiagnoseOptions,
) -> Result<Augmented, DiagnoseError> {
    kind_of(effect, opts)?;
    let (obs, _) = observe_campaign(campaign, opts.threads);
    let refs: Vec<&Observation> = obs.iter().collect();
    check_inputs(&refs, model, opts)?;
    augment_observations(&refs, model, effect, opts)
}

fn kind_of(effect: &str, opts: &DiagnoseOptions) -> Result<zmp_models::EffectKind, DiagnoseError> {
    kind_named(effect).ok_or_else(|| {
        let known = catalogue_names().join(", ");
        model_error(
            opts,
            format!("unknown effect {effect:?}: the catalogue has {known}"),
        )
    })
}

/// [`augment`] on observations already made (checked against the model by the caller): the
/// effect under each of its laws (on each excited plane for a mode) added to the model's own
/// structure refitted, by the diagnosis's multi-start policy; the best fit on these records.
pub fn augment_observations(
    refs: &[&Observation],
    model: &ModelSpec,
    effect: &str,
    opts: &DiagnoseOptions,
) -> Result<Augmented, DiagnoseError> {
    let kind = kind_of(effect, opts)?;
    zmp_campaign::par::with_threads(opts.threads, || {
        let r = DataRange::of(refs);
        let (before, floor) = error_of(model, refs, opts)?;
        let mine: Vec<_> = candidates(model, &r)
            .into_iter()
            .filter(|c| c.kind == kind)
            .collect();
        if mine.is_empty() {
            return Err(model_error(
                opts,
                format!(
                    "{effect} has nothing to add to this model on this campaign (it has it \
                     already?); to refit it run `cargo xtask identify CAMPAIGN --model {}`",
                    opts.model_path
                ),
            ));
        }
        // The effect is added to the model's own structure refitted first (what the diagnosis
        // compares it with): a model identified without the effect has absorbed part of it.
        let root = fit_root(model, refs, &r)
            .ok_or_else(|| model_error(opts, "the refit of the model failed".into()))?;
        let fit = mine
            .iter()
            .filter_map(|c| {
                let starts = profile(kind).starts(&root.spec, c, &r);
                fit_starts(&starts, refs, &r)
            })
            .min_by(|a, b| a.cost.total_cmp(&b.cost))
            .ok_or_else(|| model_error(opts, format!("the fit of {effect} failed")))?;
        finish(refs, fit, &format!("+{effect}"), before, floor, opts)
    })
}

/// A model the diagnosis fitted as a written version (change `+EFFECT`, `refit`, ...), fitted
/// further to convergence on every record, with standard errors and provenance. `model` is the
/// version it follows (for the error before).
pub fn version_from_diagnosis(
    refs: &[&Observation],
    model: &ModelSpec,
    fit: &Fit,
    change: &str,
    opts: &DiagnoseOptions,
) -> Result<Augmented, DiagnoseError> {
    zmp_campaign::par::with_threads(opts.threads, || {
        let (before, floor) = error_of(model, refs, opts)?;
        finish(refs, fit.clone(), change, before, floor, opts)
    })
}

fn finish(
    refs: &[&Observation],
    fit: Fit,
    change: &str,
    before: f64,
    floor: f64,
    opts: &DiagnoseOptions,
) -> Result<Augmented, DiagnoseError> {
    let r = DataRange::of(refs);
    // The model written is fitted on for as long as it descends.
    let fit = polish(fit, refs, &r);
    let (after, _) = error_of(&fit.spec, refs, opts)?;
    let mut spec = fit.spec.clone();
    record_stderr(&mut spec, &fit);
    stamp(&mut spec, change, &opts.campaign_path, refs.len());
    Ok(Augmented {
        parameters: effect_parameters(&fit),
        spec,
        change: change.to_string(),
        error_before: before,
        error_after: after,
        noise_floor: floor,
        records: refs.len(),
    })
}

/// The fitted parameters of every effect beyond the core (pendulum and tracking low-pass).
fn effect_parameters(fit: &Fit) -> BTreeMap<String, (f64, f64)> {
    let core = [
        zmp_models::EffectKind::Pendulum,
        zmp_models::EffectKind::TrackingLowpass,
    ];
    fit.frees
        .iter()
        .zip(&fit.std_err)
        .filter(|(f, _)| !core.contains(&f.kind))
        .map(|(f, e)| (f.name(), (f.bounds.value, *e)))
        .collect()
}

/// Refits every parameter of the structure `model` names (its effects and the core) on
/// `campaign`. `None` when the model has no effect beyond the core.
pub fn refit_structure(
    campaign: &Campaign,
    model: &ModelSpec,
    opts: &DiagnoseOptions,
) -> Result<Option<Augmented>, DiagnoseError> {
    zmp_campaign::par::with_threads(opts.threads, || {
        let (obs, _) = observe_campaign(campaign, opts.threads);
        let refs: Vec<&Observation> = obs.iter().collect();
        check_inputs(&refs, model, opts)?;
        let r = DataRange::of(&refs);
        if crate::profiles::effect_frees(model, &r).is_empty() {
            return Ok(None);
        }
        let (before, floor) = error_of(model, &refs, opts)?;
        let frees = all_frees(model, &r);
        let fit = fit_lm(
            model,
            &frees,
            &refs,
            ITERS_JOINT,
            DESCENT_FACTOR * ITERS_JOINT,
        )
        .ok_or_else(|| model_error(opts, "the refit of the model's structure failed".into()))?;
        finish(&refs, fit, "refit", before, floor, opts).map(Some)
    })
}

/// The structure a diagnosis names, for a version's change label: `+time_delay+backlash`.
pub fn change_label(s: &Structure) -> String {
    s.effects()
        .iter()
        .map(|c| format!("+{}", c.name()))
        .collect()
}
