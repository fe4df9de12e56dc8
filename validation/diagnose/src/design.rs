//! The experiment that decides between rival model structures (`cargo xtask design-next`).
//!
//! When two or three structures explain a campaign equally well, the records that separate
//! them are designed by the T-criterion of Atkinson and Fedorov (1975): take structure `i` as
//! true, refit rival `j` (every parameter the diagnosis fits) to `i`'s noise-free predictions
//! on the campaign and the designed records, each record weighted by its noise; what remains,
//!
//! ```text
//! T_ij(design) = min over theta_j of  sum over records r  sum over components c
//!                ( (eta_i,rc - eta_j,rc(theta_j)) / sigma_rc )^2,
//! ```
//!
//! is the chi-square by which the records set `j` apart from `i` (the non-centrality of the
//! likelihood-ratio test between them when `i` is true), `sqrt(T_ij)` in noise standard
//! deviations. The components are the diagnosis's own (first harmonic, trend and, within the
//! band, third harmonic of both outputs: `measure::whitened`), so a play's amplitude
//! dependence and its odd harmonics count as much as a delay's phase.
//!
//! The design is built greedily over a grid of candidate records within the robot's limits
//! ([`limits`]): each step adds the record that maximises the smallest separation over the
//! ordered pairs after it, `min_ij (T_ij + d_ij(x))` with `d_ij(x)` the record's chi-square
//! against the current refit of `j` (the directional gain, first order in the refit), each
//! pair's term capped at the target once it is reached so that the least separated pair
//! decides; then every rival is refitted with the record. It stops at the record budget or
//! when every ordered pair is separated by [`TARGET_SIGMA`] noise standard deviations.

mod evaluate;
pub mod limits;
pub mod noise;
pub mod separation;
mod toml_out;

use crate::measure::Prediction;
use crate::observe::Observation;
use crate::profiles::DataRange;
use crate::run::{check_inputs, observe_campaign, DiagnoseError, DiagnoseOptions};
use limits::{centres, Candidate, Limits, RecordTiming};
use noise::NoiseModel;
use separation::{
    as_truth, candidate_observation, gains, predict_all, record_set, refit, Pair, NESTED_CHI2,
};
use zmp_campaign::Campaign;
use zmp_models::{Axis, ModelSpec};

/// Most records a design proposes by default.
pub const MAX_RECORDS: usize = 24;

/// Separation at which a pair counts as decided, in noise standard deviations: the expected
/// chi-square difference 25 exceeds the 1 % likelihood-ratio threshold for up to four extra
/// parameters (13.3) by more than its own standard deviation (about `2 sqrt(25) = 10`).
pub const TARGET_SIGMA: f64 = 5.0;

/// One rival structure: a fitted model and the name it goes by (its file).
#[derive(Debug, Clone)]
pub struct Rival {
    pub label: String,
    pub spec: ModelSpec,
}

/// Options of [`design_next`].
#[derive(Debug, Clone)]
pub struct DesignOptions {
    /// The campaign's name in errors.
    pub campaign_path: String,
    pub max_records: usize,
    pub target_sigma: f64,
    pub threads: usize,
    /// Noise seed written into the design (for the simulators).
    pub seed: u64,
}

impl Default for DesignOptions {
    fn default() -> Self {
        DesignOptions {
            campaign_path: "campaign".into(),
            max_records: MAX_RECORDS,
            target_sigma: TARGET_SIGMA,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            seed: 1,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    #[error("design-next separates two or three rival models; got {0} (name each with --model)")]
    ModelCount(usize),
    #[error(
        "{first} and {second} have the same structure ({structure}): the design refits every \
         parameter of a rival, so no record can separate them"
    )]
    SameStructure {
        first: String,
        second: String,
        structure: String,
    },
    /// A model that does not describe the campaign (another robot, units, swapped axes), or a
    /// campaign the diagnosis cannot use: the diagnosis's own checks.
    #[error(transparent)]
    Input(#[from] DiagnoseError),
    #[error(
        "{campaign}: no record has a noise estimate of {output} (its first-harmonic variance is \
         zero or undefined: a campaign simulated without noise, or records too short): the \
         design weighs every record by its noise"
    )]
    NoNoise { campaign: String, output: String },
    #[error("{campaign}: no candidate record lies within the limits ({why})")]
    NoCandidates { campaign: String, why: String },
    #[error("{model}: its refit to {truth}'s predictions failed")]
    Fit { model: String, truth: String },
}

/// A designed record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignedRecord {
    pub excited: Axis,
    pub omega: f64,
    pub amplitude: f64,
    pub operating_point: [f64; 2],
    /// Its length (transient and steady state), s.
    pub duration_s: f64,
}

/// An ordered pair's separation, in noise standard deviations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Separation {
    /// Index of the model taken as true, and of the refitted rival.
    pub truth: usize,
    pub rival: usize,
    /// On the campaign alone.
    pub campaign_sigma: f64,
    /// On the campaign with the designed records.
    pub total_sigma: f64,
    /// Of that chi-square, the part on the designed records (as a square root).
    pub added_sigma: f64,
    /// Whether the rival nests the model taken as true (reproduces it on the campaign and on
    /// every candidate record): no record separates the pair in this direction, and the data
    /// decide it by the rival's extra parameters (their significance), not by a separation.
    pub nested: bool,
}

/// The designed experiment.
#[derive(Debug, Clone)]
pub struct Designed {
    pub labels: Vec<String>,
    pub records: Vec<DesignedRecord>,
    pub separations: Vec<Separation>,
    /// The smallest separation over the ordered pairs (noise standard deviations) on the
    /// campaign alone and after each record, as the greedy construction went.
    pub path: Vec<f64>,
    pub target_sigma: f64,
    pub timing: RecordTiming,
    pub limits: Limits,
    /// White ZMP noise per sample for the simulators, m: the campaign's residual noise less
    /// the quantisation's share.
    pub zmp_noise_std: f64,
    pub seed: u64,
    /// Candidate records on the grid, and within every limit under every rival.
    pub grid: usize,
    pub candidates: usize,
}

impl Designed {
    /// Total recording time of the designed records, s.
    pub fn total_time_s(&self) -> f64 {
        self.records.iter().fold(0.0, |t, r| t + r.duration_s)
    }

    /// The smallest separation of the finished design over the ordered pairs that records can
    /// separate (not nested), in noise standard deviations.
    pub fn min_sigma(&self) -> f64 {
        self.separations
            .iter()
            .filter(|s| !s.nested)
            .map(|s| s.total_sigma)
            .reduce(f64::min)
            .unwrap_or(0.0)
    }

    /// Whether every ordered pair reached the target.
    pub fn decided(&self) -> bool {
        self.min_sigma() >= self.target_sigma
    }
}

pub use evaluate::evaluate;
pub use toml_out::to_toml;

/// Designs the records that separate `rivals` (two or three fitted models) on `campaign`.
/// `progress` hears what is being done.
pub fn design_next(
    campaign: &Campaign,
    rivals: &[Rival],
    opts: &DesignOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Designed, DesignError> {
    if !(2..=3).contains(&rivals.len()) {
        return Err(DesignError::ModelCount(rivals.len()));
    }
    let (observations, _) = observe_campaign(campaign, opts.threads);
    design_next_observed(campaign, &observations, rivals, opts, progress)
}

/// [`design_next`] on the campaign's observations already made (the identification's record
/// analyses, as the loop holds them).
pub fn design_next_observed(
    campaign: &Campaign,
    observations: &[Observation],
    rivals: &[Rival],
    opts: &DesignOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Designed, DesignError> {
    if !(2..=3).contains(&rivals.len()) {
        return Err(DesignError::ModelCount(rivals.len()));
    }
    zmp_campaign::par::with_threads(opts.threads, || {
        zmp_models::effects::servo::clear_describing_function_cache();
        let obs: Vec<&Observation> = observations.iter().collect();
        check(&obs, rivals, opts)?;
        let noise = noise_model(&obs, opts)?;
        let timing = RecordTiming::of(campaign, &obs);
        let specs: Vec<&ModelSpec> = rivals.iter().map(|r| &r.spec).collect();
        let limits = Limits::of(campaign, &obs, &specs);
        let centres = centres(campaign, &obs);
        progress("candidates");
        let (admitted, truths) = admitted(&limits, &timing, &noise, &centres, rivals, opts)?;
        let campaign_truths = rivals
            .iter()
            .map(|r| {
                let p = predict_all(&r.spec, observations).map_err(|e| model_error(r, e))?;
                Ok(observations
                    .iter()
                    .zip(&p)
                    .map(|(o, p)| as_truth(o, p))
                    .collect())
            })
            .collect::<Result<Vec<Vec<Observation>>, DesignError>>()?;
        let Greedy {
            pairs,
            chosen,
            path,
        } = greedy(rivals, &campaign_truths, &truths, opts, progress)?;
        let records = chosen
            .iter()
            .map(|&k| {
                let c = admitted[k];
                DesignedRecord {
                    excited: c.excited,
                    omega: c.omega,
                    amplitude: c.amplitude,
                    operating_point: c.operating_point,
                    duration_s: timing.duration_s(c.omega),
                }
            })
            .collect();
        let q = limits.resolution;
        Ok(Designed {
            labels: rivals.iter().map(|r| r.label.clone()).collect(),
            records,
            separations: pairs
                .iter()
                .map(|p| Separation {
                    truth: p.truth,
                    rival: p.rival,
                    campaign_sigma: p.campaign.max(0.0).sqrt(),
                    total_sigma: p.total.max(0.0).sqrt(),
                    added_sigma: p.added.max(0.0).sqrt(),
                    nested: p.nested,
                })
                .collect(),
            path,
            target_sigma: opts.target_sigma,
            timing,
            zmp_noise_std: (noise.sample_std.powi(2) - q * q / 12.0).max(0.0).sqrt(),
            seed: opts.seed,
            grid: limits.grid().len(),
            candidates: admitted.len(),
            limits,
        })
    })
}

/// The campaign's noise model, or the error naming the output that has none.
fn noise_model(obs: &[&Observation], opts: &DesignOptions) -> Result<NoiseModel, DesignError> {
    NoiseModel::of(obs).map_err(|e| DesignError::NoNoise {
        campaign: opts.campaign_path.clone(),
        output: ["zmp_x", "zmp_y"][e.output].into(),
    })
}

fn model_error(r: &Rival, e: zmp_models::ModelError) -> DesignError {
    DesignError::Input(DiagnoseError::Model {
        model: r.label.clone(),
        message: e.to_string(),
    })
}

/// The diagnosis's checks of each model against the campaign, and distinct structures.
fn check(obs: &[&Observation], rivals: &[Rival], opts: &DesignOptions) -> Result<(), DesignError> {
    for r in rivals {
        let dopts = DiagnoseOptions {
            campaign_path: opts.campaign_path.clone(),
            model_path: r.label.clone(),
            threads: opts.threads,
            ..DiagnoseOptions::default()
        };
        check_inputs(obs, &r.spec, &dopts)?;
    }
    let structures: Vec<String> = rivals.iter().map(|r| structure(&r.spec)).collect();
    for a in 0..rivals.len() {
        for b in a + 1..rivals.len() {
            if structures[a] == structures[b] {
                return Err(DesignError::SameStructure {
                    first: rivals[a].label.clone(),
                    second: rivals[b].label.clone(),
                    structure: structures[a].clone(),
                });
            }
        }
    }
    Ok(())
}

/// A structure's parts: the parameters a refit frees, by name, and the laws its effects
/// follow.
fn parts(spec: &ModelSpec) -> Vec<String> {
    // The names alone: the records only bound the parameters.
    let mut names: Vec<String> = crate::fit::all_frees(spec, &DataRange::for_names())
        .iter()
        .map(|f| f.name())
        .collect();
    for e in &spec.effects {
        if let Some(v) = e.value("in_servo") {
            names.push(format!("{}.{}.in_servo={v}", e.info.kind, e.key()));
        }
    }
    names.sort();
    names
}

/// A structure in words.
fn structure(spec: &ModelSpec) -> String {
    parts(spec).join(", ")
}

/// Whether `rival` has every part of `truth`'s structure and more: with its extra effects at
/// the end where they vanish (a delay of zero, a play of no width) it is the truth.
fn contains(rival: &ModelSpec, truth: &ModelSpec) -> bool {
    let (r, t) = (parts(rival), parts(truth));
    r.len() > t.len() && t.iter().all(|p| r.contains(p))
}

/// The candidates within every limit under every rival, and each rival's truth observations
/// of them (`truths[model][candidate]`).
fn admitted(
    limits: &Limits,
    timing: &RecordTiming,
    noise: &NoiseModel,
    centres: &[([f64; 2], [f64; 2])],
    rivals: &[Rival],
    opts: &DesignOptions,
) -> Result<(Vec<Candidate>, Vec<Vec<Observation>>), DesignError> {
    let grid = limits.grid();
    let blank: Vec<Observation> = grid
        .iter()
        .enumerate()
        .map(|(k, c)| candidate_observation(c, timing, noise, usize::MAX - k))
        .collect();
    let preds: Vec<Vec<Prediction>> = rivals
        .iter()
        .map(|r| predict_all(&r.spec, &blank).map_err(|e| model_error(r, e)))
        .collect::<Result<_, _>>()?;
    let keep: Vec<usize> = (0..grid.len())
        .filter(|&k| {
            let c = &grid[k];
            let centre = centres
                .iter()
                .find(|(op, _)| *op == c.operating_point)
                .map_or([0.0; 2], |x| x.1);
            let j = c.excited.index();
            let std = blank[k].y1_var[j].sqrt();
            rivals
                .iter()
                .zip(&preds)
                .all(|(r, p)| limits.admits(&r.spec, c, p[k].g, p[k].g3, centre, std))
        })
        .collect();
    if keep.is_empty() {
        return Err(DesignError::NoCandidates {
            campaign: opts.campaign_path.clone(),
            why: format!(
                "{} candidates on the grid of {:.3}-{:.3} rad/s and {:.2}-{:.2} mm; the ZMP must \
                 stay within the range the campaign reached and the trunk acceleration within \
                 {:.3} / {:.3} m/s2",
                grid.len(),
                limits.omega_min,
                limits.omega_max,
                limits.amplitudes[0] * 1e3,
                limits.amplitudes[limits.amplitudes.len() - 1] * 1e3,
                limits.acceleration_cap[0].0,
                limits.acceleration_cap[1].0
            ),
        });
    }
    let truths = preds
        .iter()
        .map(|p| keep.iter().map(|&k| as_truth(&blank[k], &p[k])).collect())
        .collect();
    Ok((keep.iter().map(|&k| grid[k]).collect(), truths))
}

/// What the greedy construction ends with.
struct Greedy {
    /// Every ordered pair, refitted on the campaign and the chosen records.
    pairs: Vec<Pair>,
    /// The chosen candidates, in order.
    chosen: Vec<usize>,
    /// The smallest separation (noise standard deviations) before and after each record.
    path: Vec<f64>,
}

/// The greedy construction (see the module documentation).
fn greedy(
    rivals: &[Rival],
    campaign: &[Vec<Observation>],
    truths: &[Vec<Observation>],
    opts: &DesignOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Greedy, DesignError> {
    let n = rivals.len();
    let ordered: Vec<(usize, usize)> = (0..n)
        .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
        .collect();
    let threads = zmp_campaign::par::budget();
    let fit_error = |i: usize, j: usize| DesignError::Fit {
        model: rivals[j].label.clone(),
        truth: rivals[i].label.clone(),
    };
    progress("refitting each rival to the others' predictions");
    let mut pairs = zmp_campaign::par::parallel_map(ordered.len(), threads, |k| {
        let (i, j) = ordered[k];
        separation::start(i, j, &rivals[j].spec, &rivals[i].spec, &campaign[i])
    })
    .into_iter()
    .zip(&ordered)
    .map(|(p, &(i, j))| p.ok_or_else(|| fit_error(i, j)))
    .collect::<Result<Vec<Pair>, _>>()?;
    // A rival whose structure contains the truth's and whose refit reproduces the truth's
    // campaign within one noise standard deviation nests it: its extra effects vanish at the
    // truth (the refit's remainder is numerics, or the describing functions' simulation).
    for p in pairs.iter_mut() {
        p.nested = contains(&rivals[p.rival].spec, &rivals[p.truth].spec) && p.total < 1.0;
    }
    let cap = opts.target_sigma * opts.target_sigma;
    let smallest = |pairs: &[Pair]| {
        pairs
            .iter()
            .filter(|p| !p.nested)
            .map(|p| p.total)
            .reduce(f64::min)
            // Every direction nested: the rivals are one another on every record.
            .unwrap_or(0.0)
    };
    let campaign_top = campaign[0].iter().map(|o| o.omega).fold(0.0, f64::max);
    let mut chosen: Vec<usize> = Vec::new();
    let mut path = Vec::new();
    loop {
        let top = chosen
            .iter()
            .map(|&k| truths[0][k].omega)
            .fold(campaign_top, f64::max);
        let gain: Vec<Vec<f64>> = pairs
            .iter()
            .map(|p| {
                if p.nested {
                    return Ok(vec![0.0; truths[p.truth].len()]);
                }
                let mine: Vec<Observation> = truths[p.truth]
                    .iter()
                    .map(|o| Observation {
                        third_band: 3.0 * o.omega <= top.max(o.omega) * (1.0 + 1e-9),
                        ..o.clone()
                    })
                    .collect();
                gains(p, &mine).ok_or_else(|| fit_error(p.truth, p.rival))
            })
            .collect::<Result<_, _>>()?;
        // A rival that reproduces its truth on the campaign, the records so far and every
        // candidate nests it (found once its refit has travelled there).
        for (p, g) in pairs.iter_mut().zip(&gain) {
            p.nested |= p.total < NESTED_CHI2 && g.iter().all(|v| *v < NESTED_CHI2);
        }
        if chosen.is_empty() {
            path.push(smallest(&pairs).max(0.0).sqrt());
        } else {
            let last = path.len() - 1;
            path[last] = smallest(&pairs).max(0.0).sqrt();
            progress(&format!(
                "record {}/{}: smallest separation {:.2} noise standard deviations",
                chosen.len(),
                opts.max_records,
                path[last]
            ));
        }
        if chosen.len() >= opts.max_records || smallest(&pairs) >= cap {
            break;
        }
        let active: Vec<Pair> = pairs.iter().filter(|p| !p.nested).cloned().collect();
        let active_gain: Vec<Vec<f64>> = pairs
            .iter()
            .zip(gain)
            .filter(|(p, _)| !p.nested)
            .map(|(_, g)| g)
            .collect();
        let Some(best) = pick(&active, &active_gain, cap) else {
            progress("no candidate separates the rivals further");
            break;
        };
        chosen.push(best);
        pairs = zmp_campaign::par::parallel_map(pairs.len(), threads, |k| {
            let p = &pairs[k];
            if p.nested {
                return Some(p.clone());
            }
            let added: Vec<Observation> =
                chosen.iter().map(|&c| truths[p.truth][c].clone()).collect();
            let set = record_set(&campaign[p.truth], &added);
            refit(p, &set, campaign[p.truth].len(), None)
        })
        .into_iter()
        .zip(&pairs)
        .map(|(r, p)| r.ok_or_else(|| fit_error(p.truth, p.rival)))
        .collect::<Result<_, _>>()?;
        path.push(smallest(&pairs).max(0.0).sqrt());
    }
    // The finished design's separations, the rival also refitted from its own fitted values
    // (a refit stuck where the greedy path took it would overstate the separation).
    if !chosen.is_empty() {
        pairs = zmp_campaign::par::parallel_map(pairs.len(), threads, |k| {
            let p = &pairs[k];
            if p.nested {
                return Some(p.clone());
            }
            let added: Vec<Observation> =
                chosen.iter().map(|&c| truths[p.truth][c].clone()).collect();
            let set = record_set(&campaign[p.truth], &added);
            refit(
                p,
                &set,
                campaign[p.truth].len(),
                Some(&rivals[p.rival].spec),
            )
        })
        .into_iter()
        .zip(&pairs)
        .map(|(r, p)| r.ok_or_else(|| fit_error(p.truth, p.rival)))
        .collect::<Result<_, _>>()?;
    }
    Ok(Greedy {
        pairs,
        chosen,
        path,
    })
}

/// The candidate that maximises the smallest capped separation after it (ties: the larger
/// capped sum); `None` when no candidate adds anything.
fn pick(pairs: &[Pair], gain: &[Vec<f64>], cap: f64) -> Option<usize> {
    let n = gain.first()?.len();
    let score = |k: usize| {
        let after: Vec<f64> = pairs
            .iter()
            .zip(gain)
            .map(|(p, g)| (p.total + g[k].max(0.0)).min(cap))
            .collect();
        (
            after.iter().copied().fold(f64::INFINITY, f64::min),
            after.iter().sum::<f64>(),
        )
    };
    let now: f64 = pairs.iter().map(|p| p.total.min(cap)).sum();
    let best = (0..n).max_by(|&a, &b| {
        let (sa, sb) = (score(a), score(b));
        sa.0.total_cmp(&sb.0).then(sa.1.total_cmp(&sb.1))
    })?;
    (score(best).1 > now * (1.0 + 1e-9) + 1e-12).then_some(best)
}
