//! The diagnosis of a campaign against a model: observations, the baseline error and its noise
//! floor, where the model fails, forward selection of catalogued effects on held-out records,
//! the verdict and the evidence.

use super::cells::{cells, channel_summary, Cell};
use super::engine::{
    control, distinct_omegas, own_parameters, without_effect, Scored, EXPLAINED_CHI2_PER_COMPONENT,
    EXPLAINED_RATIO,
};
use super::evidence::sentence;
use super::measure::{aggregate, chi2_parts, predict, score, Prediction};
use super::observe::{observe, Observation};
use super::select::{gain, search};
use serde::Serialize;
use std::collections::BTreeMap;
use zmp_campaign::Campaign;
use zmp_identify::{analyse_records, reason, IdentifyOptions, RecordFit};
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, Channel, ModelSpec};

mod output;

/// Format name of the JSON report.
pub const DIAGNOSIS_FORMAT: &str = "zmp-diagnosis/1";

/// Held-out error of the model's own structure refitted, as a fraction of the model's, below
/// which an unexplained diagnosis still hands the refit to the loop.
pub const REFIT_ADOPT: f64 = 0.5;

pub use super::select::MAX_EFFECTS;

#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    #[error("{campaign}: {message}")]
    Campaign { campaign: String, message: String },
    #[error("{model}: {message}")]
    Model { model: String, message: String },
}

/// Options of a diagnosis.
#[derive(Debug, Clone)]
pub struct DiagnoseOptions {
    /// Shown in the report as given.
    pub campaign_path: String,
    pub model_path: String,
    pub threads: usize,
    pub max_effects: usize,
    /// Refuse a model off by 10x or more on a diagonal channel (another robot, units, swapped
    /// axes). Off only where the model was just identified from this very campaign (the
    /// loop): a model fitted to the data is the right robot however badly the seed's
    /// structure fits it (a long delay swallowed by the low-pass can flip the sign of `a`).
    pub scale_check: bool,
    /// Wall-clock limit of the diagnosis (and of the loop, `iterate::run_loop`): past it no
    /// fit evaluates its model again, each ends with its best parameters so far, and the
    /// work ends with what it has ([`Diagnosis::time_limit_reached`] says so). `None`: no
    /// limit. A fit whose describing functions come from simulation (a friction beside a play
    /// inside its servo and a mode) can take seconds per evaluation.
    pub time_limit: Option<std::time::Duration>,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            campaign_path: "campaign".into(),
            model_path: "model.toml".into(),
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            max_effects: MAX_EFFECTS,
            scale_check: true,
            time_limit: None,
        }
    }
}

/// One ranked finding.
#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    pub effect: String,
    pub channels: Vec<String>,
    /// Fitted parameters of the effect, dotted names, and their standard errors.
    pub parameters: BTreeMap<String, f64>,
    pub std_errors: BTreeMap<String, f64>,
    pub error_before: f64,
    pub error_after: f64,
    pub held_out: bool,
    pub significant: bool,
    pub evidence: String,
    /// Where the error remains after this finding (significant cells, worst first).
    #[serde(rename = "where")]
    pub remaining: Vec<Cell>,
}

/// The whole diagnosis.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    pub campaign: String,
    pub model: String,
    pub records: usize,
    pub skipped: Vec<(usize, String)>,
    pub noise_floor: f64,
    pub baseline_error: f64,
    /// Held-out error of the model's own structure with every parameter refitted (NaN when
    /// the model explained the data as it was).
    pub refit_error: f64,
    pub verdict: String,
    /// Whether the final model explains the data (error within 1.5x the noise floor, no
    /// failing cell).
    pub explained: bool,
    pub findings: Vec<Finding>,
    /// Effects selected in order and the held-out error after each.
    pub selected: Vec<(String, f64)>,
    /// The model with the selected effects, fitted on all records.
    pub final_model: ModelSpec,
    /// The structures the search went through, in order: the effects each step added and the
    /// model with them fitted on all records (every parameter free).
    pub path: Vec<(Vec<String>, super::engine::Fitted)>,
    /// With the verdict `parameter_refit`: the model's own structure refitted, which explains
    /// the data; with `unexplained` and no effect added: that refit when its held-out error is
    /// below [`REFIT_ADOPT`] of the model's (the loop's next version).
    pub refit: Option<super::engine::Fitted>,
    pub final_error: f64,
    /// Cells of the starting model, worst first.
    pub cells: Vec<Cell>,
    /// `(channel, error, floor)` of the starting model.
    pub channels: Vec<(String, f64, f64)>,
    pub observations: Vec<Observation>,
    pub base_predictions: Vec<Prediction>,
    pub final_predictions: Vec<Prediction>,
    /// Every candidate of the first round with its held-out error (what was tried).
    pub tried: Vec<(String, f64)>,
    /// Whether the time limit ([`DiagnoseOptions::time_limit`]) passed before the search
    /// ended: the findings are those reached in time.
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

/// Observations from record analyses already made (identification's), and the records left
/// out with why. Saturated records are kept: the diagnosis models saturation.
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
    super::observe::mark_third_band(&mut obs);
    (obs, skipped)
}

/// Checks that the model describes the campaign's channels; returns its predictions (which
/// the check needs anyway).
pub fn check_inputs(
    obs: &[&Observation],
    model: &ModelSpec,
    opts: &DiagnoseOptions,
) -> Result<Vec<Prediction>, DiagnoseError> {
    let camp = |message: String| DiagnoseError::Campaign {
        campaign: opts.campaign_path.clone(),
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
        let a = model
            .value(
                EffectKind::Pendulum,
                Binding::Global,
                &format!("a{}", ch.suffix()),
            )
            .unwrap_or(0.0);
        let b = model
            .value(
                EffectKind::Pendulum,
                Binding::Global,
                &format!("b{}", ch.suffix()),
            )
            .unwrap_or(0.0);
        if a == 0.0 && b == 0.0 {
            return Err(DiagnoseError::Model {
                model: opts.model_path.clone(),
                message: format!(
                    "pendulum.a{0} and pendulum.b{0} are both zero: the model has no {1} \
                     channel, but the campaign excites {axis}",
                    ch.suffix(),
                    ch.name()
                ),
            });
        }
    }
    // The model must be of the right order of magnitude on the diagonal channels: a factor
    // of ten (in median) means another robot, other units or swapped channels.
    let preds = predict(model, obs).map_err(|e| DiagnoseError::Model {
        model: opts.model_path.clone(),
        message: e.to_string(),
    })?;
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
            let ch = Channel::new(axis, axis);
            return Err(DiagnoseError::Model {
                model: opts.model_path.clone(),
                message: format!(
                    "the measured {0} is {m:.3} times the model's (median over records): the \
                     model does not describe this campaign's channels (other robot, units or \
                     swapped axes?)",
                    ch.name()
                ),
            });
        }
    }
    Ok(preds)
}

/// Channels an effect changed: those whose error fell by at least half of the excess.
fn channels_changed(
    obs: &[&Observation],
    before: &[Prediction],
    after: &[Prediction],
    effect: &str,
    spec: &ModelSpec,
) -> Vec<String> {
    let b = channel_summary(obs, before);
    let a = channel_summary(obs, after);
    let mut out: Vec<String> = b
        .iter()
        .zip(&a)
        .filter(|(x, y)| {
            let excess = x.1 * x.1 - x.2 * x.2;
            excess > 0.0 && x.1 > EXPLAINED_RATIO * x.2 && x.1 * x.1 - y.1 * y.1 > 0.5 * excess
        })
        .map(|(x, _)| x.0.clone())
        .collect();
    if out.is_empty() {
        // From where the effect sits.
        let kinds = super::candidates::model_kinds(effect);
        for e in spec.effects.iter().filter(|e| kinds.contains(&e.info.kind)) {
            if let Binding::Axis(ax) = e.binding {
                for ch in Channel::ALL {
                    let hit = match e.info.site {
                        zmp_models::Site::Sensor => ch.output == ax,
                        _ => ch.input == ax,
                    };
                    if hit && !out.iter().any(|c| c == ch.name()) {
                        out.push(ch.name().to_string());
                    }
                }
            }
        }
        out.sort();
    }
    out
}

fn significant_cells(c: Vec<Cell>) -> Vec<Cell> {
    c.into_iter().filter(|c| c.significant).take(8).collect()
}

/// Whether `preds` explain the observations: error within [`EXPLAINED_RATIO`] of the noise
/// floor, chi-square within [`EXPLAINED_CHI2_PER_COMPONENT`] per residual component (the first
/// harmonic and trend, and the third harmonic, each on its own: see [`chi2_parts`]), and no
/// cell significantly above its floor.
pub fn explains(obs: &[&Observation], preds: &[Prediction]) -> bool {
    let scores: Vec<_> = obs.iter().zip(preds).map(|(o, p)| score(o, p)).collect();
    let (e, f) = aggregate(&scores);
    e <= EXPLAINED_RATIO * f
        && chi2_parts(obs, preds)
            .iter()
            .all(|&(chi2, n)| chi2 <= EXPLAINED_CHI2_PER_COMPONENT * n as f64)
        && !cells(obs, preds).iter().any(|c| c.significant)
}

/// Runs the diagnosis. `progress(what)` reports candidates as they finish.
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
            diagnose_observations_in_budget(observations, skipped, model, opts, progress)
        })
    })
}

/// [`diagnose_observations`] once its thread budget is set.
fn diagnose_observations_in_budget(
    observations: Vec<Observation>,
    skipped: Vec<(usize, String)>,
    model: &ModelSpec,
    opts: &DiagnoseOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Diagnosis, DiagnoseError> {
    zmp_models::effects::servo::clear_describing_function_cache();
    let obs: Vec<&Observation> = observations.iter().collect();
    let base_predictions = check_inputs(&obs, model, opts)?;
    let model_err = |e: zmp_models::ModelError| DiagnoseError::Model {
        model: opts.model_path.clone(),
        message: e.to_string(),
    };
    let base_scores: Vec<_> = obs
        .iter()
        .zip(&base_predictions)
        .map(|(o, p)| score(o, p))
        .collect();
    let (baseline, floor) = aggregate(&base_scores);
    let base_cells = cells(&obs, &base_predictions);
    let channels = channel_summary(&obs, &base_predictions);
    progress("baseline");
    let explained_as_is = explains(&obs, &base_predictions);

    let mut findings = Vec::new();
    let mut selected: Vec<(String, f64)> = Vec::new();
    let mut tried = Vec::new();
    let mut current = model.clone();
    let mut current_preds = base_predictions.clone();
    let mut final_error = baseline;
    let mut refit_error = f64::NAN;
    let mut verdict = "none".to_string();
    let mut explained = explained_as_is;
    let mut path = Vec::new();
    let mut refit = None;
    if !explained_as_is {
        let root = control(model, &obs);
        progress("parameter_refit");
        let Some(root) = root else {
            return Err(DiagnoseError::Model {
                model: opts.model_path.clone(),
                message: "the model's own parameters could not be refitted on this campaign".into(),
            });
        };
        refit_error = root.error;
        let stop = |s: &Scored| -> bool {
            s.error <= EXPLAINED_RATIO * floor
                && predict(&s.fitted.spec, &obs).is_ok_and(|p| explains(&obs, &p))
        };
        let result = search(&root, &obs, opts.threads, progress, &stop);
        tried = result
            .first_round
            .iter()
            .map(|s| (s.effect.clone(), s.error))
            .collect();
        let mut parent = root.clone();
        for step in &result.steps {
            for (k, name) in step.added.iter().enumerate() {
                // A pair's first effect is scored with its partner (they act together).
                let mut shown = step.scored.clone();
                shown.effect = name.clone();
                let mut f = finding(&obs, &shown, &parent, floor, true);
                if step.added.len() == 2 {
                    f.evidence.push_str(&format!(
                        " (found together with {}: neither alone passes the held-out test)",
                        step.added[1 - k]
                    ));
                } else if stop(&parent) {
                    f.evidence.push_str(&format!(
                        " (added though the model without it explains the data: it removes \
                         {:.0} % of the excess held-out chi-square left there)",
                        100.0 * step.gain.total_fraction
                    ));
                }
                findings.push(f);
                selected.push((name.clone(), step.scored.error));
            }
            parent = step.scored.clone();
            path.push((step.added.clone(), step.scored.fitted.clone()));
        }
        let last = result.steps.last().map(|s| &s.scored).unwrap_or(&root);
        current = last.fitted.spec.clone();
        current_preds = predict(&current, &obs).map_err(model_err)?;
        final_error = aggregate(
            &obs.iter()
                .zip(&current_preds)
                .map(|(o, p)| score(o, p))
                .collect::<Vec<_>>(),
        )
        .0;
        explained = explains(&obs, &current_preds);
        // The runners-up of the first round, for the record.
        let first = result.steps.first().map(|s| s.added[0].clone());
        for s in result
            .first_round
            .iter()
            .filter(|s| Some(&s.effect) != first.as_ref())
            .take(3)
        {
            findings.push(finding(&obs, s, &root, floor, false));
        }
        verdict = if let Some((e, _)) = selected.first() {
            e.clone()
        } else if stop(&root) {
            refit = Some(root.fitted.clone());
            "parameter_refit".to_string()
        } else {
            // The refit does not explain the data but removes most of the error (a limit
            // the identification set far too low, a low-pass that absorbed an effect): the
            // loop takes it as the next version and diagnoses again from it, rather than
            // stopping at a model that is many times worse than its own structure can be.
            if root.error < REFIT_ADOPT * baseline {
                refit = Some(root.fitted.clone());
            }
            "unexplained".to_string()
        };
        if verdict == "parameter_refit" {
            findings.insert(
                0,
                Finding {
                    effect: "parameter_refit".into(),
                    channels: channels.iter().map(|c| c.0.clone()).collect(),
                    parameters: BTreeMap::new(),
                    std_errors: BTreeMap::new(),
                    error_before: baseline,
                    error_after: refit_error,
                    held_out: true,
                    significant: true,
                    evidence: format!(
                        "the model's own structure with its parameters refitted explains the \
                         data ({:.1}x -> {:.1}x the noise floor on held-out records): identify \
                         the campaign again rather than add an effect",
                        baseline / floor,
                        refit_error / floor
                    ),
                    remaining: Vec::new(),
                },
            );
        }
        if !explained && verdict != "parameter_refit" {
            let where_ = significant_cells(cells(&obs, &current_preds));
            let mut text = if selected.is_empty() && refit.is_some() {
                format!(
                    "the model's own structure with its parameters refitted brings the error \
                     from {:.1}x to {:.1}x the noise floor on held-out records (identify the \
                     campaign again, or let the loop take the refit); beyond that no catalogued \
                     effect removes a significant part (best: {})",
                    baseline / floor,
                    refit_error / floor,
                    tried.first().map_or("none fitted".to_string(), |t| format!(
                        "{} at {:.1}x",
                        t.0,
                        t.1 / floor
                    ))
                )
            } else if selected.is_empty() {
                format!(
                    "an error of {:.1}x the noise floor remains that no catalogued effect \
                     removes (best: {})",
                    baseline / floor,
                    tried.first().map_or("none fitted".to_string(), |t| format!(
                        "{} at {:.1}x",
                        t.0,
                        t.1 / floor
                    ))
                )
            } else {
                format!(
                    "with {} added, an error of {:.1}x the noise floor remains that no further \
                     catalogued effect removes",
                    selected
                        .iter()
                        .map(|s| s.0.as_str())
                        .collect::<Vec<_>>()
                        .join(" and "),
                    final_error / floor
                )
            };
            if let Some(c) = where_.first() {
                text.push_str(&format!("; worst: {} its floor", c.line().trim_end()));
            }
            let mut chans: Vec<String> = where_.iter().map(|c| c.channel.clone()).collect();
            chans.sort();
            chans.dedup();
            let f = Finding {
                effect: "unexplained".into(),
                channels: chans,
                parameters: BTreeMap::new(),
                std_errors: BTreeMap::new(),
                error_before: final_error,
                error_after: final_error,
                held_out: false,
                significant: true,
                evidence: text,
                remaining: where_,
            };
            if selected.is_empty() {
                findings.insert(0, f);
            } else {
                let at = selected.len();
                findings.insert(at, f);
            }
        }
    }
    let records = obs.len();
    Ok(Diagnosis {
        campaign: opts.campaign_path.clone(),
        model: opts.model_path.clone(),
        records,
        skipped,
        noise_floor: floor,
        baseline_error: baseline,
        refit_error,
        verdict,
        explained,
        findings,
        selected,
        final_model: current,
        path,
        refit,
        final_error,
        cells: base_cells,
        channels,
        base_predictions,
        final_predictions: current_preds,
        observations,
        tried,
        time_limit_reached: zmp_campaign::par::past_deadline(),
    })
}

fn finding(
    obs: &[&Observation],
    s: &Scored,
    parent: &Scored,
    floor: f64,
    selected: bool,
) -> Finding {
    let params = own_parameters(s);
    let base_spec = without_effect(s);
    let before = &predict(&base_spec, obs).unwrap_or_default();
    let after = predict(&s.fitted.spec, obs).unwrap_or_else(|_| before.to_vec());
    let g = gain(parent, s);
    let mut evidence = sentence(
        &s.effect,
        obs,
        &base_spec,
        before,
        &params,
        parent.error,
        s.error,
        floor,
    );
    evidence.push_str(&format!(
        " (held-out chi-square {:.0} -> {:.0}, {} of {} records changed beyond their noise)",
        parent.chi2,
        s.chi2,
        g.acting.len(),
        obs.len()
    ));
    Finding {
        effect: s.effect.clone(),
        channels: channels_changed(obs, before, &after, &s.effect, &s.fitted.spec),
        parameters: params.iter().map(|(k, v)| (k.clone(), v.0)).collect(),
        std_errors: params.iter().map(|(k, v)| (k.clone(), v.1)).collect(),
        error_before: parent.error,
        error_after: s.error,
        held_out: true,
        significant: selected,
        evidence,
        remaining: significant_cells(cells(obs, &after)),
    }
}
