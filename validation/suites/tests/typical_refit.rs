//! A structural mode beside a command delay, on data this project did not make: draws of the
//! independent simulator (`zmp-indep-sim`, no physics code shared with `zmp-models`) whose
//! trunk rings on a flexible link in each plane while the CoM reference reaches the servo late,
//! on the seed's saturating robot.
//!
//! A mode and a delay both bend the phase; the loop adds one effect at a time, and the one
//! added first can absorb part of the other (a link fit that puts nearly all the mass on the
//! link, a servo low-pass slowed for it), so that the structure ends right but its fit stuck
//! where it began. Two changes: a link whose share of the mass ends at its cap is not taken for
//! a mode (`candidates::plausible`), and once the loop is done, a model with a mode that leaves
//! the data unexplained is refitted from typical values (`iterate::typical`). Fresh development
//! draws 7400-7409 of `pair:structural_mode,time_delay` (outside every range the blind suite
//! reports): before, 7400 ended unexplained at 0.92x the floor and 7409 at 6.86x with the
//! delay unnamed (now named, at 52 ms against the drawn 96, a sensor low-pass beside it: the
//! test asserts the mode frequencies, not the delay's value).
//!
//! The refit also starts with each mode at each upper starting frequency of the mode candidate
//! and with the delays cut to three tenths: spent held-out draw 1150030 (examined after its
//! range was run) has a y mode at 22.5 rad/s, above the sweep, that the loop fitted at 41.8
//! with delays of 46-49 ms standing in for it (2.20x the floor). And where the servo low-pass
//! lags more than the seed's, one start moves that extra lag to the delays: spent held-out draw
//! 1160041 (a mode per plane, a 75 ms delay, drift) ended at 2.18x with the servo at 16.6 rad/s
//! and delays of 16-17 ms. And it starts each mode at the sweep's frequencies and their middles,
//! under the model's law and inside the servo: spent held-out draw 1180004's lightly damped link
//! between two sweep frequencies. The tolerances below were set after seeing these draws' runs.

use zmp_models::EffectKind;
use zmp_suites::indep_loop;

use indep_loop::{assert_modes_within, loop_and_robot};
use zmp_diagnose::iterate::TYPICAL_REFIT;
use zmp_models::{Axis, Binding};

/// The loop names the mode and the delay, ends explained within `max_ratio` of the noise
/// floor with the typical refit as a version, and puts each plane's mode within 10 % of the
/// drawn frequency; returns the loop's result and the drawn robot.
fn check(seed: u64, max_ratio: f64) -> (zmp_diagnose::iterate::LoopResult, zmp_indep_sim::Robot) {
    let (r, robot) = loop_and_robot(seed, "pair:structural_mode,time_delay");
    for e in [EffectKind::StructuralMode, EffectKind::TimeDelay] {
        assert!(
            r.found.iter().any(|f| f == e),
            "draw {seed}: found {:?}",
            r.found
        );
    }
    assert!(
        r.versions
            .iter()
            .any(|(_, v)| v.change.starts_with(TYPICAL_REFIT)),
        "draw {seed}: no {TYPICAL_REFIT} version"
    );
    assert!(
        r.explained && r.final_error <= max_ratio * r.noise_floor,
        "draw {seed}: explained {}, final {:.2}x the floor",
        r.explained,
        r.final_error / r.noise_floor
    );
    assert_modes_within(&r, &robot, [0.1, 0.1], seed);
    (r, robot)
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_mode_and_a_delay_fitted_one_after_the_other_are_refitted_from_typical_values() {
    let _ = check(7400, 1.0);
}

/// Since the refit from typical values also starts without a sensor low-pass, the low-pass
/// named beside 7409's delay leaves, and the delay goes from 52 ms to 82 ms (drawn 96) at
/// 0.84x the floor (tolerance set after that run).
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_delay_a_link_had_absorbed_is_named_once_the_link_is_no_mode() {
    let (r, robot) = check(7409, 1.05);
    assert!(
        !r.final_model.has(EffectKind::SensorLowpass),
        "a sensor low-pass is left"
    );
    assert_delays_within(&r, &robot, 0.2);
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_mode_above_the_sweep_a_long_delay_stood_in_for_is_refitted_at_its_frequency() {
    let seed = 1_150_030;
    let (r, robot) = check(seed, 1.0);
    // And the delays come back to the drawn one (14 ms), not the 46-49 ms that took the mode.
    assert_delays_within(&r, &robot, 0.25);
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn the_lag_a_slow_servo_took_from_the_delay_goes_back_to_it() {
    let (r, robot) = loop_and_robot(1_160_041, "triple:structural_mode,time_delay,sensor_drift");
    for e in [
        EffectKind::StructuralMode,
        EffectKind::TimeDelay,
        EffectKind::SensorDrift,
    ] {
        assert!(r.found.iter().any(|f| f == e), "found {:?}", r.found);
    }
    assert!(
        r.versions.iter().any(|(_, v)| v.change == TYPICAL_REFIT),
        "no {TYPICAL_REFIT} version"
    );
    // Before: unexplained at 2.18x the floor.
    assert!(
        r.explained && r.final_error <= 1.1 * r.noise_floor,
        "explained {}, final {:.2}x the floor",
        r.explained,
        r.final_error / r.noise_floor
    );
    // The x mode inside the sweep within 5 %, the y one above it within 10 %.
    assert_modes_within(&r, &robot, [0.05, 0.1], 1_160_041);
}

/// Spent held-out draw 1180004 (examined after its range): a link per plane, at 25.0 and
/// 12.5 rad/s with damping 0.08 and 0.03, the second between the sweep's 9.8 and 15 rad/s.
/// The loop ended unexplained at 15.4x the floor with the y link at 15.7 rad/s, its damping at
/// the floor; the refit's starts at the sweep's frequencies and their middles, under both laws
/// (`iterate::typical`), reach 0.94x with the links at 24.8 and 12.52 rad/s inside the servo.
/// Tolerances set after its run.
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_lightly_damped_link_between_two_sweep_frequencies_is_refitted_at_its_own() {
    let (r, robot) = loop_and_robot(1_180_004, "single:structural_mode");
    assert_eq!(r.found, [EffectKind::StructuralMode]);
    assert!(
        r.versions.iter().any(|(_, v)| v.change == TYPICAL_REFIT),
        "no {TYPICAL_REFIT} version"
    );
    assert!(
        r.explained && r.final_error <= 1.0 * r.noise_floor,
        "explained {}, final {:.2}x the floor",
        r.explained,
        r.final_error / r.noise_floor
    );
    assert_modes_within(&r, &robot, [0.03, 0.01], 1_180_004);
}

/// Spent held-out draw 1200041 (examined after its range): a mode per plane, at 31.9 rad/s
/// (above the sweep) and 18.4, a 99 ms delay and drift, the servo at 39.8 rad/s. The
/// identification gave the delay's lag to a servo of 11.3 rad/s, damping 0.80; the loop named
/// near-undamped links at 19.1 and 16.5 rad/s and the drift, and the delay tried beside those
/// links removed 8 % of what was left: unexplained at 9.1x the floor. The delay fitted with
/// the structure made typical (the seed's servo, the servo's extra lag as the delay, the modes
/// also at the upper starts; `iterate::absorbed_delay`) removes 99 % (held-out chi-square
/// 107771 -> 2284), and with the links then inside the servo the model is at 0.80x.
/// Tolerances set after its run.
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_delay_a_slow_servo_took_beside_links_it_bent_is_fitted_with_the_structure_typical() {
    let seed = 1_200_041;
    let (r, robot) = loop_and_robot(seed, "triple:structural_mode,time_delay,sensor_drift");
    for e in [
        EffectKind::StructuralMode,
        EffectKind::TimeDelay,
        EffectKind::SensorDrift,
    ] {
        assert!(r.found.iter().any(|f| f == e), "found {:?}", r.found);
    }
    assert!(
        r.explained && r.final_error <= 1.0 * r.noise_floor,
        "explained {}, final {:.2}x the floor",
        r.explained,
        r.final_error / r.noise_floor
    );
    // Fitted 34.9 and 18.8 rad/s.
    assert_modes_within(&r, &robot, [0.12, 0.05], seed);
    // Fitted 92 ms on both axes (drawn 99).
    assert_delays_within(&r, &robot, 0.12);
}

/// Asserts that the final model's servo low-pass frequency lies within `tol` (relative) of the
/// drawn robot's.
fn assert_servo_within(
    r: &zmp_diagnose::iterate::LoopResult,
    robot: &zmp_indep_sim::Robot,
    tol: f64,
) {
    let servo = r
        .final_model
        .value(
            EffectKind::TrackingLowpass,
            Binding::Axis(Axis::X),
            "omega_n",
        )
        .unwrap();
    let drawn = robot.axes[0].servo.omega_n;
    assert!(
        (servo - drawn).abs() <= tol * drawn,
        "servo {servo:.2} rad/s against the drawn {drawn:.2}"
    );
}

/// Asserts that each axis's delay in the loop's final model lies within `tol` (relative) of
/// the drawn robot's command delay (a missing delay counts as zero).
fn assert_delays_within(
    r: &zmp_diagnose::iterate::LoopResult,
    robot: &zmp_indep_sim::Robot,
    tol: f64,
) {
    for (k, axis) in robot.axes.iter().enumerate() {
        let b = Binding::Axis([Axis::X, Axis::Y][k]);
        let got = r
            .final_model
            .value(EffectKind::TimeDelay, b, "delay")
            .unwrap_or(0.0);
        let want = axis.command_delay;
        assert!(
            (got - want).abs() <= tol * want,
            "axis {k}: delay {:.1} ms against the drawn {:.1}",
            got * 1e3,
            want * 1e3
        );
    }
}

/// Spent held-out draw 1210038 (examined after its range): a link per plane at 22.2 and
/// 17.2 rad/s, a 15 ms delay, limits of 1.82 m/s2, the servo at 29.0 rad/s and damping 0.83.
/// The loop gave the delay's lag to the servo (21.8 rad/s, 0.78), named the links as filters
/// of the reference with their damping at the floor and a limit, and ended unexplained at
/// 1.24x the floor, the 8 mm records at the top frequencies 6.3x theirs. The servo's lag was
/// no more than the seed's, so no delay was looked for. Now a model with a mode that leaves the
/// data unexplained is given the delay fitted with its structure made typical even so, under
/// both laws, with limits that never act restarted below the demand (the y limit stayed idle
/// at 2.71 otherwise, at 93 per component): 98 % of the excess removed (4474 -> 892), 0.89x.
/// Tolerances set after its run (fitted: servo 29.06 rad/s, delays 14.5 ms, links 21.7 and
/// 17.2 rad/s).
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_delay_a_servo_no_slower_than_the_seeds_took_is_found_beside_links() {
    let seed = 1_210_038;
    let (r, robot) = loop_and_robot(seed, "pair:structural_mode,time_delay");
    for e in [EffectKind::StructuralMode, EffectKind::TimeDelay] {
        assert!(r.found.iter().any(|f| f == e), "found {:?}", r.found);
    }
    assert!(
        r.explained && r.final_error <= 0.95 * r.noise_floor,
        "explained {}, final {:.2}x the floor",
        r.explained,
        r.final_error / r.noise_floor
    );
    assert_modes_within(&r, &robot, [0.05, 0.02], seed);
    assert_delays_within(&r, &robot, 0.08);
    assert_servo_within(&r, &robot, 0.03);
}

/// Spent held-out draw 1210022 (examined after its range): a lone link per plane, x at
/// 14.3 rad/s (damping 0.038), y at 23.6 (0.049, above the sweep), the servo at 35.0 rad/s.
/// The loop named the x link, a limit and a 5 ms delay and ended at 2.10x the floor with the
/// servo at 22.5 rad/s; the search's y mode scored 2.5x, and the refit from typical values
/// only re-typed the modes already there. It now also starts a typical link on each excited
/// plane without one (`iterate::typical`): both links within 1 % of the drawn, the servo
/// within 1 %, the delay taken out, 1.03x the floor. The draw still ends unexplained: the
/// 8 mm records at 15 rad/s, beside the x link's resonance, lose 9 % of their gain to the
/// force limit where the model loses none, 12x their floor (with the x limit restarted at
/// the drawn value the fit ends at the same chi-square). Tolerances set after its run.
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_second_planes_link_the_search_missed_is_started_by_the_typical_refit() {
    let seed = 1_210_022;
    let (r, robot) = loop_and_robot(seed, "single:structural_mode");
    assert!(
        r.versions.iter().any(|(_, v)| v.change == TYPICAL_REFIT),
        "no {TYPICAL_REFIT} version"
    );
    assert!(!r.final_model.has(EffectKind::TimeDelay), "a delay is left");
    assert!(
        r.final_error <= 1.1 * r.noise_floor,
        "final {:.2}x the floor",
        r.final_error / r.noise_floor
    );
    assert_modes_within(&r, &robot, [0.01, 0.01], seed);
    assert_servo_within(&r, &robot, 0.01);
}

/// Spent held-out draw 1210030 (examined after its range): a link per plane at 26.5 and
/// 29.1 rad/s (above the sweep), a 41 ms delay, the servo at 34.6 rad/s. The loop named a
/// mode, a delay and a sensor low-pass and ended unexplained at 1.64x the floor with the modes
/// on the ZMP path and delays of a few milliseconds: the low-pass held the delay's lag. The
/// refit from typical values now also starts without the low-pass, with the links inside the
/// servo and the delay at the delay candidate's starts (`iterate::typical`): the low-pass is
/// dropped from the model and the findings, 0.87x. Tolerances set after its run (fitted:
/// delays 37.5 ms, links 26.2 and 29.7 rad/s, servo 33.9 rad/s).
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_sensor_lowpass_that_held_a_delays_lag_beside_links_is_dropped() {
    let seed = 1_210_030;
    let (r, robot) = loop_and_robot(seed, "pair:structural_mode,time_delay");
    assert_eq!(r.found, [EffectKind::StructuralMode, EffectKind::TimeDelay]);
    assert!(
        !r.final_model.has(EffectKind::SensorLowpass),
        "a sensor low-pass is left"
    );
    assert!(
        r.versions
            .iter()
            .any(|(_, v)| v.change == format!("{TYPICAL_REFIT}-without-sensor_lowpass")),
        "no {TYPICAL_REFIT}-without-sensor_lowpass version"
    );
    assert!(
        r.explained && r.final_error <= 0.95 * r.noise_floor,
        "explained {}, final {:.2}x the floor",
        r.explained,
        r.final_error / r.noise_floor
    );
    assert_modes_within(&r, &robot, [0.03, 0.04], seed);
    assert_delays_within(&r, &robot, 0.15);
}

/// Spent held-out draw 1220038 (examined after its range): a link per plane at 14.5 and
/// 32.9 rad/s (the second above the sweep), delays of 67 and 47 ms, limits of 1.13 m/s2, the
/// servo at 31.0 rad/s. The loop named the x link and a sensor low-pass at 11-14 rad/s, with no
/// delay and no force limit, and ended unexplained at 7.45x the floor; the delay looked for
/// last removed 62 % of the excess chi-square, but the error did not fall. The refit without
/// the low-pass now gives its lag to a delay on each axis where the model has none, adds a
/// force limit below the demand where it has none and a typical link on the bare plane
/// (`iterate::typical`): 0.88x with delays of 66 and 47 ms, links at 14.7 and 30.9 rad/s and
/// the servo at 30.2 rad/s. Tolerances set after its run.
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_sensor_lowpass_that_stood_for_delays_is_replaced_by_them() {
    let seed = 1_220_038;
    let (r, robot) = loop_and_robot(seed, "pair:structural_mode,time_delay");
    for e in [EffectKind::StructuralMode, EffectKind::TimeDelay] {
        assert!(r.found.iter().any(|f| f == e), "found {:?}", r.found);
    }
    assert!(
        !r.final_model.has(EffectKind::SensorLowpass),
        "a sensor low-pass is left"
    );
    assert!(
        r.explained && r.final_error <= 0.95 * r.noise_floor,
        "explained {}, final {:.2}x the floor",
        r.explained,
        r.final_error / r.noise_floor
    );
    assert_modes_within(&r, &robot, [0.03, 0.08], seed);
    assert_delays_within(&r, &robot, 0.03);
}
