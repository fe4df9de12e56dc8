//! The loop takes the model's own structure refitted as a version when that alone explains the
//! data. On a saturating robot of `zmp-indep-sim` (a simulator sharing no code with this
//! crate; seed 940012 of the spent held-out range, a hidden acceleration limit and nothing
//! else), the identification of that day kept the seed's servo low-pass (30 rad/s, damping 1)
//! and ended at about 2x the noise floor; the diagnosis found that refitting the same
//! structure (the low-pass and the limit moved) explains the data. Before the loop adopted
//! that refit it stopped there and reported `unexplained`. The identification now gets this
//! draw right by itself (0.87x, its force-limit search starting from a grid, below), so the
//! test holds the low-pass at the seed's value (`IdentifyOptions::fix_bandwidth`), which
//! recreates that start.
//!
//! The second draw: seed 960020 of the spent held-out range, Coulomb friction in both joints:
//! the identification set the acceleration limit at 0.51 m/s2 against the robot's 1.31, the
//! model scored 19.3x its floor, the refit 1.3x, and the loop (before it took such refits)
//! stopped at 19.3x. Later the friction's own odd harmonics made it win the first step
//! outright, and the loop got from 19.3x to within 2x, naming the friction. Since the limit
//! search starts from a grid (`identify::saturation_limit::bracket`, made on held-out draw
//! 1120002, where Brent's method alone had settled in the same kind of shallow valley) the
//! identification finds the limit itself and the draw tests that.

use zmp_models::EffectKind;
use zmp_suites::indep_loop;

use indep_loop::{loop_on, loop_with};
use zmp_diagnose::augment::Augmented;
use zmp_diagnose::iterate::LoopResult;
use zmp_identify::IdentifyOptions;

/// The loop's versions that refit the structure without adding an effect.
fn refit_versions(r: &LoopResult) -> Vec<&Augmented> {
    r.versions
        .iter()
        .filter(|(added, aug)| added.is_empty() && aug.change == "refit")
        .map(|(_, aug)| aug)
        .collect()
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn the_loop_adopts_the_refitted_structure_when_it_explains_the_data() {
    let r = loop_with(
        940_012,
        "single:acceleration_saturation",
        None,
        &IdentifyOptions {
            given_bandwidth: Some((30.0, 1.0)),
            fix_bandwidth: true,
            ..IdentifyOptions::default()
        },
    );
    let floor = r.noise_floor;
    // The case this test is about: the identified model does not explain the data.
    assert!(
        r.identified_error > 1.5 * floor,
        "identified at {:.2}x the floor: this draw no longer tests the refit",
        r.identified_error / floor
    );
    // No effect is added (the limit is the seed's own structure) ...
    assert!(r.found.is_empty(), "effects added: {:?}", r.found);
    // ... the refit is a version of its own ...
    let refits = refit_versions(&r);
    assert_eq!(refits.len(), 1, "versions: {:?}", r.versions.len());
    let aug = refits[0];
    assert!(aug.error_after < 0.6 * aug.error_before);
    // ... and the loop ends explained, within 1.5x the floor.
    assert!(r.explained, "final error {:.2}x", r.final_error / floor);
    assert!(r.final_error <= 1.5 * floor);
    // The refit moved the servo's low-pass off the seed's 30 rad/s, damping 1.
    let wn = r
        .final_model
        .value(
            EffectKind::TrackingLowpass,
            zmp_models::Binding::Axis(zmp_models::Axis::X),
            "omega_n",
        )
        .unwrap();
    assert!((wn - 30.0).abs() > 1.0, "omega_n {wn}");
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_friction_robot_once_badly_identified_is_identified_and_its_friction_named() {
    let r = loop_on(960_020, "single:coulomb_friction");
    let floor = r.noise_floor;
    // The limit: 0.51 m/s2 once, against the robot's 1.31.
    let limit = r
        .identification
        .saturation
        .limit
        .expect("a limit estimated");
    assert!((limit / 1.31 - 1.0).abs() < 0.05, "limit {limit:.3} m/s2");
    // The identified model was at 19.3x the floor.
    assert!(
        r.identified_error < 2.0 * floor,
        "identified at {:.2}x the floor",
        r.identified_error / floor
    );
    // The hidden friction is named, and nothing else.
    assert_eq!(
        r.found,
        vec![EffectKind::CoulombFriction.to_string()],
        "{:?}",
        r.found
    );
    assert!(
        r.final_error < 1.5 * floor,
        "final error {:.2}x the floor",
        r.final_error / floor
    );
    let first = &r.diagnoses[0];
    assert!(
        first.findings[0].evidence.contains("Coulomb friction"),
        "{:?}",
        first
            .findings
            .iter()
            .map(|f| &f.evidence)
            .collect::<Vec<_>>()
    );
}
