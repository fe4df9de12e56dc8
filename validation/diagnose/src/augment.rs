//! Adding a catalogued effect to a model (fitted with the core parameters on every record),
//! and refitting the structure a model file names.

use super::candidates::{core_frees, DataRange, CATALOGUE};
use super::engine::{evaluate, fit_structure, own_parameters_of, structure_frees, Fitted};
use super::measure::aggregate;
use super::observe::Observation;
use super::run::{check_inputs, observe_campaign, DiagnoseError, DiagnoseOptions};
use std::collections::BTreeMap;
use zmp_campaign::ledger::utc_now;
use zmp_campaign::Campaign;
use zmp_models::ModelSpec;

/// A model with an effect added or its structure refitted, and its error before and after.
#[derive(Debug, Clone)]
pub struct Augmented {
    pub spec: ModelSpec,
    /// What changed: `+time_delay`, `refit`.
    pub change: String,
    pub error_before: f64,
    pub error_after: f64,
    pub noise_floor: f64,
    /// Fitted parameters of the added effect (or of every non-core effect): value, s.e.
    pub parameters: BTreeMap<String, (f64, f64)>,
    pub records: usize,
}

fn prepare(
    campaign: &Campaign,
    model: &ModelSpec,
    opts: &DiagnoseOptions,
) -> Result<Vec<Observation>, DiagnoseError> {
    let (obs, _) = observe_campaign(campaign, opts.threads);
    let refs: Vec<&Observation> = obs.iter().collect();
    check_inputs(&refs, model, opts)?;
    Ok(obs)
}

fn error_of(
    spec: &ModelSpec,
    obs: &[&Observation],
    opts: &DiagnoseOptions,
) -> Result<(f64, f64), DiagnoseError> {
    let s = evaluate(spec, obs).map_err(|e| DiagnoseError::Model {
        model: opts.model_path.clone(),
        message: e.to_string(),
    })?;
    Ok(aggregate(&s))
}

fn record_stderr(spec: &mut ModelSpec, fitted: &Fitted) {
    for (f, se) in fitted.frees.iter().zip(&fitted.std_err) {
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
    spec.provenance.insert(
        "tool".into(),
        toml::Value::String(format!("zmp-toolkit {}", env!("CARGO_PKG_VERSION"))),
    );
    spec.provenance
        .insert("date".into(), toml::Value::String(utc_now()));
    spec.provenance
        .insert("campaign".into(), toml::Value::String(campaign.to_string()));
    spec.provenance
        .insert("records".into(), toml::Value::Integer(records as i64));
    spec.provenance
        .insert("change".into(), toml::Value::String(change.to_string()));
}

/// Adds `effect` (a catalogue name) to `model` and fits it, with the core parameters, on every
/// record of `campaign`.
pub fn augment(
    campaign: &Campaign,
    model: &ModelSpec,
    effect: &str,
    opts: &DiagnoseOptions,
) -> Result<Augmented, DiagnoseError> {
    check_effect(effect, model, opts)?;
    let obs = prepare(campaign, model, opts)?;
    let refs: Vec<&Observation> = obs.iter().collect();
    augment_observations(&refs, model, effect, opts)
}

/// Whether `effect` is a catalogue name that can be added to `model`.
fn check_effect(
    effect: &str,
    model: &ModelSpec,
    opts: &DiagnoseOptions,
) -> Result<(), DiagnoseError> {
    let Some(_) = CATALOGUE.iter().find(|c| c.effect == effect) else {
        return Err(DiagnoseError::Model {
            model: opts.model_path.clone(),
            message: format!(
                "unknown effect {effect:?}: the catalogue has {}",
                CATALOGUE
                    .iter()
                    .map(|c| c.effect)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        });
    };
    if !super::engine::addable(effect, model) {
        return Err(DiagnoseError::Model {
            model: opts.model_path.clone(),
            message: format!(
                "the model already has {effect}; to refit it run `cargo xtask identify CAMPAIGN \
                 --model {}`",
                opts.model_path
            ),
        });
    }
    Ok(())
}

/// [`augment`] on observations already made (checked against the model by the caller).
pub fn augment_observations(
    refs: &[&Observation],
    model: &ModelSpec,
    effect: &str,
    opts: &DiagnoseOptions,
) -> Result<Augmented, DiagnoseError> {
    zmp_campaign::par::with_threads(opts.threads, || {
        augment_observations_in_budget(refs, model, effect, opts)
    })
}

/// [`augment_observations`] once its thread budget is set.
fn augment_observations_in_budget(
    refs: &[&Observation],
    model: &ModelSpec,
    effect: &str,
    opts: &DiagnoseOptions,
) -> Result<Augmented, DiagnoseError> {
    check_effect(effect, model, opts)?;
    let cand = CATALOGUE
        .iter()
        .find(|c| c.effect == effect)
        .expect("checked");
    let refs = refs.to_vec();
    let (before, floor) = error_of(model, &refs, opts)?;
    // The effect is added to the model's own structure refitted first (what the diagnosis
    // compares it with): a model identified without the effect has absorbed part of it.
    let base = super::engine::refit_all(model, &refs)
        .map(|f| f.spec)
        .unwrap_or_else(|| model.clone());
    let starts = (cand.prepare)(&base, &DataRange::of(&refs));
    if starts.is_empty() {
        return Err(DiagnoseError::Model {
            model: opts.model_path.clone(),
            message: format!("{effect} has nothing to add to this model on this campaign"),
        });
    }
    let fitted =
        super::engine::fit(effect, &starts, &refs).ok_or_else(|| DiagnoseError::Model {
            model: opts.model_path.clone(),
            message: format!("the fit of {effect} failed"),
        })?;
    finish(&refs, fitted, &format!("+{effect}"), before, floor, opts)
}

/// A model the diagnosis fitted as a written version: with effects added (one step of its
/// path, `change` `+EFFECT`) or its own structure refitted (`refit`), fitted further to
/// convergence on every record, with standard errors and provenance. `model` is the version
/// it follows (for the error before).
pub fn version_from_diagnosis(
    refs: &[&Observation],
    model: &ModelSpec,
    fitted: &Fitted,
    change: &str,
    opts: &DiagnoseOptions,
) -> Result<Augmented, DiagnoseError> {
    zmp_campaign::par::with_threads(opts.threads, || {
        version_from_diagnosis_in_budget(refs, model, fitted, change, opts)
    })
}

/// [`version_from_diagnosis`] once its thread budget is set.
fn version_from_diagnosis_in_budget(
    refs: &[&Observation],
    model: &ModelSpec,
    fitted: &Fitted,
    change: &str,
    opts: &DiagnoseOptions,
) -> Result<Augmented, DiagnoseError> {
    let (before, floor) = error_of(model, refs, opts)?;
    finish(refs, fitted.clone(), change, before, floor, opts)
}

fn finish(
    refs: &[&Observation],
    fitted: Fitted,
    change: &str,
    before: f64,
    floor: f64,
    opts: &DiagnoseOptions,
) -> Result<Augmented, DiagnoseError> {
    // The model written is fitted to convergence, not to the diagnosis's screening budget.
    let fitted = fit_structure(&fitted.spec, &fitted.frees, fitted.own, refs)
        .filter(|f| f.cost <= fitted.cost)
        .unwrap_or(fitted);
    let (after, _) = error_of(&fitted.spec, refs, opts)?;
    let mut spec = fitted.spec.clone();
    record_stderr(&mut spec, &fitted);
    let change = change.to_string();
    stamp(&mut spec, &change, &opts.campaign_path, refs.len());
    Ok(Augmented {
        parameters: own_parameters_of(&fitted),
        spec,
        change,
        error_before: before,
        error_after: after,
        noise_floor: floor,
        records: refs.len(),
    })
}

/// Refits every parameter of the structure `model` names (its non-core effects and the core)
/// on `campaign`. Returns `None` in `Augmented::change` terms when the model has no effect
/// beyond the core.
pub fn refit_structure(
    campaign: &Campaign,
    model: &ModelSpec,
    opts: &DiagnoseOptions,
) -> Result<Option<Augmented>, DiagnoseError> {
    zmp_campaign::par::with_threads(opts.threads, || {
        refit_structure_in_budget(campaign, model, opts)
    })
}

/// [`refit_structure`] once its thread budget is set.
fn refit_structure_in_budget(
    campaign: &Campaign,
    model: &ModelSpec,
    opts: &DiagnoseOptions,
) -> Result<Option<Augmented>, DiagnoseError> {
    let own = structure_frees(model);
    if own.is_empty() {
        return Ok(None);
    }
    let obs = prepare(campaign, model, opts)?;
    let refs: Vec<&Observation> = obs.iter().collect();
    let (before, floor) = error_of(model, &refs, opts)?;
    let n_own = own.len();
    let mut frees = own;
    frees.extend(core_frees(model, true));
    let fitted =
        fit_structure(model, &frees, n_own, &refs).ok_or_else(|| DiagnoseError::Model {
            model: opts.model_path.clone(),
            message: "the refit of the model's structure failed".into(),
        })?;
    let (after, _) = error_of(&fitted.spec, &refs, opts)?;
    let mut spec = fitted.spec.clone();
    record_stderr(&mut spec, &fitted);
    stamp(&mut spec, "refit", &opts.campaign_path, refs.len());
    Ok(Some(Augmented {
        parameters: own_parameters_of(&fitted),
        spec,
        change: "refit".into(),
        error_before: before,
        error_after: after,
        noise_floor: floor,
        records: refs.len(),
    }))
}
