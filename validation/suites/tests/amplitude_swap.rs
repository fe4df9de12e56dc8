//! Friction or play: the loop's look at the other amplitude law (`iterate::amplitude_swap`),
//! on data this project did not make (`zmp-indep-sim`, no physics code shared with
//! `zmp-models`).
//!
//! To first order a friction in a servo and a play are one law (a dead band of about
//! `2 F / wn^2`), and the search compares a friction in the servo with a play on the command.
//! The look fits the other law in place of the one named (a play also inside its servo), both
//! fitted on while they descend, and keeps the better by the search's swap rule.
//!
//! Development seed 20, a lone play the search names a friction first (1.07x the noise
//! floor; the play inside its servo 0.53x, held-out chi-square 788 against 2685), is held by
//! `tests/play_in_servo.rs` (`the_loop_moves_the_play_it_found_inside_the_servo`: the play
//! alone, inside the servo, within 0.8x the floor, widths within 15 %); one loop on that draw
//! is enough for the suite.

use zmp_models::EffectKind;
use zmp_suites::indep_loop;

use indep_loop::loop_and_robot;
use zmp_diagnose::iterate::LoopResult;
use zmp_indep_sim::{AxisMechanics, Robot};
use zmp_models::{Axis, Binding};

/// Spent held-out draw 1180029 (examined after its range): frictions of 0.17 and 0.25 m/s²
/// beside a sensor low-pass at 16 and 19 rad/s, in a servo that saturates. The search named a
/// play on the command beside the low-pass; the friction, fitted on, replaced it, with its
/// levels near the drawn ones. Since a friction's limit that the fit left idle is restarted
/// below the demand, the search names the friction itself, stopped by the joint budget at
/// 0.141 and 0.208 m/s2; the look at the other law keeps it and fits it on (change `refit`).
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_friction_named_play_beside_a_low_pass_is_named_friction() {
    let (r, robot) = loop_and_robot(1_180_029, "pair:coulomb_friction,sensor_lowpass");
    let mut found = r.found.clone();
    found.sort();
    assert_eq!(
        found,
        [EffectKind::CoulombFriction, EffectKind::SensorLowpass]
    );
    assert!(!r.final_model.has(EffectKind::Backlash));
    indep_loop::assert_final_within(&r, 2.0);
    // Tolerance set after its run (fitted 0.167 and 0.244 m/s², drawn 0.172 and 0.252).
    assert_each_axis_within(
        &r,
        &robot,
        EffectKind::CoulombFriction,
        "level",
        0.15,
        |axis| axis.friction.as_ref().expect("a drawn friction").kinetic,
    );
}

/// Spent held-out draws 1220001 and 1230010 (examined after their ranges), lone plays: the
/// search named a friction first, a mode beside it, then a play, and every later fit on that
/// model simulated the friction at every record (1220001 ran over 40 minutes in the play's
/// refit inside its servo; 1230010 reached the suite's 600 s limit unexplained at 1.65x with
/// the friction and the mode). The play is now tried in the friction's place as soon as the
/// friction is added (once per loop), and the next round searches on top of it.
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_play_named_friction_first_takes_its_place_before_the_search_goes_on() {
    let (r, robot) = loop_and_robot(1_220_001, "single:backlash");
    assert_eq!(r.found, [EffectKind::Backlash]);
    assert!(!r.final_model.has(EffectKind::CoulombFriction));
    assert!(
        !r.final_model.has(EffectKind::StructuralMode)
            && !r.final_model.has(EffectKind::FlexibleTrunk)
    );
    // The swap is the version right after the friction's.
    let changes: Vec<&str> = r.versions.iter().map(|(_, a)| a.change.as_str()).collect();
    assert_eq!(
        changes[..2],
        ["+coulomb_friction", "backlash-for-coulomb_friction"],
        "{changes:?}"
    );
    // Tolerance set after its run (0.91x; the friction, the mode and the play left 0.7x only
    // after the 40 minutes).
    indep_loop::assert_final_within(&r, 1.2);
    assert!(!r.time_limit_reached);
    // Tolerance set after its run (fitted 0.73 and 0.85 mm, drawn 0.80 on both).
    assert_each_axis_within(&r, &robot, EffectKind::Backlash, "width", 0.15, |axis| {
        axis.transmission.as_ref().expect("a drawn play").play
    });
}

/// Asserts that `kind.param` of the loop's final model lies within `tol` (relative) of the
/// drawn robot's value (`drawn` of its axis) on both axes.
fn assert_each_axis_within(
    r: &LoopResult,
    robot: &Robot,
    kind: EffectKind,
    param: &str,
    tol: f64,
    drawn: impl Fn(&AxisMechanics) -> f64,
) {
    let bindings = [Binding::Axis(Axis::X), Binding::Axis(Axis::Y)];
    for (k, axis) in robot.axes.iter().enumerate() {
        let got = r
            .final_model
            .value(kind, bindings[k], param)
            .unwrap_or_else(|| panic!("axis {k}: no {kind}.{param}"));
        let want = drawn(axis);
        assert!(
            (got - want).abs() <= tol * want,
            "axis {k}: {kind}.{param} {got:.5} against the drawn {want:.5}"
        );
    }
}
