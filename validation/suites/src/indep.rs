//! The out-of-sample blind suite's harness: robots drawn by `zmp-indep-sim` (a simulator that
//! shares no code with `zmp-models`), their campaigns written to disk by that simulator and
//! read back by the project's reader, then the user's loop (`diagnose::iterate::run_loop`,
//! what `cargo xtask loop` runs) with nothing of the truth but the campaign folder.
//!
//! Scoring (fixed before the suite was run):
//! - The seed's structure already holds acceleration saturation and pendulum-form coupling
//!   (the loop identifies both), so a hidden `acceleration_saturation` or `cross_coupling`
//!   (drawn in pendulum form) is part of what the identified model must carry, not something
//!   the diagnosis has to add: it counts as found when nothing false is added and the loop
//!   ends explained.
//! - Every other hidden catalogue effect must be added by the loop: a single one **named**
//!   when it is the first effect added; a pair or triple **found** when every one of them is
//!   added.
//! - **False effect**: any added effect (other than acceleration saturation, which the seed's
//!   structure has anyway) that is not hidden.
//! - A draw with an effect outside the catalogue is right when the loop ends `unexplained`.
//! - After the loop, a draw whose effects are all in the catalogue must be explained with its
//!   error within 2x the noise floor.

#![allow(dead_code)]

use std::path::Path;
use zmp_campaign::read_campaign;
use zmp_diagnose::iterate::run_loop;
use zmp_diagnose::DiagnoseOptions;
use zmp_identify::IdentifyOptions;
use zmp_indep_sim::{draw_with, write_campaign, CouplingForm, Design, DrawOptions, Scenario};

/// What the seed's structure already carries (identified, never "missing").
pub const IN_STRUCTURE: [&str; 2] = ["acceleration_saturation", "cross_coupling"];

/// The kind of a draw, for the tables.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
pub enum Class {
    Clean,
    Single(String),
    Pair,
    Triple,
    Outside(String),
}

/// One draw of the suite.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Case {
    pub seed: u64,
    pub scenario: String,
    pub class: Class,
}

/// What the loop made of a draw (a unit's outcome in `cargo xtask suite`: [`crate::sharded`]).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Outcome {
    pub case: Case,
    /// Hidden effects, catalogue names (outside effects by their own names).
    pub hidden: Vec<String>,
    /// Whether every hidden effect is in the catalogue.
    pub in_catalogue: bool,
    /// Effects the loop added, in order.
    pub found: Vec<String>,
    pub explained: bool,
    #[serde(deserialize_with = "crate::sharded::nan_if_null")]
    pub identified_ratio: f64,
    #[serde(deserialize_with = "crate::sharded::nan_if_null")]
    pub final_ratio: f64,
    /// Short description of the truth.
    pub truth: String,
    pub seconds: f64,
    /// The loop's error when it stopped on one (a failure of the draw, never right).
    pub error: Option<String>,
    /// Whether the draw's loop reached [`DRAW_TIME_LIMIT`] (it is scored on what it reached).
    pub time_limit_reached: bool,
}

/// Wall-clock limit of one draw's loop (`DiagnoseOptions::time_limit`), fixed before the
/// held-out range 1230000 ran: the slowest draws of the development seeds take under two
/// minutes on one thread, and held-out draw 1220001 (a play named beside a friction and a
/// mode, whose fits simulate every record at every evaluation) ran over 40 minutes and held
/// the whole suite. A draw past the limit is scored on the model it reached, and its line
/// says so.
pub const DRAW_TIME_LIMIT: std::time::Duration = std::time::Duration::from_secs(600);

impl Outcome {
    /// Hidden effects the diagnosis must add (not already in the seed's structure).
    pub fn must_find(&self) -> Vec<&str> {
        self.hidden
            .iter()
            .map(|s| s.as_str())
            .filter(|h| !IN_STRUCTURE.contains(h))
            .collect()
    }

    /// Added effects that are not hidden (acceleration saturation never counts as false).
    pub fn false_effects(&self) -> Vec<&str> {
        self.found
            .iter()
            .map(|s| s.as_str())
            .filter(|f| *f != "acceleration_saturation" && !self.hidden.iter().any(|h| h == f))
            .collect()
    }

    /// The first effect the loop added that the diagnosis had to find (saturation skipped).
    pub fn first_named(&self) -> Option<&str> {
        self.found
            .iter()
            .map(|s| s.as_str())
            .find(|f| *f != "acceleration_saturation")
    }

    /// Right by the rules in the module docs.
    pub fn right(&self) -> bool {
        if self.error.is_some() {
            return false;
        }
        if !self.in_catalogue {
            return !self.explained;
        }
        let must = self.must_find();
        let all_found = must.iter().all(|m| self.found.iter().any(|f| f == m));
        match &self.case.class {
            Class::Single(_) if !must.is_empty() => self.first_named() == Some(must[0]),
            // Already in the seed's structure: nothing false added, and explained.
            Class::Single(_) => self.false_effects().is_empty() && self.explained,
            Class::Clean => self.false_effects().is_empty(),
            _ => all_found,
        }
    }

    /// Within 2x the noise floor and explained after the loop.
    pub fn closed(&self) -> bool {
        self.error.is_none() && self.explained && self.final_ratio <= 2.0
    }
}

/// The catalogue effects a single draw hides, in suite order.
pub const SINGLES: [&str; 9] = [
    "time_delay",
    "backlash",
    "coulomb_friction",
    "acceleration_saturation",
    "structural_mode",
    "sensor_lowpass",
    "operating_point_dependence",
    "sensor_drift",
    "cross_coupling",
];

/// Pairs, cycled.
pub const PAIRS: [(&str, &str); 8] = [
    ("time_delay", "backlash"),
    ("time_delay", "sensor_drift"),
    ("coulomb_friction", "sensor_lowpass"),
    ("structural_mode", "time_delay"),
    ("backlash", "operating_point_dependence"),
    ("sensor_lowpass", "sensor_drift"),
    ("coulomb_friction", "time_delay"),
    ("structural_mode", "sensor_drift"),
];

/// Triples, cycled.
pub const TRIPLES: [(&str, &str, &str); 3] = [
    ("time_delay", "backlash", "sensor_drift"),
    (
        "coulomb_friction",
        "sensor_lowpass",
        "operating_point_dependence",
    ),
    ("structural_mode", "time_delay", "sensor_drift"),
];

/// Out-of-catalogue effects.
pub const OUTSIDE: [&str; 4] = [
    "second_structural_mode",
    "stribeck_friction",
    "rate_limited_servo",
    "cubic_stiffness",
];

/// The suite's draws from `first_seed` on: every single effect `singles` times, `pairs`
/// pairs, `triples` triples, `clean` clean robots and every outside effect `outside` times.
pub fn suite(
    first_seed: u64,
    singles: usize,
    pairs: usize,
    triples: usize,
    clean: usize,
    outside: usize,
) -> Vec<Case> {
    let mut out = Vec::new();
    let mut seed = first_seed;
    let mut push = |scenario: String, class: Class| {
        out.push(Case {
            seed,
            scenario,
            class,
        });
        seed += 1;
    };
    for _ in 0..singles {
        for e in SINGLES {
            push(format!("single:{e}"), Class::Single(e.to_string()));
        }
    }
    for k in 0..pairs {
        let (a, b) = PAIRS[k % PAIRS.len()];
        push(format!("pair:{a},{b}"), Class::Pair);
    }
    for k in 0..triples {
        let (a, b, c) = TRIPLES[k % TRIPLES.len()];
        push(format!("triple:{a},{b},{c}"), Class::Triple);
    }
    for _ in 0..clean {
        push("clean".into(), Class::Clean);
    }
    for _ in 0..outside {
        for e in OUTSIDE {
            push(format!("outside:{e}"), Class::Outside(e.to_string()));
        }
    }
    out
}

/// Draws the case's robot, writes its campaign into `dir` with the independent simulator,
/// reads it back and runs the loop on one thread.
pub fn run_case(case: &Case, dir: &Path) -> anyhow::Result<Outcome> {
    let t = std::time::Instant::now();
    let scenario: Scenario = case
        .scenario
        .parse()
        .map_err(|e| anyhow::anyhow!("{}: {e}", case.scenario))?;
    let design = Design::default();
    let robot = draw_with(
        case.seed,
        &scenario,
        &design,
        &DrawOptions {
            coupling_form: Some(CouplingForm::Pendulum),
        },
    );
    // `ZMP_BLIND_KEEP=DIR` keeps each draw's campaign in DIR (for looking at one draw with
    // `cargo xtask loop DIR/campaign-SEED`); otherwise it goes with the temporary folder.
    let keep = std::env::var_os("ZMP_BLIND_KEEP").map(std::path::PathBuf::from);
    let camp_dir = keep
        .as_deref()
        .unwrap_or(dir)
        .join(format!("campaign-{}", case.seed));
    write_campaign(&robot, &design, &camp_dir, true)?;
    let camp = read_campaign(&camp_dir)?;
    let opts = DiagnoseOptions {
        campaign_path: camp_dir.display().to_string(),
        model_path: "identified.toml".into(),
        threads: 1,
        time_limit: Some(DRAW_TIME_LIMIT),
        ..DiagnoseOptions::default()
    };
    let iopts = IdentifyOptions {
        threads: Some(1),
        ..IdentifyOptions::default()
    };
    let r = run_loop(&camp, None, &iopts, &opts, &|_| {});
    if keep.is_none() {
        let _ = std::fs::remove_dir_all(&camp_dir);
    }
    let hidden: Vec<String> = robot.hidden.iter().map(|h| h.name.to_string()).collect();
    let in_catalogue = robot.hidden.iter().all(|h| h.in_catalogue);
    let truth = robot
        .hidden
        .iter()
        .map(|h| format!("{}{}", h.name, if h.visible { "" } else { " (invisible)" }))
        .collect::<Vec<_>>()
        .join(", ");
    let seconds = t.elapsed().as_secs_f64();
    Ok(match r {
        Ok(r) => Outcome {
            case: case.clone(),
            hidden,
            in_catalogue,
            found: r.found.clone(),
            explained: r.explained,
            identified_ratio: r.identified_error / r.noise_floor,
            final_ratio: r.final_error / r.noise_floor,
            truth,
            seconds,
            error: None,
            time_limit_reached: r.time_limit_reached,
        },
        Err(e) => Outcome {
            case: case.clone(),
            hidden,
            in_catalogue,
            found: Vec::new(),
            explained: false,
            identified_ratio: f64::NAN,
            final_ratio: f64::NAN,
            truth,
            seconds,
            error: Some(e.to_string()),
            time_limit_reached: false,
        },
    })
}

/// One line per outcome, for the test's log.
pub fn line(o: &Outcome) -> String {
    format!(
        "{:>7} {:<58} -> found [{}] {} ({:.1}x -> {:.2}x floor) {} [{:.0} s{}]",
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
        o.seconds,
        if o.time_limit_reached {
            ", time limit"
        } else {
            ""
        }
    )
}

/// The suite's scores.
#[derive(Debug, Clone, Default)]
pub struct Scores {
    /// Single catalogue effects (the diagnosis must add them): named first / draws.
    pub singles: (usize, usize),
    /// Single effects the seed's structure carries: right / draws.
    pub in_structure: (usize, usize),
    /// Pairs and triples: every hidden effect found / draws.
    pub multiples: (usize, usize),
    /// Pairs alone.
    pub pairs: (usize, usize),
    /// Clean robots with no false effect / clean draws.
    pub clean: (usize, usize),
    /// Outside effects that end unexplained / draws.
    pub outside: (usize, usize),
    /// In-catalogue draws explained within 2x the floor after the loop / draws.
    pub closed: (usize, usize),
    pub worst_closed_ratio: f64,
    /// In-catalogue draws with a false effect.
    pub false_alarms: (usize, usize),
}

fn add(x: &mut (usize, usize), ok: bool) {
    x.1 += 1;
    if ok {
        x.0 += 1;
    }
}

pub fn scores(outcomes: &[Outcome]) -> Scores {
    let mut s = Scores::default();
    for o in outcomes {
        match &o.case.class {
            Class::Single(_) if !o.must_find().is_empty() => add(&mut s.singles, o.right()),
            Class::Single(_) => add(&mut s.in_structure, o.right()),
            Class::Pair => {
                add(&mut s.multiples, o.right());
                add(&mut s.pairs, o.right());
            }
            Class::Triple => add(&mut s.multiples, o.right()),
            Class::Clean => add(&mut s.clean, o.right()),
            Class::Outside(_) => add(&mut s.outside, o.right()),
        }
        if o.in_catalogue {
            add(&mut s.closed, o.closed());
            add(&mut s.false_alarms, !o.false_effects().is_empty());
            if o.explained {
                s.worst_closed_ratio = s.worst_closed_ratio.max(o.final_ratio);
            }
        }
    }
    s
}

fn pct(x: (usize, usize)) -> String {
    if x.1 == 0 {
        return "-".into();
    }
    format!("{}/{} ({:.0} %)", x.0, x.1, 100.0 * x.0 as f64 / x.1 as f64)
}

/// The confusion table (rows: what was hidden; columns: the first effect the loop added, or
/// its outcome when it added none) and the scores, as markdown.
pub fn markdown(title: &str, outcomes: &[Outcome]) -> String {
    use std::collections::BTreeMap;
    let short = |s: &str| -> String {
        s.split('_')
            .map(|w| w.chars().take(4).collect::<String>())
            .collect::<Vec<_>>()
            .join("_")
    };
    let mut cols: Vec<String> = SINGLES
        .iter()
        .filter(|e| !IN_STRUCTURE.contains(e))
        .map(|e| e.to_string())
        .collect();
    cols.extend(["none".into(), "unexplained".into(), "error".into()]);
    let col_of = |o: &Outcome| -> String {
        if o.error.is_some() {
            return "error".into();
        }
        match o.first_named() {
            Some(f) => f.to_string(),
            None if o.explained => "none".into(),
            None => "unexplained".into(),
        }
    };
    let row_of = |o: &Outcome| -> String {
        match &o.case.class {
            Class::Single(e) => e.clone(),
            Class::Clean => "clean (saturation only)".into(),
            Class::Pair => "pair".into(),
            Class::Triple => "triple".into(),
            Class::Outside(e) => format!("outside: {e}"),
        }
    };
    let mut rows: BTreeMap<(usize, String), BTreeMap<String, usize>> = BTreeMap::new();
    for o in outcomes {
        let order = match &o.case.class {
            Class::Single(e) => SINGLES.iter().position(|s| s == e).unwrap_or(0),
            Class::Clean => 20,
            Class::Pair => 30,
            Class::Triple => 31,
            Class::Outside(_) => 40,
        };
        *rows
            .entry((order, row_of(o)))
            .or_default()
            .entry(col_of(o))
            .or_default() += 1;
    }
    let mut t = format!("**{title}**\n\n| hidden \\ first added | ");
    t.push_str(
        &cols
            .iter()
            .map(|c| short(c))
            .collect::<Vec<_>>()
            .join(" | "),
    );
    t.push_str(" | right |\n|---");
    t.push_str(&"|---".repeat(cols.len() + 1));
    t.push_str("|\n");
    for ((_, r), row) in &rows {
        let right = outcomes
            .iter()
            .filter(|o| &row_of(o) == r)
            .filter(|o| o.right())
            .count();
        let n = outcomes.iter().filter(|o| &row_of(o) == r).count();
        t.push_str(&format!("| {r} |"));
        for c in &cols {
            match row.get(c) {
                Some(n) => t.push_str(&format!(" {n} |")),
                None => t.push_str(" · |"),
            }
        }
        t.push_str(&format!(" {right}/{n} |\n"));
    }
    let s = scores(outcomes);
    t.push_str(&format!(
        "\nSingle effects named first: {}. Effects the seed's structure carries (saturation, \
         pendulum-form coupling): {}. Pairs and triples with every effect found: {} (pairs {}). \
         Clean robots without a false effect: {}. Outside the catalogue ending unexplained: {}. \
         In-catalogue draws explained within 2x the noise floor after the loop: {} (worst {:.2}x); \
         with a false effect: {}.\n",
        pct(s.singles),
        pct(s.in_structure),
        pct(s.multiples),
        pct(s.pairs),
        pct(s.clean),
        pct(s.outside),
        pct(s.closed),
        s.worst_closed_ratio,
        pct(s.false_alarms),
    ));
    let limited: Vec<String> = outcomes
        .iter()
        .filter(|o| o.time_limit_reached)
        .map(|o| o.case.seed.to_string())
        .collect();
    if !limited.is_empty() {
        t.push_str(&format!(
            "Draws whose loop reached the {} s time limit (scored on the model reached): {} \
             ({}).\n",
            DRAW_TIME_LIMIT.as_secs(),
            limited.len(),
            limited.join(", ")
        ));
    }
    t
}
