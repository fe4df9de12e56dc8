//! Held-out scores: the two folds of a campaign's records and a fitted model's scores on
//! each fold when refitted on the other (see the module documentation of `engine.rs`).

use super::{fit_from, heavy_base, is_costly, Fitted, Scored, ITERS_FOLD};
use crate::measure::{aggregate, chi2, predict, score, RecordScore};
use crate::observe::Observation;

/// The two folds: `fold[k]` is true for records in the second one. At each frequency the
/// records, ordered by excited axis, amplitude and operating point, alternate between the
/// folds, the first of them alternating with the frequency.
pub fn folds(obs: &[&Observation]) -> Vec<bool> {
    let omegas = distinct_omegas(obs);
    let mut fold = vec![false; obs.len()];
    for (q, w) in omegas.iter().enumerate() {
        let mut at: Vec<usize> = (0..obs.len())
            .filter(|&k| (obs[k].omega - w).abs() <= 1e-9 * w.abs())
            .collect();
        at.sort_by(|&a, &b| {
            let (x, y) = (obs[a], obs[b]);
            x.excited
                .index()
                .cmp(&y.excited.index())
                .then(x.nominal_amplitude.total_cmp(&y.nominal_amplitude))
                .then(x.operating_point[0].total_cmp(&y.operating_point[0]))
                .then(x.operating_point[1].total_cmp(&y.operating_point[1]))
                .then(a.cmp(&b))
        });
        for (r, &k) in at.iter().enumerate() {
            fold[k] = (r + q) % 2 == 1;
        }
    }
    fold
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
    let nan = RecordScore {
        error2: f64::NAN,
        floor2: f64::NAN,
    };
    let mut scores = vec![nan; obs.len()];
    let mut chi2s = vec![f64::NAN; obs.len()];
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
            let iters = if is_costly(name) || heavy_base(&fitted.spec) {
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
                chi2s[k] = chi2(o, pr);
            }
        }
    }
    let complete =
        scores.iter().all(|s| s.error2.is_finite()) && chi2s.iter().all(|c| c.is_finite());
    let (error, total) = if complete {
        (aggregate(&scores).0, chi2s.iter().sum())
    } else {
        (f64::INFINITY, f64::INFINITY)
    };
    Scored {
        effect: name.to_string(),
        error,
        chi2: total,
        scores,
        chi2s,
        dofs: obs.iter().map(|o| o.components() as f64).collect(),
        fitted,
    }
}
