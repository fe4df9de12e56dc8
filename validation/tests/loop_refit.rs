//! The loop takes the model's own structure refitted as a version when that alone explains the
//! data. On a saturating robot of `zmp-indep-sim` (a simulator sharing no code with this
//! crate; seed 940012 of the spent held-out range, a hidden acceleration limit and nothing
//! else), the identification keeps the seed's servo low-pass (30 rad/s, damping 1) and ends
//! at about 2x the noise floor; the diagnosis finds that refitting the same structure (the
//! low-pass and the limit moved) explains the data. Before the loop adopted that refit it
//! stopped there and reported `unexplained`.
//!
//! The second draw: seed 960020 of the spent held-out range, Coulomb friction in both joints:
//! the identification set the acceleration limit at 0.51 m/s2 against the robot's 1.31, the
//! model scored 19.3x its floor, the refit 1.3x, and the loop (before it took such refits)
//! stopped at 19.3x. From then until the third harmonic entered the chi-square (0c42746) the
//! loop's first version there was that refit, which does not explain the data but removes most
//! of its error; now the friction's own odd harmonics make it win the first step outright, so
//! the draw tests that the loop gets from 19.3x to within 2x either way, naming the friction,
//! with the refit still reported by the first diagnosis.

#[path = "support/indep_loop.rs"]
mod indep_loop;

use indep_loop::loop_on;
use zmp_validation::diagnose::augment::Augmented;
use zmp_validation::diagnose::iterate::LoopResult;

/// The loop's versions that refit the structure without adding an effect.
fn refit_versions(r: &LoopResult) -> Vec<&Augmented> {
    r.versions
        .iter()
        .filter(|(added, aug)| added.is_empty() && aug.change == "refit")
        .map(|(_, aug)| aug)
        .collect()
}

#[test]
fn the_loop_adopts_the_refitted_structure_when_it_explains_the_data() {
    let r = loop_on(940_012, "single:acceleration_saturation");
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
            "tracking_lowpass",
            zmp_models::Binding::Axis(zmp_models::Axis::X),
            "omega_n",
        )
        .unwrap();
    assert!((wn - 30.0).abs() > 1.0, "omega_n {wn}");
}

#[test]
fn the_loop_gets_a_badly_identified_friction_robot_near_its_floor() {
    let r = loop_on(960_020, "single:coulomb_friction");
    let floor = r.noise_floor;
    assert!(
        r.identified_error > 5.0 * floor,
        "identified at {:.2}x the floor: this draw no longer tests the refit",
        r.identified_error / floor
    );
    // The hidden friction is named (the loop's first version, or after a refit).
    assert_eq!(
        r.found,
        vec!["coulomb_friction".to_string()],
        "{:?}",
        r.found
    );
    let first = &r.versions[0].1;
    assert!(
        first.error_after < 0.2 * first.error_before,
        "first version: {:.4} -> {:.4}",
        first.error_before,
        first.error_after
    );
    // The loop's last model is within 2x the floor (it ended at 19.3x).
    assert!(
        r.final_error < 2.0 * floor,
        "final error {:.2}x the floor",
        r.final_error / floor
    );
    // The first diagnosis names the friction, judged against the structure refitted first.
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
