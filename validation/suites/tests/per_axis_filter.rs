//! A sensor low-pass fitted with one cutoff per axis. On a draw of the independent simulator
//! (`zmp-indep-sim`, no physics code shared with `zmp-models`): held-out draw 1010005 (spent),
//! whose two force sensors filter at 39.3 and 46.5 rad/s. With one cutoff shared by both axes
//! the fit put a 258 rad/s filter on x alone (1.4x the noise floor) and the loop named a
//! structural mode and a delay instead.

use zmp_models::EffectKind;
use zmp_suites::indep_loop;

use zmp_models::{Axis, Binding};

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn two_sensors_with_different_cutoffs_are_named_a_sensor_lowpass() {
    let r = indep_loop::loop_on(1_010_005, "single:sensor_lowpass");
    assert_eq!(
        r.found,
        vec![EffectKind::SensorLowpass.to_string()],
        "{:?}",
        r.found
    );
    assert!(r.explained, "final {:.2}x", r.final_error / r.noise_floor);
    assert!(
        r.final_error < 1.2 * r.noise_floor,
        "final {:.2}x the floor",
        r.final_error / r.noise_floor
    );
    // Each axis its own cutoff, near the drawn robot's (39.3 and 46.5 rad/s): the campaign
    // reaches 15 rad/s, so a cutoff is seen through a phase lag of 16-21 degrees at most.
    for (axis, truth) in [(Axis::X, 39.28), (Axis::Y, 46.51)] {
        let c = r
            .final_model
            .value(EffectKind::SensorLowpass, Binding::Axis(axis), "cutoff")
            .unwrap_or_else(|| panic!("no sensor_lowpass on {axis:?}"));
        assert!(
            (c / truth - 1.0).abs() < 0.15,
            "{axis:?} cutoff {c:.1} rad/s, drawn {truth}"
        );
    }
}
