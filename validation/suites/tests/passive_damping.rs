//! The saturation's passive damping (`acceleration_saturation.passive_damping`) on data this
//! project did not make: a draw of the independent simulator (`zmp-indep-sim`, no physics
//! code shared with `zmp-models`) whose backlash sits in a compliant transmission with a
//! dragging load. The drag acts on the load whatever the motor's force; the servo's force
//! limit does not bound it. Below the limit it is part of the servo's damping; at the fast,
//! large sines, where the force is clamped, it brakes further, and the seed's clamp alone
//! (`passive_damping = 0`) cannot follow those records.
//!
//! The diagnosis does not search the parameter (free in every refit it also explains a
//! rate-limited servo, outside the catalogue: README, "Effects"); a model that has one gets it
//! refitted with everything else. Here the user's start model has one.

use zmp_models::EffectKind;
use zmp_suites::indep_loop;

use indep_loop::loop_from;
use zmp_files::sections::check_page as doc_section;
use zmp_indep_sim::{draw_with, CouplingForm, Design, DrawOptions};
use zmp_models::{Axis, Binding, ModelSpec};

/// Single-backlash draws: development seed 11 (a play of 0.3 mm in 3 and 8 mm sines; the
/// blind suite's loop ends there unexplained at 2.1x the noise floor), on which the law was
/// found, and held-out seed 980001, examined after the one run of the 980000 range (the suite
/// ended it at 2.35x with nothing found), on which it was checked.
const DRAWS: [(u64, &str); 2] = [(11, "development"), (980_001, "held-out")];
const SCENARIO: &str = "single:backlash";

/// The drawn robot's drag as the CoM deceleration per unit speed, 1/s: the joint's viscous
/// drag `m_J / tau` over the axis's unit inertia (no flexible links: `m_J` is the load,
/// `1 - drive share`).
fn true_drag(seed: u64) -> [f64; 2] {
    let robot = draw_with(
        seed,
        &SCENARIO.parse().unwrap(),
        &Design::default(),
        &DrawOptions {
            coupling_form: Some(CouplingForm::Pendulum),
        },
    );
    [0, 1].map(|k| {
        let a = &robot.axes[k];
        assert!(a.modes.is_empty(), "the truth below assumes a rigid trunk");
        let t = a
            .transmission
            .as_ref()
            .expect("a backlash draw has a transmission");
        (1.0 - a.drive_mass_fraction) / t.load_drag_time.expect("the load drags")
    })
}

#[test]
#[ignore = "long: a loop on one draw of the independent simulator (minutes); `cargo xtask ci --long` runs it"]
fn a_passive_damping_in_the_model_is_refitted_to_the_load_drag_and_closes_the_gap() {
    // The seed's structure with a saturation on each axis that has a passive damping (its
    // values are starting points: the diagnosis refits them).
    let text = format!(
        "{}\n[acceleration_saturation.x]\nlimit = 1.0\npassive_damping = 1.0\n\
         [acceleration_saturation.y]\nlimit = 1.0\npassive_damping = 1.0\n",
        include_str!("../../../models/params/silo2-paper.toml")
    );
    let start = ModelSpec::parse(&text, "start.toml").unwrap();
    let names = |f: &[String]| {
        if f.is_empty() {
            "nothing".to_string()
        } else {
            f.join(", ")
        }
    };
    let words = |explained: bool| {
        if explained {
            "explained"
        } else {
            "unexplained"
        }
    };
    // The four loops (each draw from the seed's structure and from the start model) run at
    // once: one loop alone keeps the two cores about three quarters busy (its serial fits), and
    // without a time limit a loop's result does not depend on how fast it runs.
    let runs: Vec<_> = std::thread::scope(|s| {
        let jobs: Vec<_> = DRAWS
            .iter()
            .flat_map(|&(seed, _)| [(seed, None), (seed, Some(start.clone()))])
            .map(|(seed, from)| s.spawn(move || loop_from(seed, SCENARIO, from)))
            .collect();
        jobs.into_iter()
            .map(|j| j.join().expect("a loop panicked"))
            .collect()
    });
    let mut summary = String::new();
    for ((seed, range), pair) in DRAWS.into_iter().zip(runs.chunks(2)) {
        let truth = true_drag(seed);
        let plain = &pair[0];
        let plain_ratio = plain.final_error / plain.noise_floor;
        let damped = &pair[1];
        let ratio = damped.final_error / damped.noise_floor;
        // The damping stands in for the drag where the play is on the command: the version
        // that adds the play. The loop then moves the play inside the servo
        // (`iterate::play_law`), whose law carries a drag of its own.
        let with_play = &damped
            .versions
            .iter()
            .find(|(added, _)| added.iter().any(|e| e == "backlash"))
            .expect("a version that adds the play")
            .1
            .spec;
        let fitted = [Axis::X, Axis::Y].map(|a| {
            with_play
                .value(
                    EffectKind::AccelerationSaturation,
                    Binding::Axis(a),
                    "passive_damping",
                )
                .expect("the model keeps the saturation")
        });
        let law =
            if damped
                .final_model
                .value(EffectKind::Backlash, Binding::Axis(Axis::X), "in_servo")
                == Some(1.0)
            {
                "; the play then inside the servo"
            } else {
                ""
            };
        let line = format!(
            "- {range} seed {seed} ({SCENARIO}): from the seed's structure the loop adds {} \
             and ends at {plain_ratio:.2}x the noise floor ({}); from the start model it adds \
             {} and ends at {ratio:.2}x ({}{law}), the passive damping refitted with the play \
             on the command to x {:.1}/s and y {:.1}/s against the drawn robot's load drag of \
             {:.1}/s and {:.1}/s.\n",
            names(&plain.found),
            words(plain.explained),
            names(&damped.found),
            words(damped.explained),
            fitted[0],
            fitted[1],
            truth[0],
            truth[1],
        );
        eprint!("{line}");
        summary.push_str(&line);
        assert!(
            damped.explained && ratio <= 1.2,
            "seed {seed}: with the passive damping the loop should explain the draw: \
             {ratio:.2}x the floor"
        );
        assert!(
            damped.found.iter().any(|f| f == "backlash"),
            "seed {seed}: the play should be named once the drag is modelled: {:?}",
            damped.found
        );
        if !plain.explained {
            assert!(
                ratio <= 0.7 * plain_ratio,
                "seed {seed}: the passive damping should remove the misfit of the clamped \
                 records: {plain_ratio:.2}x -> {ratio:.2}x"
            );
        }
        for k in 0..2 {
            assert!(
                (fitted[k] / truth[k] - 1.0).abs() <= 0.35,
                "seed {seed}, axis {k}: passive damping {:.2} 1/s against the robot's drag \
                 {:.2} 1/s",
                fitted[k],
                truth[k]
            );
        }
    }
    doc_section("docs/src/effect-laws.md", "passive-damping", &summary);
}
