//! The loop names no effect the data do not need. Two draws of the development range of
//! `zmp-indep-sim` (a simulator sharing no code with this crate) where it used to:
//!
//! * seed 38, Coulomb friction and a sensor low-pass: a structural mode was added first, then
//!   the low-pass and the friction, which left the mode nothing to do; backward elimination
//!   (`select::prune`) now drops it.
//! * seed 24, a sensor low-pass alone: a play of a few hundredths of a millimetre was added
//!   for a misfit of the 8 mm sines, though the 3 mm and 8 mm sines respond alike; play and
//!   friction are now named only when the small sines respond less or later beyond the noise
//!   (`evidence::amplitude_dependence`).
//!
//! And draws where it named too little: seed 970010 of the spent held-out range, play alone on
//! a saturating robot. The play took the held-out error from 1.6x to 1.3x the noise floor
//! (more than half the excess error) but removed only 6 % of the excess chi-square, which the
//! few lowest-noise records dominate with a misfit of something else; the search's test
//! asked for 10 % and the loop ended at 2.7x with nothing found. The test now also takes half
//! of the excess error (`select::MIN_ERROR_FRACTION`). Seed 1030039 lost a delay to a
//! structural mode in the swap pass, and seed 1060035 a delay beside play where the play alone
//! already explained the data (both below). Seed 1160031 (spent held-out, examined after its
//! range), a play of 0.3 mm beside an operating-point dependence: the amplitude contrast did not
//! show the play because three pairs whose 8 mm sine the force limit clamps outweighed the
//! others; such pairs are left out of the contrast now.

use zmp_models::EffectKind;
use zmp_suites::indep_loop;

use indep_loop::loop_on;

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn an_effect_the_later_ones_made_redundant_is_dropped() {
    let r = loop_on(38, "pair:coulomb_friction,sensor_lowpass");
    for truth in [EffectKind::CoulombFriction, EffectKind::SensorLowpass] {
        assert!(r.found.iter().any(|f| f == truth), "found {:?}", r.found);
    }
    // Once the friction and the low-pass are in, a play takes 53 % of the excess held-out
    // chi-square left, but that excess is at the noise (1.76 per component): nothing more is
    // added past "explained" (`select::dominates`).
    for absent in [EffectKind::StructuralMode, EffectKind::Backlash] {
        assert!(!r.found.iter().any(|f| f == absent), "found {:?}", r.found);
    }
    assert!(r.explained, "final {:.2}x", r.final_error / r.noise_floor);
    assert!(r.final_error <= 1.5 * r.noise_floor);
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn play_is_not_named_when_small_and_large_sines_respond_alike() {
    let r = loop_on(24, "single:sensor_lowpass");
    assert!(
        r.found.iter().any(|f| f == EffectKind::SensorLowpass),
        "found {:?}",
        r.found
    );
    assert!(
        !r.found.iter().any(|f| f == EffectKind::Backlash),
        "found {:?}",
        r.found
    );
    // The play was fitted and scored (it is in what the diagnosis tried), not left out.
    assert!(
        r.diagnoses
            .iter()
            .any(|d| d.tried.iter().any(|(e, _)| e == EffectKind::Backlash)),
        "backlash never tried"
    );
    assert!(r.explained, "final {:.2}x", r.final_error / r.noise_floor);
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn play_is_named_when_only_the_clamped_pairs_hid_its_amplitude_dependence() {
    let r = loop_on(1_160_031, "pair:backlash,operating_point_dependence");
    let mut found = r.found.clone();
    found.sort();
    assert_eq!(
        found,
        [EffectKind::Backlash, EffectKind::OperatingPointDependence]
    );
    // Before, the loop ended `unexplained` at 0.52x the floor.
    assert!(r.explained, "final {:.2}x", r.final_error / r.noise_floor);
    assert!(r.final_error <= 0.4 * r.noise_floor);
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn an_effect_that_removes_most_of_the_error_is_taken_though_the_chi_square_is_elsewhere() {
    let r = loop_on(970_010, "single:backlash");
    assert_eq!(
        r.found.first().map(String::as_str),
        Some("backlash"),
        "found {:?}",
        r.found
    );
    assert!(
        r.final_error <= 1.5 * r.noise_floor,
        "final {:.2}x",
        r.final_error / r.noise_floor
    );
    assert!(r.identified_error > 2.0 * r.noise_floor);
}

/// Seed 1030039 of the spent held-out range: a 76 ms delay beside play and sensor drift. The
/// search named the drift, the delay and the play; the swap pass then put a structural mode in
/// the delay's place for a held-out chi-square 3 % lower (2489 against 2574) and the delay was
/// lost. A more complex effect now takes another's place only by more than the tie slack by
/// which a simpler one wins (`select::swap`). Every effect must be found and nothing else.
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_delay_is_not_swapped_for_a_mode_that_fits_a_little_better() {
    let r = loop_on(1_030_039, "triple:time_delay,backlash,sensor_drift");
    let mut found = r.found.clone();
    found.sort();
    assert_eq!(
        found,
        [
            EffectKind::Backlash,
            EffectKind::SensorDrift,
            EffectKind::TimeDelay
        ],
        "found {:?}",
        r.found
    );
    assert!(r.final_error < 2.0 * r.noise_floor);
}

/// Seed 1060035 of the spent held-out range: a 23 ms delay beside play. The play alone
/// explains the data (1.07x the floor, 4.67 per component, under the 5 of "explained") and
/// the search used to stop there; the delay then removes 83 % of the excess held-out
/// chi-square left, which an effect the data do not have does not (13-25 % on the draws where
/// the search went on past "explained" with its test alone). The search now goes on past
/// "explained" for such an effect (`select::dominates`), and says so in the evidence.
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn past_explained_an_effect_that_removes_most_of_what_is_left_is_added() {
    let r = loop_on(1_060_035, "pair:time_delay,backlash");
    let mut found = r.found.clone();
    found.sort();
    assert_eq!(
        found,
        [EffectKind::Backlash, EffectKind::TimeDelay],
        "found {:?}",
        r.found
    );
    let delay = r
        .diagnoses
        .iter()
        .flat_map(|d| &d.findings)
        .find(|f| f.effect == EffectKind::TimeDelay && f.significant)
        .expect("the delay's finding");
    assert!(
        delay
            .evidence
            .contains("added though the model without it explains the data"),
        "{}",
        delay.evidence
    );
    assert!(r.explained, "final {:.2}x", r.final_error / r.noise_floor);
}
