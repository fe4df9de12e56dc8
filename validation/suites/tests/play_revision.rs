//! A delay beside a play, on data this project did not make: draws of the independent
//! simulator (`zmp-indep-sim`, no physics code shared with `zmp-models`) with a command latency
//! and a play in the transmission between drive and trunk, on the seed's saturating robot.
//!
//! The search names effects on top of a play on the CoM command; beside that law a damped
//! structural mode could stand for the delay (development draw 7100: a 73 ms delay, named as a
//! mode at 22 rad/s with a tracking low-pass at half the drawn servo's bandwidth, 0.59x the
//! noise floor), and a delay found there could be dropped when the loop moved the play inside
//! the servo (7101: a 17 ms delay, the play alone left at 1.66 per component). The loop now
//! judges the other effects again with the play inside its servo (`iterate::play_revision`)
//! and re-adds what the search had named on its own evidence (`iterate::readd`).
//!
//! Draws 7100-7109 are outside every range the blind suite reports (development 1-60,
//! held-out from 900000); 1160027 is a spent held-out draw, examined after its range; 11 is a
//! development seed whose mode inside the servo kept its play on the command.

use zmp_models::EffectKind;
use zmp_suites::indep_loop;

use indep_loop::loop_and_robot;
use zmp_models::{Axis, Binding};

/// The loop names the delay and the play and nothing else, the final model has the play
/// inside its servo, and each axis's fitted delay is within `tol` (relative) of the drawn one.
fn check(seed: u64, tol: f64) {
    let (r, robot) = loop_and_robot(seed, "pair:time_delay,backlash");
    let mut found = r.found.clone();
    found.sort();
    assert_eq!(
        found,
        [EffectKind::Backlash, EffectKind::TimeDelay],
        "draw {seed}"
    );
    assert!(
        r.explained && r.final_error <= 0.5 * r.noise_floor,
        "draw {seed}: final {:.2}x the floor",
        r.final_error / r.noise_floor
    );
    let bindings = [Binding::Axis(Axis::X), Binding::Axis(Axis::Y)];
    for (k, axis) in robot.axes.iter().enumerate() {
        let b = bindings[k];
        assert_eq!(
            r.final_model.value(EffectKind::Backlash, b, "in_servo"),
            Some(1.0),
            "draw {seed}: the play on axis {k} is not inside its servo"
        );
        let delay = r
            .final_model
            .value(EffectKind::TimeDelay, b, "delay")
            .expect("a delay on every axis");
        let drawn = axis.command_delay;
        assert!(
            (delay - drawn).abs() <= tol * drawn,
            "draw {seed}, axis {k}: delay {delay:.4} s against the drawn {drawn:.4} s"
        );
    }
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_mode_named_beside_the_play_on_the_command_gives_way_to_the_delay() {
    check(7100, 0.15);
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_delay_named_beside_the_play_on_the_command_stays_when_the_play_moves_into_the_servo() {
    check(7101, 0.3);
}

/// Spent held-out draw 1160027 (examined after its range): a 26 ms delay beside a 2.1 mm play.
/// The servo low-pass took the delay's lag (13.2 rad/s, damping 0.51 against the drawn 24 and
/// 0.96) and the loop ended with the play alone at the noise; the delay fitted from the seed's
/// servo (`iterate::absorbed_delay`) is named at 25-27 ms. Tolerance set after its run.
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_delay_the_servo_low_pass_absorbed_is_named_once_the_play_is_inside_the_servo() {
    check(1_160_027, 0.1);
}

/// Development seed 11 (a lone play of 0.30 and 0.31 mm in transmissions of 173 and
/// 127 rad/s). The loop named a mode inside the servo first (35-36 rad/s), and a servo drives
/// one link, so the play named next stayed on the command, and a delay of 0 ms came third:
/// unexplained at 1.06x the floor. Without the mode the play goes inside its servo (held-out
/// chi-square 16279 -> 982) and takes the mode's place alone; the zero delay, which does
/// nothing, is taken out (`iterate::vacuous`). Tolerances set after its run (0.39x; widths
/// 0.284 and 0.319 mm).
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_mode_that_kept_the_play_out_of_its_servo_gives_way_to_the_play_inside() {
    let (r, robot) = loop_and_robot(11, "single:backlash");
    assert_eq!(r.found, [EffectKind::Backlash]);
    assert!(
        r.explained && r.final_error <= 0.5 * r.noise_floor,
        "final {:.2}x the floor",
        r.final_error / r.noise_floor
    );
    assert!(
        !r.final_model.has(EffectKind::TimeDelay) && !r.final_model.has(EffectKind::FlexibleTrunk)
    );
    for (k, axis) in robot.axes.iter().enumerate() {
        let b = [Binding::Axis(Axis::X), Binding::Axis(Axis::Y)][k];
        assert_eq!(
            r.final_model.value(EffectKind::Backlash, b, "in_servo"),
            Some(1.0)
        );
        let width = r
            .final_model
            .value(EffectKind::Backlash, b, "width")
            .unwrap();
        let drawn = axis.transmission.as_ref().expect("a drawn play").play;
        assert!(
            (width / drawn - 1.0).abs() < 0.1,
            "axis {k}: play {width} against the drawn {drawn}"
        );
    }
}
