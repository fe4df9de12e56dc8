//! Nonlinear elements: acceleration limit, play, stick-slip friction, velocity limit, hardening.

mod common;
use common::*;
use zmp_indep_sim::{simulate, AxisName, Friction, Transmission};

#[test]
fn the_com_acceleration_never_exceeds_the_limit_and_a_tight_limit_changes_the_gain() {
    let free = linear_robot();
    let mut tight = linear_robot();
    let limit = 0.5;
    tight.axes[0].servo.accel_limit = limit;
    // 8 mm at 15 rad/s demands about 1.4 m/s² of the servo; 0.5 rad/s about 2 mm/s².
    let d = design([0.0, 0.0], &[AxisName::X], &[0.008], &[0.5, 15.0], 3.0);
    let (a, b) = (simulate(&free, &d), simulate(&tight, &d));
    for rec in &b {
        let max_step = rec.truth.max_abs_com_acc[0];
        let max_sample = rec.truth.com_acc[0]
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            max_step <= limit * (1.0 + 1e-12),
            "record {}: |x_c''| reached {max_step} > {limit}",
            rec.meta.index
        );
        assert!(max_sample <= limit * (1.0 + 1e-12));
    }
    assert!(
        b[1].truth.max_abs_com_acc[0] > limit * (1.0 - 1e-9),
        "the fast record should reach the limit"
    );
    let slow = cabs(steady(&b[0], &b[0].zmp_x)) / cabs(steady(&a[0], &a[0].zmp_x));
    let fast = cabs(steady(&b[1], &b[1].zmp_x)) / cabs(steady(&a[1], &a[1].zmp_x));
    assert!(
        (slow - 1.0).abs() < 1e-6,
        "below the limit the gain must not change: ratio {slow}"
    );
    assert!(
        fast < 0.6,
        "at the limit the gain must fall well below the linear one: ratio {fast}"
    );
    eprintln!("gain ratio limited/linear: {slow:.6} at 0.5 rad/s, {fast:.3} at 15 rad/s");
}

fn backlash_robot(play: f64) -> zmp_indep_sim::Robot {
    let mut r = linear_robot();
    r.axes[0].transmission = Some(Transmission {
        play,
        omega: 150.0,
        zeta: 0.2,
        hardening_deflection: None,
        load_drag_time: Some(0.05),
    });
    r
}

#[test]
fn an_amplitude_below_half_the_play_moves_nothing() {
    let w = 2e-3;
    let robot = backlash_robot(w);
    // |H| ≤ 1.02 for ζ = 0.85 at these frequencies, so the drive stays within ±0.9 mm < w/2.
    let d = design(
        [0.01, 0.0],
        &[AxisName::X],
        &[0.4 * w],
        &[0.5, 3.0, 10.0],
        1.0,
    );
    for rec in simulate(&robot, &d) {
        assert!(
            rec.truth.com[0].iter().all(|&x| x == 0.01),
            "record {}: the trunk moved",
            rec.meta.index
        );
        assert!(
            rec.truth.zmp[0].iter().all(|&z| z == rec.truth.zmp[0][0]),
            "record {}: the ZMP moved",
            rec.meta.index
        );
    }
    // Above the play it moves, with the amplitude lost to the play at low frequency.
    let d = design([0.0, 0.0], &[AxisName::X], &[3.0 * w], &[0.5], 3.0);
    let rec = &simulate(&robot, &d)[0];
    let amp = cabs(steady(rec, &rec.truth.com[0]));
    assert!(rec.truth.events > 0);
    assert!(
        amp > 0.5 * w && amp < 3.0 * w,
        "trunk amplitude {amp} for a {} m drive",
        3.0 * w
    );
}

fn friction_robot(kinetic: f64, static_level: f64, stribeck: Option<f64>) -> zmp_indep_sim::Robot {
    let mut r = linear_robot();
    r.axes[0].friction = Some(Friction {
        kinetic,
        static_level,
        stribeck_velocity: stribeck,
    });
    r
}

#[test]
fn a_drive_below_the_static_level_does_not_move_the_joint() {
    let wn2 = 27.0f64 * 27.0;
    for robot in [
        friction_robot(0.3, 0.3, None),
        friction_robot(0.15, 0.3, Some(2e-3)),
    ] {
        // The stuck joint feels the servo force wn² (r − p): below 0.3 m/s² for |r − p| < 0.3/wn².
        let amp = 0.8 * 0.3 / wn2;
        let d = design([0.0, 0.02], &[AxisName::X], &[amp], &[0.5, 5.0], 1.0);
        for rec in simulate(&robot, &d) {
            assert!(
                rec.truth.com[0].iter().all(|&x| x == 0.0),
                "record {}: the joint slipped",
                rec.meta.index
            );
            assert_eq!(rec.truth.events, 0);
        }
    }
}

#[test]
fn above_the_static_level_the_joint_slips_and_sticks_again() {
    let robot = friction_robot(0.3, 0.3, None);
    let d = design([0.0, 0.0], &[AxisName::X], &[0.003], &[0.5], 3.0);
    let rec = &simulate(&robot, &d)[0];
    let x = &rec.truth.com[0];
    // Runs of exactly equal positions are true sticking (a regularised law would creep).
    let mut longest = 0;
    let mut run = 0;
    for k in 1..x.len() {
        run = if x[k] == x[k - 1] { run + 1 } else { 0 };
        longest = longest.max(run);
    }
    let moving = x.windows(2).filter(|w| w[0] != w[1]).count();
    assert!(
        longest >= 20,
        "no sticking phase: longest run of equal samples {longest}"
    );
    assert!(
        moving > x.len() / 2,
        "the joint should mostly slide: {moving} of {}",
        x.len()
    );
    assert!(
        rec.truth.events >= 4 * 3,
        "expected at least 4 switches per period, got {}",
        rec.truth.events
    );
}

#[test]
fn a_rate_limited_servo_never_exceeds_its_velocity() {
    let mut robot = linear_robot();
    let v_max = 0.03;
    robot.axes[0].servo.velocity_limit = Some(v_max);
    let d = design([0.0, 0.0], &[AxisName::X], &[0.008], &[9.0], 2.0);
    let rec = &simulate(&robot, &d)[0];
    let x = &rec.truth.com[0];
    let dt = rec.t[1] - rec.t[0];
    let fastest = x
        .windows(2)
        .map(|w| (w[1] - w[0]).abs() / dt)
        .fold(0.0, f64::max);
    assert!(
        fastest <= v_max * (1.0 + 1e-9),
        "mean velocity over a sample {fastest} > {v_max}"
    );
    assert!(
        fastest > 0.95 * v_max,
        "the limit should be reached: {fastest}"
    );
}

#[test]
fn a_hardening_transmission_makes_the_response_depend_on_amplitude() {
    let make = |hardening: Option<f64>| {
        let mut r = linear_robot();
        r.axes[0].transmission = Some(Transmission {
            play: 0.0,
            omega: 45.0,
            zeta: 0.08,
            hardening_deflection: hardening,
            load_drag_time: None,
        });
        r
    };
    let d = design([0.0, 0.0], &[AxisName::X], &[0.002, 0.008], &[14.0], 4.0);
    let gain_ratio = |robot: &zmp_indep_sim::Robot| {
        let recs = simulate(robot, &d);
        let g: Vec<f64> = recs
            .iter()
            .map(|r| cabs(steady(r, &r.zmp_x)) / r.meta.amplitude)
            .collect();
        g[1] / g[0]
    };
    let linear = gain_ratio(&make(None));
    let hard = gain_ratio(&make(Some(2e-4)));
    assert!(
        (linear - 1.0).abs() < 1e-6,
        "a linear transmission is amplitude-independent: {linear}"
    );
    assert!((hard - 1.0).abs() > 0.02, "a hardening one is not: {hard}");
    eprintln!("gain(8 mm)/gain(2 mm): linear {linear:.7}, hardening {hard:.4}");
}
