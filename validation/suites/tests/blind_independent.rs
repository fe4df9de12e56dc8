//! The out-of-sample blind suite: robots from `zmp-indep-sim`, a simulator written apart from
//! `zmp-models` (it shares no code with it), always saturating, with one to three hidden
//! catalogue effects (the two further forms included), none, an effect outside the catalogue,
//! or a pair built to be ambiguous on the standard design; the campaign goes through the
//! files into the user's loop (identify -> diagnose -> add), which sees nothing else. Scoring
//! rules and the composition of a range (300 draws): `zmp_suites::indep`. The thresholds
//! below are issue 55's, fixed before its held-out range was run; the development seeds are
//! where the diagnosis is tuned.
//!
//! The held-out run writes its table into the book (`docs/src/suites.md`) between the
//! markers `<!-- blind-independent:held-out -->` and appends its row to the held-out record
//! (`docs/src/held-out-history.md`) when `ZMP_UPDATE_DOCS=1`, and otherwise checks that the
//! page's table is the one it measured.

use zmp_suites::indep;

use indep::{line, scores, Outcome};
use std::time::{Duration, Instant};
use zmp_files::sections::check_page as doc_section;
use zmp_suites::sharded::Range;

/// Held-out seeds: never looked at while the diagnosis was developed. Ranges spent: from
/// 900000 (its first run stopped on seed 900000, which was then examined: the delay's range,
/// saturation's monotone demand); from 910000 (run once, singles 18/21, pairs 11/12, clean
/// 10/10, outside 8/8, closed 22/52; its summary lines, not its draws, were seen before the
/// last changes: the limit at its floor, the error rule and the swap in the search); from
/// 920000 (run once: singles 15/21, pairs 8/12, clean 10/10, outside 6/8, closed 18/52; seed
/// 920003, a heavy saturation left at 1.5x the floor, was then examined, which led to the
/// development seeds' clean robots and the noise colour at low frequency); from 930000 (run
/// once: singles 19/21, pairs 7/12, clean 10/10, outside 5/8, closed 36/52; then examined:
/// seeds 930055 (cubic stiffness: its linear compliance mode added, the cubic part invisible),
/// 930027 (a delay absorbed by the low-pass beside backlash) and 930033; the changes after
/// it: the structural mode's damping cap 0.4, the operating-point law linearised through the
/// static map's slope, a structural mode on the second axis); from 940000 (run once: singles
/// 15/21, saturation and coupling 4/6, pairs 7/12, clean 10/10, outside 7/8, closed 38/52;
/// then examined: 940001 (backlash inside a saturating servo, not found), 940009, 940011 and
/// 940012 (the identification kept the seed's servo low-pass and the loop stopped at the
/// diagnosis's `parameter_refit`), which led to the loop's refit step); from 950000 (run
/// once: singles 17/21, saturation and coupling 5/6, pairs 8/12, clean 10/10, outside 6/8,
/// closed 35/52; its summary lines were read, no draw of it was examined; the changes after
/// it, made on development seeds 11 and 31: the identification's omega_n with zeta held,
/// the restart of a saturation limit that never acts, the op-line evidence words); from
/// 960000 (run once: singles 18/21, saturation and coupling 6/6, pairs 9/12, clean 10/10,
/// outside 4/8, closed 39/52; then examined: 960020, Coulomb friction identified with a limit
/// far too low, which led to the loop taking a refit that removes most of the error); from
/// 970000 (run once, with that refit, backward elimination and the amplitude rule for play and
/// friction: singles 16/21, saturation and coupling 6/6, pairs 6/12, clean 10/10, outside 5/8,
/// closed 40/52, false effect 10/52; then examined: 970010 and 970020, to check that the
/// amplitude rule had not blocked their play and friction: it had not; 970010's play removed
/// more than half the excess error but 6 % of the excess chi-square, which led to the error
/// fraction in the search's test); from 980000 (run once on the code of 7646e21, that error
/// fraction and the per-axis amplitude rule in: singles 17/21, saturation and coupling 6/6,
/// pairs 7/12, clean 10/10, outside 4/8, closed 41/52, false effect 14/52; then examined:
/// 980001, the lone play the loop did not find, to check the passive damping found on
/// development seed 11: from a start model with one it names the play,
/// `tests/passive_damping.rs`); from 990000 (run once on the code of 366646c, the loop's
/// trunk-in-servo step in: singles 15/21, saturation and coupling 6/6, pairs 7/12, clean
/// 10/10, outside 4/8, closed 43/52, false effect 13/52; then examined: 990002, a friction the
/// loop called explained at 1.2x the floor with a chi-square of 7 per component, which led to
/// the chi-square condition for "explained"); from 1000000 (run once on the code of f1f3fe7:
/// singles 17/21, saturation and coupling 5/6, pairs 9/12, clean 10/10, outside 4/8, closed
/// 41/52, false effect 12/52; then examined: 1000011, a friction left unfound, whose odd
/// harmonics no model predicted, which led to the third harmonic in the chi-square); from
/// 1010000 (run once on the code of 0c42746, the third harmonic in: singles 17/21,
/// saturation and coupling 5/6, pairs 10/12, clean 10/10, outside 4/8, closed 44/52, false
/// effect 9/52; then examined: 1010005 and 1010014, sensor low-passes named as a mode and a
/// delay, which led to a delay and a low-pass with one value per axis); from 1020000 (run
/// once on the code of a1cfb1c, that per-axis fit in: singles 21/21, saturation and coupling
/// 6/6, pairs 7/12, triples 3/3, clean 10/10, outside 5/8, closed 42/52, false effect 6/52);
/// from 1030000 (run once on the code of a4ed5ef, the trunk law fitted from typical links
/// too: singles 19/21, saturation and coupling 6/6, pairs 9/12, triples 1/3, clean 10/10,
/// outside 4/8, closed 41/52, false effect 6/52); from 1040000 (run once on the code of
/// ca4047f, the trunk law refitting the force limit and the swap's margin: singles 21/21,
/// saturation and coupling 5/6, pairs 7/12, triples 1/3, clean 10/10, outside 4/8, closed
/// 40/52, false effect 7/52); from 1050000 (run once on the code of a056e76, the servo's
/// creep and speed sub-steps and the local noise by Goertzel in: singles 20/21, saturation
/// and coupling 5/6, pairs 9/12, triples 2/3, clean 10/10, outside 5/8, closed 42/52, false
/// effect 6/52; then examined: spent draw 1040027, whose refit from the true delay drives
/// the delay to zero beside the catalogue's play); from 1060000 (run once on the code of
/// 940b574, the linked servo's creep in, the diagnosis otherwise that of 1050000: singles
/// 21/21, saturation and coupling 6/6, pairs 8/12, triples 2/3, clean 10/10, outside 6/8,
/// closed 46/52, false effect 7/52; then examined: 1060035, a delay beside play, where the
/// play alone is "explained" at 4.67 per component and the search, forced on, names the delay
/// and then a false mode); from 1070000 (run once on the code of 1d809c6, the search going
/// on past "explained" for an effect that removes half of the excess: singles 18/21,
/// saturation and coupling 6/6, pairs 6/12, triples 2/3, clean 10/10, outside 4/8, closed
/// 41/52, false effect 7/52; then examined: 1070027, a delay beside play, where the best
/// further effect past "explained" is a mode at 35 % of the excess, and 1070011, a lone
/// friction whose drawn values in the model leave 2.6x the floor at the clamped records);
/// from 1080000 (run once on the code of 6f92688, the friction's `tanh` from one `exp` and
/// the linked servo's eigenvalue sub-steps in: singles 19/21, saturation and coupling 4/6,
/// pairs 11/12, triples 2/3, clean 10/10, outside 5/8, closed 43/52, false effect 6/52; then
/// examined: 1080004, a lone mode the filter law cannot fit where the force limit clips, left
/// at 11.45x with nothing found, which led to the mode candidate fitted inside the servo);
/// from 1090000 (run once on the code of f42682d, that candidate in: singles 19/21, saturation
/// and coupling 5/6, pairs 10/12, triples 1/3, clean 10/10, outside 7/8, closed 44/52, false
/// effect 9/52; not examined); from 1100000 (run once on the code of 3959683, the trend's
/// noise read where the trend sees it: singles 21/21, saturation and coupling 6/6, pairs 7/12,
/// triples 3/3, clean 10/10, outside 4/8, closed 50/52, false effect 7/52; not examined);
/// from 1110000 (run once on the code of b70c71c, the loop moving a play it adds inside its
/// servo: singles 18/21, saturation and coupling 6/6, pairs 9/12, triples 2/3, clean 10/10,
/// outside 4/8, closed 49/52, false effect 4/52; not examined); from 1120000 (run once on the
/// code of f864e4f, a simpler effect winning a near tie past "explained" too: singles 20/21,
/// saturation and coupling 6/6, pairs 6/12, triples 3/3, clean 10/10, outside 3/8, closed
/// 47/52, false effect 6/52; then examined: 1120002, a lone friction whose identified force
/// limit was a quarter of the drawn one, which led to the limit search starting from a grid);
/// from 1130000 (run once on the code of 2eba340, that grid in: singles 19/21, saturation and
/// coupling 6/6, pairs 9/12, triples 1/3, clean 10/10, outside 3/8, closed 50/52, false effect
/// 8/52; not examined); from 1140000 (run once on the code of d63dc39, the effects beside a
/// play judged again with the play inside its servo: singles 21/21, saturation and coupling
/// 6/6, pairs 9/12, triples 2/3, clean 10/10, outside 5/8, closed 47/52, false effect 8/52;
/// then examined: 1140013 and 1140004, lone modes left unexplained, a mode in each plane, one
/// inside the sweep and one above it, which led to the two planes' links started at different
/// frequencies; and 1140030, a mode beside a delay at 3.7x, whose link had taken the delay's
/// phase at its share cap, which led to that cap ruled out and the refit from typical values); from 1150000 (run once on the code of f8cc365, the two planes' links started
/// apart, a link at its share cap no mode, the typical refit at the end: singles 21/21,
/// saturation and coupling 6/6, pairs 8/12, triples 2/3, clean 10/10, outside 2/8, closed
/// 48/52, false effect 4/52; then examined: 1150030, a mode above the sweep a long delay stood
/// in for, which led to the refit from typical values starting each mode at the upper
/// frequencies and the delays cut to three tenths); from 1160000 (run once on the code of
/// 718b597, those starts and the three-pass harmonic regression in: singles 21/21, saturation
/// and coupling 6/6, pairs 7/12, triples 2/3, clean 10/10, outside 3/8, closed 50/52, false
/// effect 5/52; then examined: 1160031, a play beside an operating-point dependence left
/// unexplained at 0.52x the floor, whose play the amplitude contrast hid behind three pairs the
/// force limit clamps, which led to such pairs left out of the contrast; 1160027 and 1160041,
/// delays whose lag a slow servo low-pass had taken, which led to the delay tried from the
/// seed's servo and the typical refit's start with that lag moved to the delays); from 1170000
/// (run once on the code of 1087e5e, those three changes in: singles 18/21, saturation and
/// coupling 6/6, pairs 8/12, triples 3/3, clean 10/10, outside 3/8, closed 48/52, false effect
/// 6/52; then examined: 1170010, a lone play in a soft transmission whose small sines respond
/// more than the large ones, which only the play inside the servo fits and the search never
/// tries, and 1170031, unchanged by this round's code; which led to the loop's last look with
/// the play inside the servo); from 1180000 (run once on the code of d152f2a, that look in:
/// singles 20/21, saturation and coupling 6/6, pairs 7/12, triples 2/3, clean 10/10, outside
/// 3/8, closed 50/52, false effect 4/52; then examined: 1180004, a lone mode inside the sweep,
/// which led to the typical refit's in-band starts; 1180037 and 1180029, frictions beside a
/// low-pass named play, which led to friction and force limit simulated together and the
/// loop's look at the other amplitude law); from 1190000 (run once on the code of c739d1d,
/// those in: singles 19/21, saturation and coupling 6/6, pairs 10/12, triples 2/3, clean
/// 10/10, outside 2/8, closed 51/52, false effect 7/52; then examined: 1190020, a lone
/// friction whose own fit fell to zero and was screened out, which led to the friction's joint
/// fit from its starts); from 1200000 (run once on the code of 139fae4, that in: singles
/// 21/21, saturation and coupling 6/6, pairs 12/12, triples 1/3, clean 10/10, outside 2/8,
/// closed 51/52, false effect 6/52; then examined: 1200041, a mode-delay-drift triple whose
/// links bent to the delay's phase, which led to the delay fitted with the structure made
/// typical); from 1210000 (run once on the code of b9063f6, that in, and development seed 11's
/// mode giving way to the play inside its servo: singles 20/21, saturation and coupling 6/6,
/// pairs 9/12, triples 2/3, clean 10/10, outside 4/8, closed 48/52, false effect 7/52; then
/// examined: 1210022, 1210030 and 1210038, modes beside delays or on both planes, which led to
/// the typical refit's link on a bare plane, its starts without a sensor low-pass and the delay
/// looked for beside links without an absorbed lag); from 1220000 (started on the code of
/// a348115, those in but the last; stopped after 40 minutes with draw 1220001, a lone play,
/// still in the loop's play-inside-the-servo refit on a model with a friction and a mode, so
/// its table was not written; of the other 59: singles 20/20, saturation and coupling 6/6,
/// pairs 10/12, triples 3/3, clean 10/10, outside 2/8, closed 50/51 (worst 1.02x); then
/// examined: 1220038, a mode-delay pair named as a mode and a sensor low-pass, which led to
/// those starts adding the delay and the force limit a model lacks); from 1230000 (run on
/// 12b4bff, the first range with each draw's loop limited to `DRAW_TIME_LIMIT`, 600 s; 16.2
/// minutes: singles 20/21, saturation and coupling 6/6, pairs 10/12, triples 2/3, clean
/// 10/10, outside 2/8, closed 51/52 (worst 1.00x), false effect 5/52; misses 1230010, a lone
/// play named as a friction and a mode, at its time limit, unexplained at 1.65x; 1230027, a
/// delay beside a play named as the play; 1230037, a friction beside a low-pass named as the
/// friction; 1230039, the triple's delay named as a friction); from 1240000 (run on 823e75c,
/// a friction just added swapped at once for a play, and the outside effects drawn visible
/// against their catalogue forms; 21.2 minutes: singles 21/21, saturation and coupling 6/6,
/// pairs 9/12, triples 3/3, clean 10/10, outside 4/8, closed 50/52 (not closed: 1240030, a
/// mode-delay pair at its time limit, 1.39x; 1240041, the mode-delay-drift triple, 2.62x),
/// false effect 3/52; misses 1240027 and 1240035, a delay beside a play named as the play;
/// 1240031, an operating-point dependence beside a play named as the play); from 1250000 (run
/// on 8ea5e78, eigenvalues with a bounded iteration; 23.0 minutes: singles 21/21, saturation
/// and coupling 6/6, pairs 8/12, triples 2/3, clean 10/10, outside 5/8, closed 52/52 (worst
/// 1.09x), false effect 5/52; misses 1250027 and 1250035, a delay beside a play named as the
/// play; 1250028, a delay beside a drift named as a low-pass; 1250029, a friction beside a
/// low-pass named as a play; 1250040, the friction-low-pass-operating-point triple's friction
/// and low-pass named as a play). The ranges up to 1250000 held 60 draws; from 1260000 a range
/// holds 300 ([`Composition::RANGE`]), still within the 10000 seeds between two ranges.
const HELD_OUT_FIRST_SEED: u64 = 1_260_000;

// Thresholds of issue 55 (frozen before its held-out range ran): single effects named first,
// clean robots without a false effect, false effects among in-catalogue draws, pairs and
// triples found (or the truth inside an ambiguous set of at most three), in-catalogue draws
// ending ambiguous, outside effects ending unexplained and their residual described right.
const MIN_SINGLES: f64 = 0.95;
const MIN_CLEAN: f64 = 0.95;
const MAX_FALSE: f64 = 0.05;
const MIN_MULTIPLES: f64 = 0.90;
const MAX_AMBIGUOUS: f64 = 0.25;
const MIN_OUTSIDE: f64 = 0.80;
const MIN_WORDS: f64 = 0.70;

/// Appends the range's row to the held-out record (`zmp_suites::history`) and regenerates the
/// book's history page: the date, the commit that ran it, the counts, the minutes.
fn record_range(first_seed: u64, outcomes: &[Outcome], took: Option<std::time::Duration>) {
    let s = scores(outcomes);
    let code = std::process::Command::new("git")
        .args(["rev-parse", "--short=7", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    let row = zmp_suites::history::RangeRow {
        range: first_seed,
        date: zmp_campaign::ledger::utc_now()[..10].to_string(),
        code,
        singles: Some(s.singles),
        carried: Some(s.in_structure),
        pairs: Some((
            s.pairs.0 + s.ambiguous_pairs.0,
            s.pairs.1 + s.ambiguous_pairs.1,
        )),
        triples: Some((
            s.multiples.0 - s.pairs.0 - s.ambiguous_pairs.0,
            s.multiples.1 - s.pairs.1 - s.ambiguous_pairs.1,
        )),
        clean: Some(s.clean),
        outside: Some(s.outside),
        closed: Some(s.closed),
        false_effects: Some(s.false_alarms),
        ambiguous: Some(s.ambiguous),
        words: (s.words.1 > 0).then_some(s.words),
        after_design: (s.after_design.1 > 0).then_some(s.after_design),
        minutes: took.map(|t| t.as_secs_f64() / 60.0),
        note: String::new(),
    };
    zmp_suites::history::append(&row).unwrap_or_else(|e| panic!("{e}"));
    let text = std::fs::read_to_string(zmp_suites::history::record_path()).unwrap();
    let rows = zmp_suites::history::parse(&text).unwrap();
    doc_section(
        "docs/src/held-out-history.md",
        "held-out-history",
        &zmp_suites::history::render(&rows),
    );
}

fn frac(x: (usize, usize)) -> f64 {
    if x.1 == 0 {
        1.0
    } else {
        x.0 as f64 / x.1 as f64
    }
}

fn check(outcomes: &[Outcome]) -> Vec<String> {
    let s = scores(outcomes);
    let mut bad = Vec::new();
    let mut at_least = |what: &str, x: (usize, usize), min: f64| {
        if frac(x) < min {
            bad.push(format!("{what}: {x:?} < {min}"));
        }
    };
    at_least("single effects named", s.singles, MIN_SINGLES);
    at_least("clean without a false effect", s.clean, MIN_CLEAN);
    at_least("pairs and triples found", s.multiples, MIN_MULTIPLES);
    at_least("outside unexplained", s.outside, MIN_OUTSIDE);
    at_least("outside residual described", s.words, MIN_WORDS);
    let mut at_most = |what: &str, x: (usize, usize), max: f64| {
        if x.1 > 0 && frac(x) > max {
            bad.push(format!("{what}: {x:?} > {max}"));
        }
    };
    at_most(
        "in-catalogue draws with a false effect",
        s.false_alarms,
        MAX_FALSE,
    );
    at_most(
        "in-catalogue draws ending ambiguous",
        s.ambiguous,
        MAX_AMBIGUOUS,
    );
    if s.closed.0 < s.closed.1 {
        bad.push(format!(
            "in-catalogue draws within 2x the floor after the loop, fewer than all: {:?}",
            s.closed
        ));
    }
    bad
}

#[test]
#[ignore = "300 draws, hours on 2 cores (or sharded: cargo xtask suite): run once, by hand, with ZMP_UPDATE_DOCS=1 (cargo test --release -p zmp-suites --test blind_independent held_out -- --ignored); it writes the book's table and appends its row to the held-out record"]
fn held_out_blind_suite_on_an_independent_simulator() {
    let (outcomes, table, took) = suite_job(Range::HeldOut, Some(HELD_OUT_FIRST_SEED));
    assert_eq!(outcomes.len(), 300);
    println!("{table}");
    doc_section("docs/src/suites.md", "blind-independent:held-out", &table);
    if std::env::var(zmp_files::sections::UPDATE_VAR).is_ok_and(|v| v == "1") {
        record_range(HELD_OUT_FIRST_SEED, &outcomes, took);
    }
    let bad = check(&outcomes);
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// A range as a job of `cargo xtask suite` (the job folder, its unit files and their merge,
/// `zmp_suites::sharded::render`): with `ZMP_SUITE_JOB=DIR`, the complete job a `cargo xtask
/// suite --range RANGE --out DIR` run left there (in one process or in shards on a cluster,
/// resumed as often as it took) is merged, and the run's minutes are not known here (`None`);
/// otherwise every draw runs here, in a temporary job folder, and the minutes are this run's.
/// The table is the merge's either way, the same bytes.
fn suite_job(range: Range, first_seed: Option<u64>) -> (Vec<Outcome>, String, Option<Duration>) {
    let tmp = tempfile::tempdir().unwrap();
    let started = Instant::now();
    let (dir, took) = match std::env::var_os("ZMP_SUITE_JOB") {
        Some(d) => (std::path::PathBuf::from(d), None),
        None => {
            let (job, cases) = zmp_suites::sharded::job(range, first_seed).unwrap();
            let dir = tmp.path().join("job");
            zmp_shard::open_job(&dir, &job).unwrap();
            let opts = zmp_shard::RunOptions {
                shard: zmp_shard::Shard::WHOLE,
                only: None,
                keep_done: false,
                steal: false,
                threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
                quiet: false,
            };
            zmp_shard::run_units(&dir, &job, &opts, |u| {
                let case = cases
                    .iter()
                    .find(|c| zmp_suites::sharded::unit_id(c) == u.id)
                    .unwrap();
                zmp_suites::sharded::run_unit(case)
            })
            .unwrap();
            (dir, Some(started.elapsed()))
        }
    };
    let c = zmp_shard::collect(&dir).unwrap_or_else(|e| panic!("{e:#}"));
    let (job_range, job_first) = zmp_suites::sharded::job_range(&c.job).unwrap();
    assert_eq!(job_range, range, "{}: not a {range} job", dir.display());
    if let Some(first) = first_seed {
        assert_eq!(job_first, Some(first), "{}: another range", dir.display());
    }
    assert!(
        c.complete(),
        "{}: the job is not complete: {}",
        dir.display(),
        c.problems_text(&format!(
            "cargo xtask suite --range {range} --resume --out DIR"
        ))
    );
    let outcomes: Vec<Outcome> = c
        .done
        .iter()
        .map(|d| serde_json::from_value(d.outcome.clone()).unwrap())
        .collect();
    for o in &outcomes {
        println!("{}  [{}]", line(o), o.truth);
    }
    let merged = zmp_suites::sharded::render(&c).unwrap();
    (outcomes, merged.text, took)
}

#[test]
#[ignore = "development seeds 1-300, hours on 2 cores: run by hand (cargo test --release -p zmp-suites --test blind_independent development -- --ignored), or merge a `cargo xtask suite --range development` job with ZMP_SUITE_JOB=DIR"]
fn development_blind_suite_on_an_independent_simulator() {
    let (outcomes, table, _) = suite_job(Range::Development, None);
    println!("{table}");
    doc_section(
        "docs/src/suites.md",
        "blind-independent:development",
        &table,
    );
    let bad = check(&outcomes);
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}
