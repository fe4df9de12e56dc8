//! Fits every catalogued candidate (with the core parameters), scores it on held-out records
//! and selects effects forward: the best significant candidate, then the best on top of it.
//!
//! Held-out scoring: two folds by frequency parity (records at the 1st, 3rd, ... distinct
//! frequencies against the 2nd, 4th, ...): each fold's model predicts the other fold's records.

use super::candidates::{apply, core_frees, model_kind, Candidate, DataRange, Free, CATALOGUE};
use super::lm::{minimise, Bounded};
use super::measure::{aggregate, predict, residuals, score, RecordScore};
use super::observe::Observation;
use std::collections::BTreeMap;
use zmp_models::ModelSpec;

/// Excess error above the noise floor, as a multiple of it, below which the model counts as
/// explaining the data.
pub const EXPLAINED_RATIO: f64 = 1.5;
/// Fraction of the excess error (above the floor) a candidate must remove to count.
pub const MIN_EXPLAINED_FRACTION: f64 = 0.5;

/// A fitted model and where it came from.
#[derive(Debug, Clone)]
pub struct Fitted {
    pub spec: ModelSpec,
    pub frees: Vec<Free>,
    pub theta: Vec<f64>,
    pub std_err: Vec<f64>,
    pub cost: f64,
}

/// One candidate's result on held-out records.
#[derive(Debug, Clone)]
pub struct Scored {
    pub effect: String,
    /// Held-out error and per-record held-out scores (in observation order).
    pub error: f64,
    pub scores: Vec<RecordScore>,
    /// Fitted on all records.
    pub fitted: Fitted,
}

fn fit_from(
    start: &ModelSpec,
    frees: &[Free],
    obs: &[&Observation],
    iters: usize,
) -> Option<Fitted> {
    let theta0: Vec<Bounded> = frees.iter().map(|f| f.bounds).collect();
    let mut work = start.clone();
    let mut r = |theta: &[f64]| -> Option<Vec<f64>> {
        apply(&mut work, frees, theta);
        let p = predict(&work, obs).ok()?;
        let mut out = Vec::with_capacity(obs.len() * 6);
        for (o, pr) in obs.iter().zip(&p) {
            residuals(o, pr, &mut out);
        }
        out.iter().all(|v| v.is_finite()).then_some(out)
    };
    let (theta, cost, var) = minimise(&theta0, iters, &mut r)?;
    let mut spec = start.clone();
    apply(&mut spec, frees, &theta);
    Some(Fitted {
        spec,
        frees: frees.to_vec(),
        std_err: var.iter().map(|v| v.sqrt()).collect(),
        theta,
        cost,
    })
}

/// Fits a candidate's starting points on `obs`: its own parameters first, then jointly with the
/// core parameters from the best start.
pub fn fit(starts: &[(ModelSpec, Vec<Free>)], obs: &[&Observation]) -> Option<Fitted> {
    let best = starts
        .iter()
        .filter_map(|(s, f)| {
            if f.is_empty() {
                Some(Fitted {
                    spec: s.clone(),
                    frees: vec![],
                    theta: vec![],
                    std_err: vec![],
                    cost: f64::INFINITY,
                })
            } else {
                fit_from(s, f, obs, 25)
            }
        })
        .min_by(|a, b| a.cost.total_cmp(&b.cost))?;
    let mut frees = best.frees.clone();
    for (f, v) in frees.iter_mut().zip(&best.theta) {
        f.bounds.value = *v;
    }
    let own = frees.len();
    frees.extend(core_frees(&best.spec));
    let mut joint = fit_from(&best.spec, &frees, obs, 30)?;
    // Report only the candidate's own parameters first; core after.
    joint.frees.truncate(frees.len());
    let _ = own;
    Some(joint)
}

/// The two frequency-parity folds: `fold[k]` is true for records in the second fold.
pub fn folds(obs: &[&Observation]) -> Vec<bool> {
    let mut omegas: Vec<f64> = obs.iter().map(|o| o.omega).collect();
    omegas.sort_by(f64::total_cmp);
    omegas.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs());
    obs.iter()
        .map(|o| {
            let k = omegas
                .iter()
                .position(|w| (w - o.omega).abs() <= 1e-9 * w.abs())
                .unwrap_or(0);
            k % 2 == 1
        })
        .collect()
}

/// Held-out scores of a candidate, and its fit on all records.
pub fn cross_validate(
    name: &str,
    starts: &[(ModelSpec, Vec<Free>)],
    obs: &[&Observation],
) -> Option<Scored> {
    let fold = folds(obs);
    let mut scores = vec![
        RecordScore {
            error2: f64::NAN,
            floor2: f64::NAN
        };
        obs.len()
    ];
    for side in [false, true] {
        let train: Vec<&Observation> = obs
            .iter()
            .zip(&fold)
            .filter(|(_, f)| **f == side)
            .map(|(o, _)| *o)
            .collect();
        let test_idx: Vec<usize> = (0..obs.len()).filter(|k| fold[*k] != side).collect();
        if train.is_empty() || test_idx.is_empty() {
            continue;
        }
        let fitted = fit(starts, &train)?;
        let test: Vec<&Observation> = test_idx.iter().map(|&k| obs[k]).collect();
        let p = predict(&fitted.spec, &test).ok()?;
        for ((&k, o), pr) in test_idx.iter().zip(&test).zip(&p) {
            scores[k] = score(o, pr);
        }
    }
    let valid: Vec<RecordScore> = scores
        .iter()
        .copied()
        .filter(|s| s.error2.is_finite())
        .collect();
    let (error, _) = aggregate(&valid);
    let fitted = fit(starts, obs)?;
    Some(Scored {
        effect: name.to_string(),
        error,
        scores,
        fitted,
    })
}

/// Scores of `spec` as it is on `obs`.
pub fn evaluate(
    spec: &ModelSpec,
    obs: &[&Observation],
) -> Result<Vec<RecordScore>, zmp_models::ModelError> {
    let p = predict(spec, obs)?;
    Ok(obs.iter().zip(&p).map(|(o, pr)| score(o, pr)).collect())
}

/// Candidates of the catalogue not yet in `spec`, scored on top of it.
pub fn score_candidates(base: &ModelSpec, obs: &[&Observation], exclude: &[String]) -> Vec<Scored> {
    let range = DataRange::of(obs);
    let cands: Vec<&Candidate> = CATALOGUE
        .iter()
        .filter(|c| !exclude.iter().any(|e| e == c.effect))
        .filter(|c| c.effect == "cross_coupling" || !base.has(model_kind(c.effect)))
        .collect();
    let results: Vec<Option<Scored>> = std::thread::scope(|s| {
        let handles: Vec<_> = cands
            .iter()
            .map(|c| {
                let range = &range;
                s.spawn(move || {
                    let starts = (c.prepare)(base, range);
                    if starts.is_empty() {
                        return None;
                    }
                    cross_validate(c.effect, &starts, obs)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().ok().flatten())
            .collect()
    });
    let mut out: Vec<Scored> = results.into_iter().flatten().collect();
    out.sort_by(|a, b| a.error.total_cmp(&b.error));
    out
}

/// The refit-only control: the model's own structure, core parameters refitted.
pub fn control(base: &ModelSpec, obs: &[&Observation]) -> Option<Scored> {
    cross_validate("parameter_refit", &[(base.clone(), vec![])], obs)
}

/// Parameters of a fitted candidate's own effect, by dotted name.
pub fn own_parameters(s: &Scored) -> BTreeMap<String, f64> {
    let kind = model_kind(&s.effect);
    s.fitted
        .frees
        .iter()
        .zip(&s.fitted.theta)
        .filter(|(f, _)| f.kind == kind && (kind != "pendulum" || s.effect == "cross_coupling"))
        .map(|(f, v)| (f.name(), *v))
        .collect()
}

/// Whether `candidate` removes enough of the excess error of `reference` above `floor`.
pub fn significant(reference: f64, candidate: f64, floor: f64) -> bool {
    let excess = reference * reference - floor * floor;
    reference > EXPLAINED_RATIO * floor
        && excess > 0.0
        && (reference * reference - candidate * candidate) > MIN_EXPLAINED_FRACTION * excess
}
