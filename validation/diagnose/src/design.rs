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
//! when every ordered pair is separated by the target.
//!
//! A record at a frequency neither the campaign nor the design holds yet is recorded twice:
//! the criterion judges each record by the fit of the fold that did not see it, the records
//! of one frequency alternating between the folds, so a frequency met once would be judged by
//! extrapolation alone.
//!
//! **The target** is the separation at which the diagnosis's own criterion decides: with one
//! structure true, Cox's statistic of the comparison is normal with mean
//! `sqrt(T) / (2 sqrt(c))`, so a pair is decided with probability `1 - alpha` when
//! `sqrt(T) >= 2 sqrt(c) (z_crit + z_(1 - alpha))` (`criterion::decisive_separation`), with
//! `z_crit` and the mismatch factor `c` those of the search that found the set (the loop
//! passes them; from the rivals alone, the threshold of a search from each and the best
//! rival's chi-square per component on the campaign). A campaign whose records part the
//! rivals by less than that has not decided them, whatever its separation in noise alone.

mod evaluate;
mod greedy;
pub mod limits;
pub mod noise;
pub mod separation;
mod staged;
mod toml_out;

use crate::criterion::decisive_separation;
use crate::measure::{predict, whitened, Prediction};
use crate::observe::Observation;
use crate::profiles::DataRange;
use crate::run::{check_inputs, observe_campaign, DiagnoseError, DiagnoseOptions};
use crate::search::z_threshold;
use greedy::{greedy, Greedy};
use limits::{centres, Candidate, Limits, RecordTiming};
use noise::NoiseModel;
use separation::{as_truth, candidate_observation, predict_all};
use zmp_campaign::Campaign;
use zmp_models::{Axis, ModelSpec};

/// Most records a design proposes by default.
pub const MAX_RECORDS: usize = 24;

/// The diagnosis's criterion a design aims to satisfy (`criterion`): its threshold and the
/// mismatch factor of the search that found the rivals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    /// The criterion's threshold, a standard normal deviate.
    pub z_crit: f64,
    /// The mismatch factor (chi-square per component of the best structure, at least 1).
    pub mismatch: f64,
}

impl Decision {
    /// The separation at which the criterion decides a pair with probability `1 - alpha`,
    /// noise standard deviations (`criterion::decisive_separation`).
    pub fn separation(&self) -> f64 {
        decisive_separation(self.z_crit, self.mismatch)
    }
}

/// One rival structure: a fitted model and the name it goes by (its file).
#[derive(Debug, Clone)]
pub struct Rival {
    /// The name the rival goes by in the design and its errors (its model file).
    pub label: String,
    /// The rival's fitted model; the design refits its parameters to each other rival.
    pub spec: ModelSpec,
}

/// Options of [`design_next`].
#[derive(Debug, Clone)]
pub struct DesignOptions {
    /// The campaign's name in errors.
    pub campaign_path: String,
    /// Most records the design may propose; it stops earlier once every pair is decided.
    pub max_records: usize,
    /// Separation, in noise standard deviations, at which a pair counts as decided; `None`:
    /// where the criterion decides ([`Decision::separation`]).
    pub target_sigma: Option<f64>,
    /// The criterion of the search that found the rivals; `None`: from the rivals on the
    /// campaign (the threshold of a search from each, the best one's mismatch).
    pub decision: Option<Decision>,
    /// Highest candidate frequency, rad/s; `None`: twice the campaign's highest, below the
    /// slowest rival's servo `omega_n` (never below the campaign's highest).
    pub omega_cap: Option<f64>,
    /// Worker threads for the candidate evaluations.
    pub threads: usize,
    /// Noise seed written into the design (for the simulators).
    pub seed: u64,
}

impl Default for DesignOptions {
    fn default() -> Self {
        DesignOptions {
            campaign_path: "campaign".into(),
            max_records: MAX_RECORDS,
            target_sigma: None,
            decision: None,
            omega_cap: None,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            seed: 1,
        }
    }
}

/// Why a design could not be made: wrong rivals, unusable inputs, no room for a record.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    /// Fewer than two or more than three rival models were given (the count given).
    #[error("design-next separates two or three rival models; got {0} (name each with --model)")]
    ModelCount(usize),
    /// Two rivals share one structure, so no record can separate them.
    #[error(
        "{first} and {second} have the same structure ({structure}): the design refits every \
         parameter of a rival, so no record can separate them"
    )]
    SameStructure {
        /// Label of the first rival.
        first: String,
        /// Label of the second rival, whose structure equals the first's.
        second: String,
        /// The shared structure, as the diagnosis names it.
        structure: String,
    },
    /// A model that does not describe the campaign (another robot, units, swapped axes), or a
    /// campaign the diagnosis cannot use: the diagnosis's own checks.
    #[error(transparent)]
    Input(#[from] DiagnoseError),
    /// The campaign has no noise estimate for an output, and the design weighs records by it.
    #[error(
        "{campaign}: no record has a noise estimate of {output} (its first-harmonic variance is \
         zero or undefined: a campaign simulated without noise, or records too short): the \
         design weighs every record by its noise"
    )]
    NoNoise {
        /// The campaign's name.
        campaign: String,
        /// The output channel without a noise estimate.
        output: String,
    },
    /// Every candidate record of the grid breaks a limit under some rival.
    #[error("{campaign}: no candidate record lies within the limits ({why})")]
    NoCandidates {
        /// The campaign's name.
        campaign: String,
        /// The grid and the limits that excluded every candidate.
        why: String,
    },
    /// A rival could not be refitted to the predictions of the model taken as true.
    #[error("{model}: its refit to {truth}'s predictions failed")]
    Fit {
        /// Label of the rival whose refit failed.
        model: String,
        /// Label of the model taken as true.
        truth: String,
    },
    /// A staged design's records could not be run (`design_staged`): why.
    #[error("the designed records could not be run: {0}")]
    Records(String),
    /// A rival could not be refitted on the campaign with the pilot's records (its label).
    #[error("{0}: its fit on the campaign with the pilot's records failed")]
    Refit(String),
}

/// A designed record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DesignedRecord {
    /// The axis the reference sine drives.
    pub excited: Axis,
    /// Excitation frequency, rad/s.
    pub omega: f64,
    /// Reference amplitude, m.
    pub amplitude: f64,
    /// Operating point `[x, y]` the sine is centred on, m.
    pub operating_point: [f64; 2],
    /// Its length (transient and steady state), s.
    pub duration_s: f64,
}

/// An ordered pair's separation, in noise standard deviations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Separation {
    /// Index (into the rivals) of the model taken as true.
    pub truth: usize,
    /// Index of the rival refitted to the true model's predictions.
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
    /// The rivals' labels, in the order the separations index them.
    pub labels: Vec<String>,
    /// The proposed records, in the order the greedy construction chose them.
    pub records: Vec<DesignedRecord>,
    /// Every ordered pair's separation with the finished design.
    pub separations: Vec<Separation>,
    /// The smallest separation over the ordered pairs (noise standard deviations) on the
    /// campaign alone and after each record, as the greedy construction went (a record at a
    /// new frequency, recorded twice, gives both copies the value after the two).
    pub path: Vec<f64>,
    /// The separation the design aimed for, noise standard deviations.
    pub target_sigma: f64,
    /// The criterion it was derived from (`None` when it was given).
    pub decision: Option<Decision>,
    /// How long each designed record runs, read from the campaign's records.
    pub timing: RecordTiming,
    /// The robot's limits every designed record stays within.
    pub limits: Limits,
    /// White ZMP noise per sample for the simulators, m: the campaign's residual noise less
    /// the quantisation's share.
    pub zmp_noise_std: f64,
    /// Noise seed for the simulators that run the design.
    pub seed: u64,
    /// How many candidate records the grid holds.
    pub grid: usize,
    /// How many of them lie within every limit under every rival.
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
pub use staged::{design_staged, RunRecords, Staged, PILOT};
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
        let decision = match (opts.target_sigma, opts.decision) {
            (Some(_), _) => None,
            (None, Some(d)) => Some(d),
            (None, None) => Some(decision_of(&obs, rivals)?),
        };
        let target = opts
            .target_sigma
            .or(decision.map(|d| d.separation()))
            .unwrap_or_default();
        let timing = RecordTiming::of(campaign, &obs);
        let specs: Vec<&ModelSpec> = rivals.iter().map(|r| &r.spec).collect();
        let limits = Limits::of(campaign, &obs, &specs, opts.omega_cap);
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
        } = greedy(rivals, &campaign_truths, &truths, opts, target, progress)?;
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
            target_sigma: target,
            decision,
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

/// The criterion a diagnosis of the campaign would decide by, from the rivals alone: the
/// highest threshold of a search from any of them, the lowest chi-square per component of
/// their predictions of the campaign (in-sample; at least 1).
fn decision_of(obs: &[&Observation], rivals: &[Rival]) -> Result<Decision, DesignError> {
    let r = DataRange::of(obs);
    let z_crit = rivals
        .iter()
        .map(|x| z_threshold(&x.spec, &r))
        .fold(0.0, f64::max);
    let mut mismatch = f64::INFINITY;
    let mut buf = Vec::new();
    for x in rivals {
        let p = predict(&x.spec, obs).map_err(|e| model_error(x, e))?;
        let (mut chi2, mut n) = (0.0, 0usize);
        for (o, pr) in obs.iter().zip(&p) {
            buf.clear();
            whitened(o, pr, &mut buf);
            chi2 += buf.iter().map(|v| v * v).sum::<f64>();
            n += buf.len();
        }
        mismatch = mismatch.min(chi2 / n.max(1) as f64);
    }
    Ok(Decision {
        z_crit,
        mismatch: mismatch.max(1.0),
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
