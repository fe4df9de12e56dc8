//! The out-of-sample suite as a sharded job (`cargo xtask suite`, issue 57): one unit per draw,
//! run by [`crate::indep::run_case`] and scored by [`crate::indep::scores`] and
//! [`crate::indep::markdown`], whatever those compute; this layer only names the draws, says
//! what each is expected to cost, and turns the units' outcomes back into the table, the report
//! and the JSON.

use crate::indep::{
    after_design_words, markdown, run_case, scores, suite, Case, Class, Composition, Outcome,
    DRAW_TIME_LIMIT,
};
use anyhow::{bail, Context, Result};
use serde_json::{json, Value};
use std::fmt;
use std::str::FromStr;
use zmp_shard::{Collected, Job, JobKind, Merged, UnitSpec};

/// Which draws a suite job runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Range {
    /// The development seeds (where the diagnosis is tuned), 60 draws from seed 1.
    Development,
    /// A held-out range: 60 draws from a first seed never run before; run once.
    HeldOut,
    /// The CI subset: [`CI_DRAWS`] draws of the development range derived from its
    /// composition ([`ci_subset`]).
    Ci,
    /// A few quick development draws ([`SMOKE_SEEDS`]): what the tests of the shard
    /// machinery run (several times each), not a measure of the diagnosis.
    Smoke,
}

impl FromStr for Range {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Range> {
        match s {
            "development" => Ok(Range::Development),
            "held-out" => Ok(Range::HeldOut),
            "ci" => Ok(Range::Ci),
            "smoke" => Ok(Range::Smoke),
            _ => bail!("--range {s:?}: expected development, held-out, ci or smoke"),
        }
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Range::Development => "development",
            Range::HeldOut => "held-out",
            Range::Ci => "ci",
            Range::Smoke => "smoke",
        })
    }
}

/// The development range's first seed.
pub const DEVELOPMENT_FIRST_SEED: u64 = 1;

/// Draws of one range from `first_seed`: the 300-draw composition of the ranges of
/// `tests/blind_independent.rs` ([`Composition::RANGE`]).
pub fn standard_range(first_seed: u64) -> Vec<Case> {
    suite(first_seed, &Composition::RANGE)
}

/// How many draws the CI subset holds (issue 55: a fixed 12-draw subset of the development
/// range, one of each kind and two ambiguous pairs with their designed experiment).
pub const CI_DRAWS: usize = 12;

/// The kind a draw stands for in the CI subset: the effect of a single, the scenario of a
/// pair built to be ambiguous (each of them is a kind of its own), else its class.
fn ci_kind(c: &Case) -> String {
    match &c.class {
        Class::Single(e) => format!("single:{e}"),
        Class::AmbiguousPair => c.scenario.clone(),
        Class::Pair => "pair".into(),
        Class::Triple => "triple".into(),
        Class::Clean => "clean".into(),
        Class::Outside(_) => "outside".into(),
    }
}

/// The CI subset of the range of `c` from `first_seed`, derived from the composition (never
/// picked by outcome, so it follows the ranges when they change): the first draw of each kind
/// that is not a single (a pair, each pair built to be ambiguous, a triple, a clean robot, an
/// effect outside the catalogue), then the first draw of each single effect in suite order
/// until [`CI_DRAWS`]; in seed order.
pub fn ci_subset(first_seed: u64, c: &Composition) -> Vec<Case> {
    let cases = suite(first_seed, c);
    let mut seen = std::collections::BTreeSet::new();
    let firsts: Vec<&Case> = cases.iter().filter(|c| seen.insert(ci_kind(c))).collect();
    let (singles, others): (Vec<&Case>, Vec<&Case>) = firsts
        .into_iter()
        .partition(|c| matches!(c.class, Class::Single(_)));
    let room = CI_DRAWS.saturating_sub(others.len());
    let mut out: Vec<Case> = others
        .into_iter()
        .chain(singles.into_iter().take(room))
        .cloned()
        .collect();
    out.sort_by_key(|c| c.seed);
    out
}

/// The draws of the smoke range: development draws that finish in seconds on one thread (a
/// delay the diagnosis must name, saturation and pendulum coupling the seed's structure
/// carries, two clean robots), chosen for their speed when the shard tests were written
/// (`xtask/tests/scale.rs` runs them several times and kills a shard between the two clean
/// robots). They test the shard machinery, not the diagnosis: the CI subset
/// ([`ci_subset`]) does that.
pub const SMOKE_SEEDS: [u64; 5] = [1, 4, 9, 209, 210];

/// The seeds of the CI subset of the development range ([`ci_subset`]).
pub fn ci_seeds() -> Vec<u64> {
    ci_subset(DEVELOPMENT_FIRST_SEED, &Composition::RANGE)
        .iter()
        .map(|c| c.seed)
        .collect()
}

/// Where each held-out range starts: ranges are this many seeds apart.
pub const HELD_OUT_STRIDE: u64 = 10_000;

/// The held-out ranges already run (`held-out-ranges.csv`).
pub fn spent_ranges() -> Result<Vec<u64>> {
    let path = crate::history::record_path();
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let rows = crate::history::parse(&text).map_err(|e| anyhow::anyhow!(e))?;
    Ok(rows.iter().map(|r| r.range).collect())
}

/// The next held-out range: one stride past the last one run.
pub fn next_held_out() -> Result<u64> {
    Ok(spent_ranges()?
        .into_iter()
        .max()
        .map_or(1_000_000, |r| r + HELD_OUT_STRIDE))
}

/// The draws of `range` (the held-out range from `first_seed` or the next unspent one).
pub fn range_cases(range: Range, first_seed: Option<u64>) -> Result<Vec<Case>> {
    Ok(match (range, first_seed) {
        (Range::Ci | Range::Smoke, Some(_)) => {
            bail!("--first-seed: the {range} range is a fixed set of draws")
        }
        (Range::Ci, None) => ci_subset(DEVELOPMENT_FIRST_SEED, &Composition::RANGE),
        (Range::Smoke, None) => standard_range(DEVELOPMENT_FIRST_SEED)
            .into_iter()
            .filter(|c| SMOKE_SEEDS.contains(&c.seed))
            .collect(),
        (Range::Development, s) => standard_range(s.unwrap_or(DEVELOPMENT_FIRST_SEED)),
        (Range::HeldOut, Some(s)) => {
            if let Some(r) = spent_ranges()?
                .into_iter()
                .find(|&r| (r..r + HELD_OUT_STRIDE).contains(&s))
            {
                bail!(
                    "--first-seed {s}: held-out range {r} was already run (validation/suites/\
                     held-out-ranges.csv); a held-out range is run once. The next one starts \
                     at {}",
                    next_held_out()?
                );
            }
            standard_range(s)
        }
        (Range::HeldOut, None) => standard_range(next_held_out()?),
    })
}

/// The unit id of a draw.
pub fn unit_id(c: &Case) -> String {
    format!("draw-{}", c.seed)
}

/// The job of `range`.
pub fn job(range: Range, first_seed: Option<u64>) -> Result<(Job, Vec<Case>)> {
    let cases = range_cases(range, first_seed)?;
    let units = cases
        .iter()
        .map(|c| UnitSpec::new(unit_id(c), c.expected_cost()))
        .collect();
    let params = json!({
        "range": range.to_string(),
        "first_seed": cases.first().map(|c| c.seed),
        "draws": cases.len(),
        "seeds": cases.iter().map(|c| c.seed).collect::<Vec<_>>(),
        "time_limit_s": DRAW_TIME_LIMIT.as_secs(),
    });
    Ok((Job::new(JobKind::Suite, params, units)?, cases))
}

/// The range a suite job was made for.
pub fn job_range(job: &Job) -> Result<(Range, Option<u64>)> {
    let range: Range = job.params["range"]
        .as_str()
        .context("job.json: field `params.range` is missing")?
        .parse()?;
    let first = match range {
        Range::Ci | Range::Smoke => None,
        _ => job.params["first_seed"].as_u64(),
    };
    Ok((range, first))
}

/// One draw: its campaign written into a temporary folder by the independent simulator, the
/// user's loop on one thread, the outcome as JSON.
pub fn run_unit(case: &Case) -> Result<Value> {
    let dir = tempfile::tempdir()?;
    let o = run_case(case, dir.path())?;
    Ok(serde_json::to_value(o)?)
}

/// Reads a NaN written as `null` back (serde_json writes a NaN ratio, that of a draw whose loop
/// stopped on an error, as `null`).
pub fn nan_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v: Option<f64> = serde::Deserialize::deserialize(d)?;
    Ok(v.unwrap_or(f64::NAN))
}

fn title(range: Range, cases: &[Case]) -> String {
    let (a, b) = (
        cases.first().map_or(0, |c| c.seed),
        cases.last().map_or(0, |c| c.seed),
    );
    match range {
        Range::Development => format!("Development seeds {a}-{b} ({} draws)", cases.len()),
        Range::HeldOut => format!("Held-out seeds {a}-{b} ({} draws)", cases.len()),
        Range::Ci | Range::Smoke => format!(
            "{} of the development seeds ({} draws: {})",
            if range == Range::Ci {
                "CI subset"
            } else {
                "Smoke subset"
            },
            cases.len(),
            cases
                .iter()
                .map(|c| c.seed.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// One draw for the report (no wall time: the report is the same however the draws ran).
pub fn draw_line(o: &Outcome) -> String {
    format!(
        "{:>7} {:<58} -> found [{}] {} ({:.1}x -> {:.2}x floor) {}{}{}  [{}]",
        o.case.seed,
        o.case.scenario,
        o.found.join(", "),
        match (&o.error, o.explained) {
            (Some(e), _) => format!("error: {e}"),
            (None, true) => "explained".into(),
            (None, false) => "unexplained".into(),
        },
        o.identified_ratio,
        o.final_ratio,
        if o.right() { "ok" } else { "WRONG" },
        if o.time_limit_reached {
            ", time limit"
        } else {
            ""
        },
        after_design_words(o),
        o.truth
    )
}

fn draw_json(o: &Outcome) -> Value {
    json!({
        "seed": o.case.seed,
        "scenario": o.case.scenario,
        "truth": o.truth,
        "hidden": o.hidden,
        "found": o.found,
        "outcome": match (&o.error, o.explained) {
            (Some(_), _) => "error",
            (None, true) => "explained",
            (None, false) => "unexplained",
        },
        "error": o.error,
        "identified_ratio": o.identified_ratio,
        "final_ratio": o.final_ratio,
        "right": o.right(),
        "closed": o.closed(),
        "time_limit_reached": o.time_limit_reached,
        "after_design": o.after_design.as_ref().map(|a| json!({
            "records": a.records,
            "recording_s": a.recording_s,
            "predicted_sigma": a.predicted_sigma,
            "found": a.found,
            "explained": a.explained,
            "ambiguous_set": a.ambiguous_set,
            "error": a.error,
            "time_limit_reached": a.time_limit_reached,
        })),
        "named_alone_after_design": o.named_alone_after_design(),
    })
}

/// The table, report and JSON of a suite job's units (`table.md`, `report.md`, `result.json`:
/// the same bytes whatever the shards).
pub fn render(c: &Collected) -> Result<Merged> {
    let (range, first) = job_range(&c.job)?;
    let cases = range_cases_for_merge(range, first, &c.job)?;
    let outcomes: Vec<Outcome> = c
        .done
        .iter()
        .map(|d| {
            serde_json::from_value(d.outcome.clone())
                .with_context(|| format!("unit {}: its outcome is not a suite draw", d.spec.id))
        })
        .collect::<Result<_>>()?;
    let table = markdown(&title(range, &cases), &outcomes);
    let mut report = format!("{table}\n");
    for o in &outcomes {
        report.push_str(&format!("    {}\n", draw_line(o)));
    }
    let s = scores(&outcomes);
    let pair = |x: (usize, usize)| json!([x.0, x.1]);
    let mut result = json!({
        "format": "zmp-suite/1",
        "range": range.to_string(),
        "title": title(range, &cases),
        "draws": outcomes.iter().map(draw_json).collect::<Vec<_>>(),
        "scores": {
            "singles": pair(s.singles),
            "in_structure": pair(s.in_structure),
            "multiples": pair(s.multiples),
            "pairs": pair(s.pairs),
            "clean": pair(s.clean),
            "outside": pair(s.outside),
            "closed": pair(s.closed),
            "worst_closed_ratio": s.worst_closed_ratio,
            "false_alarms": pair(s.false_alarms),
            "ambiguous": pair(s.ambiguous),
            "after_design": pair(s.after_design),
        },
        "complete": c.complete(),
    });
    if !c.complete() {
        let failed: Vec<&str> = c.failed.iter().map(|f| f.unit.as_str()).collect();
        result["failed"] = json!(failed);
        result["missing"] = json!(c.missing);
        report.push_str(&format!(
            "\nIncomplete: {} of {} draws merged; failed: {}; missing: {}.\n",
            outcomes.len(),
            cases.len(),
            if failed.is_empty() {
                "none".into()
            } else {
                failed.join(", ")
            },
            if c.missing.is_empty() {
                "none".into()
            } else {
                c.missing.join(", ")
            },
        ));
    }
    let mut json_text = serde_json::to_string_pretty(&result)?;
    json_text.push('\n');
    Ok(Merged {
        files: vec![
            ("table.md".into(), table.clone().into_bytes()),
            ("report.md".into(), report.into_bytes()),
            ("result.json".into(), json_text.into_bytes()),
        ],
        json: result,
        text: table,
    })
}

/// The draws of a job being merged: the job's own range (a held-out range already recorded
/// as spent is still merged).
fn range_cases_for_merge(range: Range, first: Option<u64>, job: &Job) -> Result<Vec<Case>> {
    let cases = match range {
        Range::HeldOut => standard_range(first.context("job.json: no `params.first_seed`")?),
        _ => range_cases(range, first)?,
    };
    let ids: Vec<String> = cases.iter().map(unit_id).collect();
    let job_ids: Vec<&String> = job.units.iter().map(|u| &u.id).collect();
    if ids.iter().collect::<Vec<_>>() != job_ids {
        bail!("job.json: its units are not the draws of the {range} range this code makes");
    }
    Ok(cases)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ci_subset_is_the_first_draw_of_each_kind_of_the_composition() {
        // Counted by hand from the suite's order: 11 singles x 8 rounds (seeds 1-88), 60 pairs
        // (89-148), 24 pairs built ambiguous (149-172), 36 triples (173-208), 40 clean robots
        // (209-248), the outside effects from 249; six kinds besides the singles leave room
        // for the first six singles.
        let ci = ci_subset(DEVELOPMENT_FIRST_SEED, &Composition::RANGE);
        let seeds: Vec<u64> = ci.iter().map(|c| c.seed).collect();
        assert_eq!(seeds, [1, 2, 3, 4, 5, 6, 89, 149, 150, 173, 209, 249]);
        assert_eq!(ci_seeds(), seeds);
        assert_eq!(ci[7].scenario, "pair:time_delay,backlash");
        assert_eq!(ci[8].scenario, "pair:coulomb_friction,sensor_lowpass");
        assert_eq!(ci[10].class, Class::Clean);
        assert!(matches!(ci[11].class, Class::Outside(_)));
        let smoke = range_cases(Range::Smoke, None).unwrap();
        assert_eq!(
            smoke.iter().map(|c| c.seed).collect::<Vec<_>>(),
            SMOKE_SEEDS
        );
        assert_eq!(smoke[0].scenario, "single:time_delay");
        assert_eq!(smoke[3].class, Class::Clean);
        assert_eq!(smoke[4].class, Class::Clean);
        // It follows the composition: one round of singles (1-11), 2 pairs (12-13), 2 built
        // ambiguous (14-15), a triple (16), a clean robot (17), the outside effects from 18.
        let small = Composition {
            singles: 1,
            pairs: 2,
            ambiguous_pairs: 2,
            triples: 1,
            clean: 1,
            outside: 1,
        };
        let seeds: Vec<u64> = ci_subset(1, &small).iter().map(|c| c.seed).collect();
        assert_eq!(seeds, [1, 2, 3, 4, 5, 6, 12, 14, 15, 16, 17, 18]);
        // Without pairs built ambiguous (pairs 12-13, the triple 14, clean 15, outside from 16)
        // their room goes to singles.
        let fewer = Composition {
            ambiguous_pairs: 0,
            ..small
        };
        let seeds: Vec<u64> = ci_subset(1, &fewer).iter().map(|c| c.seed).collect();
        assert_eq!(seeds, [1, 2, 3, 4, 5, 6, 7, 8, 12, 14, 15, 16]);
    }

    #[test]
    fn ranges_name_their_draws_and_refuse_a_spent_held_out_range() {
        let ci = range_cases(Range::Ci, None).unwrap();
        assert_eq!(ci.iter().map(|c| c.seed).collect::<Vec<_>>(), ci_seeds());
        let dev = range_cases(Range::Development, None).unwrap();
        assert_eq!(dev.len(), Composition::RANGE.draws());
        let spent = spent_ranges().unwrap();
        let e = range_cases(Range::HeldOut, Some(spent[0] + 5))
            .unwrap_err()
            .to_string();
        assert!(e.contains("already run"), "{e}");
        let next = next_held_out().unwrap();
        assert!(spent.iter().all(|&r| r < next));
        assert_eq!(range_cases(Range::HeldOut, None).unwrap()[0].seed, next);
        assert!(range_cases(Range::Ci, Some(3)).is_err());
        assert!("heldout".parse::<Range>().is_err());
        let (job, cases) = job(Range::Ci, None).unwrap();
        assert_eq!(job.units.len(), cases.len());
        assert_eq!(job_range(&job).unwrap(), (Range::Ci, None));
    }
}
