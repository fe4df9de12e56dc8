//! The first seed's section 6.6 experiment in simulation: the SILO2 plant under the cascade
//! ZMP controller `K1/s`, `K2/(s + K2)`; the reference steps 0.12 -> 0.17 m at t = 0 and a 4 kg
//! load is placed at t = 80 s.

// Index loops read as the matrix algebra they check.
#![allow(clippy::needless_range_loop)]

use zmp_models::closed_loop::{com_for_zmp, run, StepExperiment};
use zmp_models::controller::{CascadeController, CascadeParams};
use zmp_models::{ModelSpec, Plant};

const PAPER: &str = include_str!("../params/silo2-paper.toml");
const H: f64 = 1e-3;

fn silo2_plant() -> Plant {
    let spec = ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap();
    Plant::new(&spec, H).unwrap()
}

#[test]
fn section_6_6_step_and_load() {
    let exp = StepExperiment::silo2();
    let mut plant = silo2_plant();
    let params = CascadeParams::silo2();
    let mut ctrl = CascadeController::new(params, exp.controller_period);
    let tr = run(&mut plant, &mut ctrl, &exp);
    let m = tr.metrics(0, &exp);
    println!("{m:?}");

    // "It took about 20 seconds to reach the set point."
    assert!(
        m.reach_time > 15.0 && m.reach_time < 25.0,
        "ZMP first reaches 0.17 m at {} s",
        m.reach_time
    );
    // Settled (2 % of the 5 cm step) well before the load.
    assert!(
        m.settling_time_2pct < 80.0,
        "settles at {} s",
        m.settling_time_2pct
    );
    // After the load the error returns within 2 % of the step before the end (t = 160 s), and
    // stays: the last sample is inside the band.
    let step = exp.zmp_ref_after[0] - exp.zmp_ref_before[0];
    assert!(
        m.load_peak_error > 0.02 * step,
        "the load must disturb: {}",
        m.load_peak_error
    );
    assert!(
        exp.load_time + m.load_recovery_time < 160.0,
        "recovers from the load at {} s",
        exp.load_time + m.load_recovery_time
    );
    let last = *tr.zmp.last().unwrap();
    assert!(
        (last[0] - exp.zmp_ref_after[0]).abs() < 0.02 * step,
        "{last:?}"
    );
    // The sagittal axis, coupled through a21, is held at its reference too.
    assert!(last[1].abs() < 0.02 * step, "{last:?}");
    // Trunk angle within its limits throughout.
    for (t, th) in tr.t.iter().zip(&tr.theta) {
        for a in th {
            assert!(
                (params.theta_min..=params.theta_max).contains(a),
                "t = {t}: theta {a} outside [{}, {}]",
                params.theta_min,
                params.theta_max
            );
        }
    }
    // Time is k * period, never accumulated.
    assert_eq!(*tr.t.last().unwrap(), 160.0);
    assert_eq!(tr.t.len(), 16_001);
}

/// Anti-windup: with trunk-angle limits too tight for the set point, the controller output
/// stays within them while the error persists, and once the set point is reachable again the
/// ZMP gets there without a large overshoot, as fast as from rest.
#[test]
fn anti_windup_with_tight_trunk_limits() {
    let mut plant = silo2_plant();
    let period = 0.01;
    let sub = (period / H).round() as usize;
    let tight = CascadeParams {
        theta_min: -0.1,
        theta_max: 0.1,
        ..CascadeParams::silo2()
    };
    // Reaching 0.17 m from 0.12 m needs about 0.48 rad of trunk: unreachable with 0.1 rad.
    let zmp_start = [0.12, 0.0];
    let zmp_far = [0.17, 0.0];
    // Reachable: 0.12 m + 0.05 m * (0.05 / 0.48) needs about 0.05 rad.
    let zmp_near = [0.125, 0.0];

    let run_phase = |plant: &mut Plant,
                     ctrl: &mut CascadeController,
                     zmp_ref: [f64; 2],
                     seconds: f64,
                     trace: &mut Vec<(f64, [f64; 2], [f64; 2])>| {
        let n = (seconds / period).round() as usize;
        let mut out = plant.last_output();
        for _ in 0..n {
            let com_ref = ctrl.step(zmp_ref, out.zmp);
            let th = ctrl.theta();
            for (j, a) in th.iter().enumerate() {
                assert!(
                    (tight.theta_min..=tight.theta_max).contains(a),
                    "theta {a} outside the limits"
                );
                let off = com_ref[j] - ctrl.com_offset[j];
                assert!(off.abs() <= tight.trunk_gain() * tight.theta_max * (1.0 + 1e-12));
            }
            out = plant.advance(com_ref, sub);
            trace.push((0.0, out.zmp, th));
        }
    };

    // From rest: the step 0.12 -> 0.125 m with the tight limits, for reference.
    let com0 = com_for_zmp(&plant, zmp_start);
    let fresh = |plant: &mut Plant| {
        plant.reset(com0);
        let mut ctrl = CascadeController::new(tight, period);
        ctrl.com_offset = com0;
        ctrl.reset_to_com(com0);
        ctrl
    };
    let mut ctrl = fresh(&mut plant);
    let mut from_rest = Vec::new();
    run_phase(&mut plant, &mut ctrl, zmp_near, 60.0, &mut from_rest);

    // Saturated for 60 s asking for 0.17 m, then 0.125 m.
    let mut ctrl = fresh(&mut plant);
    let mut saturated = Vec::new();
    run_phase(&mut plant, &mut ctrl, zmp_far, 60.0, &mut saturated);
    // The lag (time constant 1/K2 = 5 s) has converged onto the clamped integrator.
    let pinned = saturated[saturated.len() - 1].2[0];
    assert!(
        (pinned - tight.theta_max).abs() < 1e-5,
        "the far set point pins the trunk at the limit: {pinned}"
    );
    let zmp_pinned = saturated.last().unwrap().1[0];
    assert!(zmp_pinned > zmp_near[0] && zmp_pinned < zmp_far[0]);
    let mut after = Vec::new();
    run_phase(&mut plant, &mut ctrl, zmp_near, 60.0, &mut after);

    // The trunk leaves the limit at once: the integrator was clamped, not wound up.
    let leave = after
        .iter()
        .position(|s| s.2[0] < tight.theta_max - 1e-3)
        .expect("the trunk never leaves the limit");
    assert!(
        leave as f64 * period < 2.0,
        "left the limit after {} s",
        leave as f64 * period
    );

    // Reaches 0.125 m, no later than the step from rest does plus a few seconds, and without
    // going far past it (from above now): at most 20 % of the distance it came down.
    let target = zmp_near[0];
    let reach = |tr: &[(f64, [f64; 2], [f64; 2])], above: bool| {
        tr.iter()
            .position(|s| {
                if above {
                    s.1[0] <= target
                } else {
                    s.1[0] >= target
                }
            })
            .map(|k| k as f64 * period)
    };
    let t_rest = reach(&from_rest, false).expect("from rest never reaches 0.125 m");
    let t_after = reach(&after, true).expect("after saturation never reaches 0.125 m");
    println!("from rest {t_rest} s, after saturation {t_after} s");
    assert!(
        t_after < t_rest + 5.0,
        "after saturation {t_after} s vs from rest {t_rest} s"
    );
    let undershoot = after.iter().map(|s| target - s.1[0]).fold(0.0, f64::max);
    assert!(
        undershoot < 0.2 * (zmp_pinned - target),
        "goes {undershoot} m past the set point coming down from {zmp_pinned}"
    );
    let last = after.last().unwrap().1[0];
    assert!(
        (last - target).abs() < 0.02 * (zmp_pinned - target),
        "ends at {last}"
    );
}
