//! The third harmonic as evidence: friction distorts the response (odd harmonics), a linear
//! effect of the same first-harmonic shape does not. On a draw of the independent simulator
//! (`zmp-indep-sim`, no physics code shared with `zmp-models`): held-out draw 1000011 (spent),
//! a Coulomb friction the loop of 22e304b left unfound (it ended explained at 1.48x the noise
//! floor on the first harmonic and trend alone) while identify flagged odd harmonics no model
//! predicted.

use zmp_models::EffectKind;
use zmp_suites::indep_loop;

use zmp_diagnose::iterate::LoopResult;
use zmp_diagnose::measure::{chi2_parts, predict};
use zmp_diagnose::observe::Observation;
use zmp_indep_sim::Robot;
use zmp_models::{Axis, Binding, ModelSpec};

/// Chi-square per component of the third-harmonic misfit, over the records where it is
/// compared (three times the frequency within the campaign's band), and those records.
fn third_chi2(model: &ModelSpec, obs: &[Observation]) -> (f64, usize) {
    let obs: Vec<&Observation> = obs.iter().collect();
    let [_, (chi2, n)] = chi2_parts(&obs, &predict(model, &obs).unwrap());
    (chi2 / n.max(1) as f64, n / 4)
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn friction_is_found_by_the_distortion_it_predicts() {
    let (r, robot) = indep_loop::loop_and_robot(1_000_011, "single:coulomb_friction");
    let (before, n) = third_chi2(&r.identification.model, &r.observations);
    // Compared on the records below a third of the top frequency: most of the campaign.
    assert!(
        n * 2 > r.observations.len(),
        "{n} of {}",
        r.observations.len()
    );
    // The identified model (saturation only) misses the distortion by several standard
    // errors per component ...
    assert!(
        before > 5.0,
        "identified: {before:.2} per third-harmonic component"
    );
    // The friction is named first; besides it only the seed's own force limit may be refitted
    // (`acceleration_saturation`, not a false effect: the seed's structure has it). Since the
    // limit search starts from a grid the identification puts this draw's limit at 1.400 m/s2
    // instead of 1.353 (drawn: 1.223; the friction's bend pulls both up). With the friction
    // fitted the servo demands less than 1.40 of its force: that limit never acts and no fit
    // moves it (the friction ended at 0.047 with a chi-square of 7 100, and a sensor low-pass
    // was named instead) unless it is restarted below the demand (`engine::fit_screened`).
    assert_eq!(
        r.found.first().map(String::as_str),
        Some("coulomb_friction"),
        "{:?}",
        r.found
    );
    assert!(
        r.found[1..]
            .iter()
            .all(|f| f == EffectKind::AccelerationSaturation),
        "{:?}",
        r.found
    );
    assert!(r.explained);
    // The drawn robot's friction (0.0658 and 0.0611 m/s2) and force limit (1.223 m/s2) come
    // back within 3 %.
    assert_friction_and_limit_drawn(&r, &robot, 0.03);
    // ... the friction's own third harmonic accounts for it, to about the noise.
    let (after, _) = third_chi2(&r.final_model, &r.observations);
    assert!(
        after < 2.0 && after < before / 3.0,
        "with friction: {after:.2} per third-harmonic component (identified {before:.2})"
    );
}

/// Spent held-out draw 1190020 (examined after its range): a lone friction of 0.175 and
/// 0.138 m/s2 in a servo of 39 rad/s that saturates at 1.30 m/s2. The identification's
/// pendulum, servo (31.6 rad/s) and limit (1.21) took up the friction's first harmonic, so the
/// friction's own fit, the rest held, fell to zero from both starts and the candidate was
/// screened out: the loop named a structural mode, then the friction, then swapped it for a
/// play (0.82x the noise floor, two effects, neither the drawn one alone). Fitted jointly from
/// its starts it is named alone, with the drawn values.
#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_friction_the_identification_absorbed_is_fitted_from_its_starts() {
    let (r, robot) = indep_loop::loop_and_robot(1_190_020, "single:coulomb_friction");
    assert_eq!(r.found, [EffectKind::CoulombFriction]);
    // Tolerance set after its run (0.78x).
    indep_loop::assert_final_within(&r, 1.0);
    // Fitted 0.1756 and 0.1382 (drawn 0.1753 and 0.1381).
    assert_friction_and_limit_drawn(&r, &robot, 0.03);
}

/// The final model's friction level and force limit on each axis within `tol` (relative) of
/// the drawn robot's.
fn assert_friction_and_limit_drawn(r: &LoopResult, robot: &Robot, tol: f64) {
    for (k, axis) in robot.axes.iter().enumerate() {
        let b = Binding::Axis([Axis::X, Axis::Y][k]);
        let level = r
            .final_model
            .value(EffectKind::CoulombFriction, b, "level")
            .unwrap();
        let drawn = axis.friction.as_ref().expect("a drawn friction").kinetic;
        assert!(
            (level / drawn - 1.0).abs() < tol,
            "axis {k}: friction {level} against {drawn}"
        );
        let limit = r
            .final_model
            .value(EffectKind::AccelerationSaturation, b, "limit")
            .unwrap();
        let drawn = axis.servo.accel_limit;
        assert!(
            (limit / drawn - 1.0).abs() < tol,
            "axis {k}: limit {limit} against {drawn}"
        );
    }
}
