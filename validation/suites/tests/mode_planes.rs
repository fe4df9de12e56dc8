//! A structural mode in each plane, on data this project did not make: draws of the independent
//! simulator (`zmp-indep-sim`, no physics code shared with `zmp-models`) whose trunk rings on a
//! flexible link in x and in y, each plane at its own frequency (drawn from 10-35 rad/s, so one
//! is often above the sweep's 15), on the seed's saturating robot.
//!
//! The mode candidate fitted the two planes' links together only from a shared starting
//! frequency; a mode inside the sweep and one above it were then never both reached, the plane
//! whose mode was missed took a delay instead, and the loop ended unexplained (held-out draw
//! 1140013: x at 12.3 rad/s, y at 18.3; a delay of 43 ms on y, 1.85x the noise floor; the drawn
//! structure refitted: 0.8x). The candidate now also starts the two links at every pair of
//! different upper frequencies, and a link whose share of the mass ends at its floor is not
//! taken for a mode.
//!
//! Draws: 1140013 (a held-out range already reported, examined after its one run) and 7302
//! (fresh development draws 7300-7309, outside every range the blind suite reports).

use zmp_models::EffectKind;
use zmp_suites::indep_loop;

use indep_loop::{assert_modes_within, loop_and_robot};

/// The loop names a structural mode and nothing else, ends explained within the noise floor,
/// and puts on each axis a mode within `tol` (relative) of the drawn one.
fn check(seed: u64, tol: f64) {
    let (r, robot) = loop_and_robot(seed, "single:structural_mode");
    assert!(
        !r.found.is_empty() && r.found.iter().all(|e| e == EffectKind::StructuralMode),
        "draw {seed}: found {:?}",
        r.found
    );
    assert!(
        r.explained && r.final_error <= r.noise_floor,
        "draw {seed}: explained {}, final {:.2}x the floor",
        r.explained,
        r.final_error / r.noise_floor
    );
    assert_modes_within(&r, &robot, [tol, tol], seed);
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_mode_inside_the_sweep_and_one_above_it_are_both_found() {
    check(1_140_013, 0.1);
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_plane_whose_mode_was_missed_no_longer_takes_a_delay() {
    check(7302, 0.1);
}
