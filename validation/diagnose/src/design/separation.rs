//! The separation of two rival structures on a set of records (Atkinson and Fedorov's
//! T-criterion): one structure taken as true, its noise-free predictions as the data; the rival
//! refitted to them with every parameter the diagnosis fits, each record weighted by its noise;
//! the chi-square that remains is how far apart the records put them, in noise variances.

use super::limits::{Candidate, RecordTiming};
use super::noise::NoiseModel;
use crate::fit::{all_frees, fit_lm, Fit as Fitted, Free, ITERS_JOINT};
use crate::measure::{chi2, predict, Prediction};
use crate::observe::{mark_third_band, Observation};
use crate::profiles::DataRange;
use num_complex::Complex64;
use zmp_models::ModelSpec;

/// `obs` with every third harmonic predicted (a copy whose band flag is set), so that a
/// record's truth holds it whatever band the records around it make.
pub fn predict_all(
    spec: &ModelSpec,
    obs: &[Observation],
) -> Result<Vec<Prediction>, zmp_models::ModelError> {
    let all: Vec<Observation> = obs
        .iter()
        .map(|o| Observation {
            third_band: true,
            ..o.clone()
        })
        .collect();
    let refs: Vec<&Observation> = all.iter().collect();
    predict(spec, &refs)
}

/// The observation a record would give if `p` were the truth and there were no noise: its
/// phasors are the prediction's, its variances `o`'s.
pub fn as_truth(o: &Observation, p: &Prediction) -> Observation {
    let mut t = o.clone();
    for i in 0..2 {
        t.y1[i] = p.g[i] * o.u1;
        t.y3[i] = o.third(p.g3[i]);
    }
    t.slope = p.slope;
    t
}

/// A candidate record as an observation with its noise and no data yet (the phasors are set
/// by [`as_truth`]): sine-referenced input of phase zero, window of the steady state.
pub fn candidate_observation(
    c: &Candidate,
    timing: &RecordTiming,
    noise: &NoiseModel,
    index: usize,
) -> Observation {
    let window = timing.steady_s(c.omega);
    let mut y1_var = [0.0; 2];
    let mut y3_var = [0.0; 2];
    let mut slope_var = [0.0; 2];
    for i in 0..2 {
        (y1_var[i], y3_var[i], slope_var[i]) = noise.variances(i, c.omega, window);
    }
    let zero = Complex64::new(0.0, 0.0);
    Observation {
        index,
        excited: c.excited,
        omega: c.omega,
        operating_point: c.operating_point,
        nominal_amplitude: c.amplitude,
        t0: timing.transient_s,
        t1: timing.transient_s + window,
        u1: Complex64::new(c.amplitude, 0.0),
        y1: [zero; 2],
        y1_var,
        y3: [zero; 2],
        y3_var,
        third_band: false,
        slope: [0.0; 2],
        slope_var,
        noise_std: [noise.sample_std; 2],
        samples: (window * timing.sample_rate_hz).round() as usize,
    }
}

/// One ordered pair: `truth`'s predictions as the data, `rival` refitted to them.
#[derive(Debug, Clone)]
pub struct Pair {
    /// Index of the model whose predictions stand in for the data.
    pub truth: usize,
    /// Index of the model refitted to them.
    pub rival: usize,
    /// The rival as refitted last.
    pub spec: ModelSpec,
    /// The rival's free parameters at their fitted values.
    pub frees: Vec<Free>,
    /// Chi-square of the refit on the campaign alone, before any record was added.
    pub campaign: f64,
    /// Chi-square of the refit on the campaign and the records added so far.
    pub total: f64,
    /// Of which on the added records.
    pub added: f64,
    /// Whether the rival reproduces the truth on the campaign and on every candidate record
    /// (see [`NESTED_CHI2`]): it nests the truth, and no record separates the pair this way.
    pub nested: bool,
}

/// A chi-square below which a rival reproduces the truth (a thousandth of a noise standard
/// deviation over the campaign, or any one candidate record): a rival that contains the truth's
/// structure (a delay refitted to zero, a play to no width) does so on every design. Such an
/// ordered pair is decided by the significance of the rival's extra parameters, not by a
/// separation.
pub const NESTED_CHI2: f64 = 1e-6;

/// The records a pair is refitted on: the truth's campaign and added records, with the
/// third-harmonic band of the whole set.
pub fn record_set(campaign: &[Observation], added: &[Observation]) -> Vec<Observation> {
    let mut set: Vec<Observation> = campaign.iter().chain(added).cloned().collect();
    mark_third_band(&mut set);
    set
}

/// Refits the pair's rival on `set` (the first `n_campaign` records the campaign's) from its
/// current parameters, and, when `also_from` is given, from those of that model too; keeps
/// the better. `None` when no fit can be evaluated.
pub fn refit(
    pair: &Pair,
    set: &[Observation],
    n_campaign: usize,
    also_from: Option<&ModelSpec>,
) -> Option<Pair> {
    let refs: Vec<&Observation> = set.iter().collect();
    let mut starts = vec![(pair.spec.clone(), pair.frees.clone())];
    if let Some(s) = also_from {
        starts.push((s.clone(), refit_frees(s, &refs)));
    }
    let best = starts
        .iter()
        .filter_map(|(s, f)| converged(s, f, &refs))
        .min_by(|a, b| a.cost.total_cmp(&b.cost))?;
    let preds = predict(&best.spec, &refs).ok()?;
    let added: f64 = refs[n_campaign..]
        .iter()
        .zip(&preds[n_campaign..])
        .map(|(o, p)| chi2(o, p))
        .sum();
    Some(Pair {
        spec: best.spec,
        frees: best.frees,
        total: best.cost,
        added,
        ..pair.clone()
    })
}

/// Rounds of the diagnosis's joint fit at most, each from where the last ended, while the
/// chi-square still falls by more than [`ROUND_GAIN`] of itself: a rival whose extra
/// parameter must travel to its bound (a delay to zero) gets there.
const ROUNDS: usize = 4;
const ROUND_GAIN: f64 = 0.01;

/// Every parameter the diagnosis's joint fit of `spec` moves, bounded for the records `obs`.
pub(crate) fn refit_frees(spec: &ModelSpec, obs: &[&Observation]) -> Vec<Free> {
    all_frees(spec, &DataRange::of(obs))
}

/// The diagnosis's joint fit of `frees` (one optimiser: `fit::fit_lm`).
fn fit_structure(spec: &ModelSpec, frees: &[Free], refs: &[&Observation]) -> Option<Fitted> {
    fit_lm(spec, frees, refs, ITERS_JOINT, 0)
}

/// [`fit_structure`] repeated from its own result while it descends (see [`ROUNDS`]).
fn converged(spec: &ModelSpec, frees: &[Free], refs: &[&Observation]) -> Option<Fitted> {
    let mut best = fit_structure(spec, frees, refs)?;
    for _ in 1..ROUNDS {
        if best.cost < NESTED_CHI2 {
            break;
        }
        match fit_structure(&best.spec, &best.frees, refs) {
            Some(f) if f.cost < (1.0 - ROUND_GAIN) * best.cost => best = f,
            Some(f) if f.cost < best.cost => {
                best = f;
                break;
            }
            _ => break,
        }
    }
    Some(best)
}

/// `spec` with every parameter it shares with `truth` (same effect, binding and name) at the
/// truth's value: a start from which a rival that nests the truth has only its own extra
/// parameters to move (a delay to zero), not a whole fit to travel along with them.
fn at_truth(spec: &ModelSpec, truth: &ModelSpec, obs: &[&Observation]) -> ModelSpec {
    let mut out = spec.clone();
    for f in refit_frees(spec, obs) {
        for b in &f.bindings {
            if let Some(v) = truth.value(f.kind, *b, f.param) {
                if (f.bounds.min..=f.bounds.max).contains(&v) {
                    out.set_value(f.kind, *b, f.param, v);
                }
            }
        }
    }
    out
}

/// A fresh pair: the rival with every parameter the diagnosis fits free, refitted to the
/// truth's campaign from its own values and from the truth's where they share a parameter
/// (same effect, binding and name); the better fit.
pub fn start(
    truth: usize,
    rival: usize,
    spec: &ModelSpec,
    truth_spec: &ModelSpec,
    campaign: &[Observation],
) -> Option<Pair> {
    let refs: Vec<&Observation> = campaign.iter().collect();
    let pair = Pair {
        truth,
        rival,
        spec: spec.clone(),
        frees: refit_frees(spec, &refs),
        campaign: 0.0,
        total: 0.0,
        added: 0.0,
        nested: false,
    };
    let set = record_set(campaign, &[]);
    let from_truth = at_truth(spec, truth_spec, &refs);
    let fitted = refit(&pair, &set, set.len(), Some(&from_truth))?;
    Some(Pair {
        campaign: fitted.total,
        ..fitted
    })
}

/// What each candidate (as `truth`'s observation, `truths`) adds to the pair's chi-square at
/// its current refit: the directional gain, first order in the refit.
pub fn gains(pair: &Pair, truths: &[Observation]) -> Option<Vec<f64>> {
    let refs: Vec<&Observation> = truths.iter().collect();
    let preds = predict(&pair.spec, &refs).ok()?;
    Some(refs.iter().zip(&preds).map(|(o, p)| chi2(o, p)).collect())
}
