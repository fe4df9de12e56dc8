//! Fits every catalogued candidate (with the core parameters), scores it on held-out records
//! and selects effects forward: the best significant candidate, then the best on top of it.
//!
//! Held-out scoring: two folds by frequency parity (records at the 1st, 3rd, ... distinct
//! frequencies against the 2nd, 4th, ...): each fold's model predicts the other fold's records.

use super::candidates::{
    apply, core_frees, model_kind, Candidate, DataRange, Free, Start, CATALOGUE,
};
use super::lm::{minimise, Bounded};
use super::measure::{aggregate, predict, residuals, score, RecordScore};
use super::observe::Observation;
use std::collections::BTreeMap;
use zmp_models::ModelSpec;

/// Error above the noise floor, as a multiple of it, below which the model counts as
/// explaining the data.
pub const EXPLAINED_RATIO: f64 = 1.5;
/// Fraction of the excess squared error (above the floor) a candidate must remove to count.
pub const MIN_EXPLAINED_FRACTION: f64 = 0.5;

/// Iterations: the own parameters from each start, then jointly with the core, then per fold.
const ITERS_OWN: usize = 8;
const ITERS_JOINT: usize = 20;
const ITERS_FOLD: usize = 8;

/// A fitted model and where it came from.
#[derive(Debug, Clone)]
pub struct Fitted {
    pub spec: ModelSpec,
    /// The candidate's own parameters first, then the core ones.
    pub frees: Vec<Free>,
    pub own: usize,
    pub theta: Vec<f64>,
    pub std_err: Vec<f64>,
    pub cost: f64,
}

/// One candidate's result on held-out records.
#[derive(Debug, Clone)]
pub struct Scored {
    pub effect: String,
    /// Held-out error (RMS over records) and per-record held-out scores (observation order).
    pub error: f64,
    pub scores: Vec<RecordScore>,
    /// Fitted on all records.
    pub fitted: Fitted,
}

fn fit_from(
    start: &ModelSpec,
    frees: &[Free],
    own: usize,
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
    let mut frees = frees.to_vec();
    for (f, v) in frees.iter_mut().zip(&theta) {
        f.bounds.value = *v;
    }
    Some(Fitted {
        spec,
        frees,
        own,
        std_err: var.iter().map(|v| v.sqrt()).collect(),
        theta,
        cost,
    })
}

/// Fits a candidate on `obs` from each of its starts, then the best further. The core
/// parameters are fitted with the candidate's own from every start (the model the diagnosis
/// starts from may have absorbed the effect into them), except for the costly servo effects,
/// whose own parameters are fitted first with the core fixed.
pub fn fit(effect: &str, starts: &[Start], obs: &[&Observation]) -> Option<Fitted> {
    let costly = is_costly(effect);
    // A model identified without the effect has absorbed part of it into the bandwidth (a
    // delay or a sensor filter into a slower, more damped low-pass): the cheap candidates also
    // start from a faster, less damped one, so that the fit does not stay in that valley.
    let mut all: Vec<Start> = starts.to_vec();
    let linear_base = starts.first().is_some_and(|(s, _)| {
        s.effects
            .iter()
            .all(|e| e.info.linear || e.info.kind == effect)
    });
    if !costly && linear_base {
        for (s, f) in starts {
            let mut fast = s.clone();
            for a in zmp_models::Axis::BOTH {
                let b = zmp_models::Binding::Axis(a);
                if let (Some(wn), Some(z)) = (
                    s.value("tracking_lowpass", b, "omega_n"),
                    s.value("tracking_lowpass", b, "zeta"),
                ) {
                    fast.set_value("tracking_lowpass", b, "omega_n", 1.5 * wn);
                    fast.set_value("tracking_lowpass", b, "zeta", (0.7 * z).max(0.5));
                }
            }
            all.push((fast, f.clone()));
        }
    }
    let best = all
        .iter()
        .filter_map(|(s, f)| {
            let mut frees = f.clone();
            let own = frees.len();
            if !costly {
                frees.extend(core_frees(s, true));
            }
            if frees.is_empty() {
                return None;
            }
            fit_from(s, &frees, own, obs, ITERS_OWN)
        })
        .min_by(|a, b| a.cost.total_cmp(&b.cost))?;
    let mut frees = best.frees.clone();
    if costly {
        frees.extend(core_frees(&best.spec, true));
    }
    fit_from(&best.spec, &frees, best.own, obs, ITERS_JOINT)
}

/// Candidates whose describing functions come from simulation.
pub fn is_costly(effect: &str) -> bool {
    matches!(effect, "coulomb_friction" | "acceleration_saturation")
}

/// Fits `frees` (the first `own` of them an effect's own) of `start` on `obs`.
pub fn fit_structure(
    start: &ModelSpec,
    frees: &[Free],
    own: usize,
    obs: &[&Observation],
) -> Option<Fitted> {
    fit_from(start, frees, own, obs, ITERS_JOINT)
}

/// The two frequency-parity folds: `fold[k]` is true for records in the second fold.
pub fn folds(obs: &[&Observation]) -> Vec<bool> {
    let omegas = distinct_omegas(obs);
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

/// The distinct excitation frequencies, ascending.
pub fn distinct_omegas(obs: &[&Observation]) -> Vec<f64> {
    let mut omegas: Vec<f64> = obs.iter().map(|o| o.omega).collect();
    omegas.sort_by(f64::total_cmp);
    omegas.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs());
    omegas
}

/// Held-out scores of a model fitted on all records: each fold is refitted from it (same
/// free parameters) and predicts the other fold.
pub fn cross_validate(name: &str, fitted: Fitted, obs: &[&Observation]) -> Scored {
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
        let refit = if fitted.frees.is_empty() {
            None
        } else {
            let iters = if is_costly(name) {
                ITERS_FOLD / 2
            } else {
                ITERS_FOLD
            };
            fit_from(&fitted.spec, &fitted.frees, fitted.own, &train, iters)
        };
        let spec = refit.as_ref().map_or(&fitted.spec, |f| &f.spec);
        let test: Vec<&Observation> = test_idx.iter().map(|&k| obs[k]).collect();
        if let Ok(p) = predict(spec, &test) {
            for ((&k, o), pr) in test_idx.iter().zip(&test).zip(&p) {
                scores[k] = score(o, pr);
            }
        }
    }
    let valid: Vec<RecordScore> = scores
        .iter()
        .copied()
        .filter(|s| s.error2.is_finite())
        .collect();
    let error = if valid.len() == scores.len() {
        aggregate(&valid).0
    } else {
        f64::INFINITY
    };
    Scored {
        effect: name.to_string(),
        error,
        scores,
        fitted,
    }
}

/// Fits and scores one candidate on top of `base`.
pub fn score_candidate(c: &Candidate, base: &ModelSpec, obs: &[&Observation]) -> Option<Scored> {
    let range = DataRange::of(obs);
    let starts = (c.prepare)(base, &range);
    if starts.is_empty() {
        return None;
    }
    let fitted = fit(c.effect, &starts, obs)?;
    Some(cross_validate(c.effect, fitted, obs))
}

/// Candidates of the catalogue not yet in `base` (and not in `exclude`), scored on top of it,
/// on up to `threads` threads, best first. `done` is called after each candidate.
pub fn score_candidates(
    base: &ModelSpec,
    obs: &[&Observation],
    exclude: &[String],
    threads: usize,
    done: &(dyn Fn(&str) + Sync),
) -> Vec<Scored> {
    let cands: Vec<&Candidate> = CATALOGUE
        .iter()
        .filter(|c| !exclude.iter().any(|e| e == c.effect))
        .filter(|c| c.effect == "cross_coupling" || !base.has(model_kind(c.effect)))
        .collect();
    // The slow (servo) candidates first so the threads finish together.
    let mut order: Vec<usize> = (0..cands.len()).collect();
    order.sort_by_key(|&k| !is_costly(cands[k].effect));
    let results = crate::par::parallel_map(order.len(), threads, |k| {
        let c = cands[order[k]];
        let scored = score_candidate(c, base, obs);
        done(c.effect);
        scored
    });
    let mut out: Vec<Scored> = results.into_iter().flatten().collect();
    out.sort_by(|a, b| a.error.total_cmp(&b.error));
    out
}

/// The refit-only control: the model's own structure, core parameters refitted.
pub fn control(base: &ModelSpec, obs: &[&Observation]) -> Option<Scored> {
    let frees = core_frees(base, true);
    let fitted = fit_from(base, &frees, 0, obs, ITERS_JOINT)?;
    Some(cross_validate("parameter_refit", fitted, obs))
}

/// Scores of `spec` as it is on `obs`.
pub fn evaluate(
    spec: &ModelSpec,
    obs: &[&Observation],
) -> Result<Vec<RecordScore>, zmp_models::ModelError> {
    let p = predict(spec, obs)?;
    Ok(obs.iter().zip(&p).map(|(o, pr)| score(o, pr)).collect())
}

/// Parameters of a fitted candidate's own effect, by dotted name, with standard errors.
pub fn own_parameters(s: &Scored) -> BTreeMap<String, (f64, f64)> {
    own_parameters_of(&s.fitted)
}

/// The same for a fit.
pub fn own_parameters_of(f: &Fitted) -> BTreeMap<String, (f64, f64)> {
    f.frees
        .iter()
        .zip(&f.theta)
        .zip(&f.std_err)
        .take(f.own)
        .map(|((fr, v), e)| (fr.name(), (*v, *e)))
        .collect()
}

/// The fitted model without the candidate's effect (its other parameters as fitted): what the
/// effect's signature is measured against.
pub fn without_effect(s: &Scored) -> ModelSpec {
    let mut spec = s.fitted.spec.clone();
    if s.effect == "cross_coupling" {
        let zeros = vec![0.0; s.fitted.own];
        apply(&mut spec, &s.fitted.frees[..s.fitted.own], &zeros);
    } else {
        spec.remove(model_kind(&s.effect));
    }
    spec
}

/// Whether `candidate` removes enough of the excess error of `reference` above `floor`.
pub fn significant(reference: f64, candidate: f64, floor: f64) -> bool {
    let excess = reference * reference - floor * floor;
    reference > EXPLAINED_RATIO * floor
        && excess > 0.0
        && (reference * reference - candidate * candidate) > MIN_EXPLAINED_FRACTION * excess
}
