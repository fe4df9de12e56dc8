//! The CI subset of the out-of-sample suite (issue 55, item 7): the 12 draws of the
//! development range that `zmp_suites::sharded::ci_subset` derives from the composition (the
//! first draw of each kind: six singles, a pair, the two pairs built to be ambiguous, a
//! triple, a clean robot, an effect outside the catalogue), each run as a unit of
//! `cargo xtask suite` runs it (`zmp_suites::indep::run_case`: the simulator's campaign, the
//! loop on one thread, and for an `ambiguous` end the designed experiment on the same robot
//! and the loop again), each with the target on its outcome:
//!
//! - a single effect the diagnosis must add: named first; one the seed's structure carries
//!   (saturation): nothing false added, explained;
//! - a clean robot: no false effect;
//! - a pair or a triple: every hidden effect found, or the truth inside an `ambiguous` set of
//!   at most three;
//! - outside the catalogue: `unexplained`;
//! - a pair built to be ambiguous: the truth named alone, after the designed experiment when
//!   the loop ended `ambiguous`.
//!
//! One test per draw, so that a draw whose outcome is wrong (a finding about the method,
//! reported, never hidden by swapping the draw) is ignored alone, naming why. The subset costs
//! far more than CI's budget of about 5 minutes (its draws took 53-610 s each, wall, two at a
//! time on a loaded 2-core machine; the triple 222 s of CPU): CI runs the two cheapest, a
//! single effect (10 s of CPU) and a clean robot (19 s); the others are `long` and run with
//! `cargo xtask ci --long`
//! (`cargo test --release -p zmp-suites --test ci_subset -- --include-ignored --nocapture`
//! runs all twelve and prints each one's line, wall and CPU time).

use zmp_suites::indep::{line, run_case, Case, Class, Composition, Outcome};
use zmp_suites::sharded::{ci_subset, DEVELOPMENT_FIRST_SEED};

/// The CI subset's draw of the kind `pick` selects (exactly one).
fn ci_case(pick: impl Fn(&Case) -> bool) -> Case {
    let v: Vec<Case> = ci_subset(DEVELOPMENT_FIRST_SEED, &Composition::RANGE)
        .into_iter()
        .filter(|c| pick(c))
        .collect();
    assert_eq!(v.len(), 1, "{v:?}");
    v.into_iter().next().unwrap()
}

/// CPU time of this thread so far, s (`/proc/thread-self/stat`: user and system clock ticks,
/// 100 per second on Linux), or `None` where there is no such file. The draw runs on this
/// thread alone (`run_case` gives the loop one thread), so its CPU time is what the draw costs
/// on a free core, whatever else the machine runs; the wall time is printed beside it.
fn thread_cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").ok()?;
    // The fields after the command name (in parentheses, which may hold spaces).
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Runs the draw and asserts the target for its kind.
fn run_and_check(pick: impl Fn(&Case) -> bool) -> Outcome {
    let case = ci_case(pick);
    let dir = tempfile::tempdir().unwrap();
    let cpu = thread_cpu_s();
    let o = run_case(&case, dir.path()).unwrap();
    let cpu = thread_cpu_s().zip(cpu).map(|(b, a)| b - a);
    println!(
        "{}  (CPU {} s)",
        line(&o),
        cpu.map_or("?".into(), |c| format!("{c:.0}"))
    );
    let target = match o.case.class {
        Class::AmbiguousPair => o.named_alone(),
        _ => o.right(),
    };
    assert!(
        target,
        "draw {} missed its target: {}",
        o.case.seed,
        line(&o)
    );
    o
}

fn single(e: &'static str) -> impl Fn(&Case) -> bool {
    move |c| c.class == Class::Single(e.into())
}

#[test]
#[ignore = "long: 242 s wall on the loaded 2-core machine (2026-12-07); run by cargo xtask ci --long"]
fn ci_single_time_delay_named_first() {
    run_and_check(single("time_delay"));
}

#[test]
#[ignore = "long: 610 s wall on the loaded 2-core machine (2026-12-07); run by cargo xtask ci --long; it reached the 600 s time limit"]
fn ci_single_backlash_named_first() {
    run_and_check(single("backlash"));
}

#[test]
#[ignore = "long: 418 s wall on the loaded 2-core machine (2026-12-07); run by cargo xtask ci --long"]
fn ci_single_coulomb_friction_named_first() {
    run_and_check(single("coulomb_friction"));
}

#[test]
#[ignore = "long: 240 s wall on the loaded 2-core machine (2026-12-07); run by cargo xtask ci --long"]
fn ci_single_acceleration_saturation_carried() {
    run_and_check(single("acceleration_saturation"));
}

#[test]
#[ignore = "known failure: the loop names sensor_lowpass and backlash and ends unexplained at 3.56x the floor (67 s wall, 44 s CPU, 2026-12-07, at 85635be): no structure with the mode is admissible"]
fn ci_single_structural_mode_named_first() {
    run_and_check(single("structural_mode"));
}

#[test]
fn ci_single_sensor_lowpass_named_first() {
    run_and_check(single("sensor_lowpass"));
}

#[test]
#[ignore = "long: 263 s wall on the loaded 2-core machine (2026-12-07); run by cargo xtask ci --long"]
fn ci_pair_found() {
    run_and_check(|c| c.class == Class::Pair);
}

#[test]
#[ignore = "long: 358 s wall, 222 s CPU (2026-12-07; in an earlier run under more load it reached the 600 s wall-clock limit and missed the delay); run by cargo xtask ci --long"]
fn ci_triple_found() {
    run_and_check(|c| c.class == Class::Triple);
}

#[test]
fn ci_clean_without_false_effect() {
    run_and_check(|c| c.class == Class::Clean);
}

#[test]
#[ignore = "long: 70 s wall, 45 s CPU beside CI on the 2-core machine (2026-12-07, at 85635be); run by cargo xtask ci --long"]
fn ci_outside_unexplained() {
    run_and_check(|c| matches!(c.class, Class::Outside(_)));
}

#[test]
#[ignore = "long: 141 s wall, 91 s CPU beside CI on the 2-core machine (2026-12-07, at 85635be: both effects named, explained at 1.04x the floor); run by cargo xtask ci --long"]
fn ci_delay_beside_play_named_alone_after_the_designed_experiment() {
    run_and_check(|c| c.scenario == "pair:time_delay,backlash");
}

#[test]
#[ignore = "long: 173-493 s wall, 103 s CPU (2026-12-07; both effects named at once, the loop did not end ambiguous); run by cargo xtask ci --long"]
fn ci_friction_beside_lowpass_named_alone_after_the_designed_experiment() {
    run_and_check(|c| c.scenario == "pair:coulomb_friction,sensor_lowpass");
}
