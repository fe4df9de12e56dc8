//! The designed experiment in two stages: a pilot, then the rest designed on what it measured.
//!
//! A design is local: its separations assume that the record's noise is the campaign's noise
//! model at the record's frequency and that the model taken as true has its parameters as
//! fitted on the campaign. Neither holds where the design matters most. A set is ambiguous
//! because the campaign does not determine what parts its members (a delay beside a play: the
//! delay's value), and the records that part them lie where the campaign did not go (above its
//! band), where the robot may do what no campaign record showed: on the independent
//! simulator's robot with a play in a compliant transmission the response at twice the
//! campaign's top frequency alternates from period to period, and the diagnosis's
//! period-to-period noise estimate of those records is tens of times the sensor's
//! (`docs/src/design-next.md`).
//!
//! So the experiment is run as Atkinson and Fedorov's sequential design: the design's first
//! [`PILOT`] records (its first choice, recorded twice at a new frequency) are run and appended;
//! every rival is refitted on the campaign with them (the diagnosis's fit from its own values),
//! which measures the noise and the parameters there; and the rest of the budget is designed on
//! that extended campaign. The rest's candidates stay below the pilot's highest candidate
//! frequency: the band may grow once, to twice the campaign's top, not twice per stage.

use super::{design_next_observed, DesignError, DesignOptions, Designed, Rival};
use crate::observe::Observation;
use crate::profiles::DataRange;
use crate::run::observe_campaign;
use crate::search::fit_root;
use zmp_campaign::Campaign;

/// Records of the pilot: the design's first choice, recorded twice at a new frequency (once
/// in each of the criterion's folds).
pub const PILOT: usize = 2;

/// A design run in two stages.
#[derive(Debug, Clone)]
pub struct Staged {
    /// The first stage: the design's first [`PILOT`] records (all of it when it needs no
    /// more).
    pub pilot: Designed,
    /// The second stage, designed on the campaign with the pilot's records and the rivals
    /// refitted there (no records when that campaign parts every pair by the target already);
    /// `None` when the pilot used the budget.
    pub rest: Option<Designed>,
    /// The rivals refitted on the campaign with the pilot's records (empty without a rest).
    pub refitted: Vec<Rival>,
    /// The campaign with every designed record run and appended.
    pub extended: Campaign,
}

impl Staged {
    /// Every designed record, the pilot's first.
    pub fn records(&self) -> Vec<super::DesignedRecord> {
        let rest = self.rest.iter().flat_map(|d| d.records.iter());
        self.pilot.records.iter().chain(rest).copied().collect()
    }

    /// The stage whose prediction stands: the rest when there is one, else the pilot.
    pub fn last(&self) -> &Designed {
        self.rest.as_ref().unwrap_or(&self.pilot)
    }
}

/// Runs a stage's records: `base` with `design`'s records recorded and appended (the
/// robot, a simulator, or a person at the robot), or why not.
pub type RunRecords<'a> = dyn FnMut(&Campaign, &Designed) -> Result<Campaign, String> + 'a;

/// The design of `rivals` on `campaign` (its `observations` made) in two stages (module
/// documentation); `run` records each stage's records.
pub fn design_staged(
    campaign: &Campaign,
    observations: &[Observation],
    rivals: &[Rival],
    opts: &DesignOptions,
    run: &mut RunRecords,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Staged, DesignError> {
    let first = DesignOptions {
        max_records: opts.max_records.min(PILOT),
        ..opts.clone()
    };
    let pilot = design_next_observed(campaign, observations, rivals, &first, progress)?;
    if pilot.records.is_empty() {
        return Ok(Staged {
            pilot,
            rest: None,
            refitted: Vec::new(),
            extended: campaign.clone(),
        });
    }
    progress("running the pilot's records");
    let extended = run(campaign, &pilot).map_err(DesignError::Records)?;
    // Whether the pilot decided is what its records measure, not what it predicted: the rest
    // is designed (and is empty when the extended campaign parts every pair by the target).
    let budget = opts.max_records.saturating_sub(pilot.records.len());
    if budget == 0 {
        return Ok(Staged {
            pilot,
            rest: None,
            refitted: Vec::new(),
            extended,
        });
    }
    let (obs, _) = observe_campaign(&extended, opts.threads);
    let refitted = refit_rivals(rivals, &obs, opts)?;
    let second = DesignOptions {
        max_records: budget,
        omega_cap: Some(pilot.limits.omega_max),
        ..opts.clone()
    };
    progress("designing the rest on the pilot's records");
    let rest = design_next_observed(&extended, &obs, &refitted, &second, progress)?;
    let extended = if rest.records.is_empty() {
        extended
    } else {
        progress("running the rest's records");
        run(&extended, &rest).map_err(DesignError::Records)?
    };
    Ok(Staged {
        pilot,
        rest: Some(rest),
        refitted,
        extended,
    })
}

/// Every rival's structure refitted on `obs` from its own values (the diagnosis's fit of a
/// structure's core and effects, `search::fit_root`).
fn refit_rivals(
    rivals: &[Rival],
    obs: &[Observation],
    opts: &DesignOptions,
) -> Result<Vec<Rival>, DesignError> {
    let refs: Vec<&Observation> = obs.iter().collect();
    let range = DataRange::of(&refs);
    let fits = zmp_campaign::par::with_threads(opts.threads, || {
        zmp_campaign::par::parallel_map(rivals.len(), opts.threads, |k| {
            fit_root(&rivals[k].spec, &refs, &range)
        })
    });
    rivals
        .iter()
        .zip(fits)
        .map(|(r, f)| {
            let f = f.ok_or_else(|| DesignError::Refit(r.label.clone()))?;
            Ok(Rival {
                label: r.label.clone(),
                spec: f.spec,
            })
        })
        .collect()
}
