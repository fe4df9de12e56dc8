//! Linear behaviour: the simulated steady state against frequency responses computed apart.

mod common;
use common::*;
use zmp_indep_sim::response::measured_response;
use zmp_indep_sim::{simulate, AxisName, CrossCoupling, FlexibleMode, OpDependence, Transmission};

/// The seed's small-signal model `(a_ij − b_ij s²) ωn_j²/(s² + 2ζ_j ωn_j s + ωn_j²)`, computed
/// here from the robot's parameters with the test's own complex arithmetic.
fn seed_model(r: &zmp_indep_sim::Robot, i: usize, j: usize, w: f64) -> (f64, f64) {
    let s = &r.axes[j].servo;
    let pend = (r.pendulum.a[i][j] + r.pendulum.b[i][j] * w * w, 0.0);
    let h = cdiv(
        (s.omega_n * s.omega_n, 0.0),
        (s.omega_n * s.omega_n - w * w, 2.0 * s.zeta * s.omega_n * w),
    );
    cmul(pend, h)
}

#[test]
fn linear_robot_steady_state_equals_the_analytic_response() {
    let robot = linear_robot();
    let omegas = [0.5, 2.0, 6.0, 15.0, 25.0];
    let op = [0.01, -0.02];
    let d = design(op, &[AxisName::X, AxisName::Y], &[0.005], &omegas, 3.0);
    let recs = simulate(&robot, &d);
    assert_eq!(recs.len(), 10);
    let mut worst: f64 = 0.0;
    for rec in &recs {
        let j = rec.meta.excited.index();
        let amp = rec.meta.amplitude;
        for (i, col) in [&rec.zmp_x, &rec.zmp_y].into_iter().enumerate() {
            let sim = steady(rec, col);
            let g = seed_model(&robot, i, j, rec.meta.omega);
            // The samples are averages over the sample interval: gain sin(x)/x, x = ωΔ/2.
            let x = 0.5 * rec.meta.omega / d.sample_rate_hz;
            let avg = x.sin() / x;
            let want = (g.0 * amp * avg, g.1 * amp * avg);
            let err = cabs(csub(sim, want)) / cabs(want);
            worst = worst.max(err);
            assert!(
                err < 1e-3,
                "record {} G{}{} at {} rad/s: sim {sim:?} analytic {want:?} rel err {err:.2e}",
                rec.meta.index,
                i + 1,
                j + 1,
                rec.meta.omega
            );
        }
        // At rest (t = 0) the ZMP is the static map of the operating point.
        for i in 0..2 {
            let rest = robot.pendulum.a[i][0] * op[0] + robot.pendulum.a[i][1] * op[1];
            let got = rec.truth.zmp[i][0];
            assert!(
                (got - rest).abs() < 1e-15,
                "zmp_{i} at rest {got} != {rest}"
            );
        }
    }
    eprintln!("worst relative first-harmonic error vs the seed's model: {worst:.2e}");
}

/// A robot whose every linear effect is on: command latency, a stiff linear transmission, one
/// and two flexible links, sensor low-pass, operating-point dependence, inertial coupling.
fn rich_linear_robot() -> zmp_indep_sim::Robot {
    let mut r = linear_robot();
    r.axes[0].command_delay = 0.04;
    r.axes[1].command_delay = 0.07;
    r.axes[0].transmission = Some(Transmission {
        play: 0.0,
        omega: 60.0,
        zeta: 0.1,
        hardening_deflection: None,
        load_drag_time: Some(0.08),
    });
    r.axes[0].modes = vec![FlexibleMode {
        omega: 18.0,
        zeta: 0.1,
        mass_fraction: 0.4,
    }];
    r.axes[1].modes = vec![
        FlexibleMode {
            omega: 14.0,
            zeta: 0.12,
            mass_fraction: 0.5,
        },
        FlexibleMode {
            omega: 30.0,
            zeta: 0.1,
            mass_fraction: 0.4,
        },
    ];
    r.sensor.lowpass_cutoff = Some([40.0, 70.0]);
    r.op_dependence = Some(OpDependence {
        a_slope: [3.0, -2.0],
        b_slope: [-4.0, 5.0],
    });
    r.cross_coupling = Some(CrossCoupling::Inertial {
        kappa_xy: 0.1,
        kappa_yx: -0.15,
    });
    r
}

#[test]
fn every_linear_effect_matches_the_small_signal_response() {
    let robot = rich_linear_robot();
    let op = [0.03, -0.02];
    let d = design(
        op,
        &[AxisName::X, AxisName::Y],
        &[0.004],
        &[1.0, 7.0, 14.0, 20.0],
        12.0,
    );
    for rec in simulate(&robot, &d) {
        let j = rec.meta.excited.index();
        let g =
            measured_response(&robot, op, rec.meta.omega, d.sample_rate_hz).expect("smooth robot");
        for (i, col) in [&rec.zmp_x, &rec.zmp_y].into_iter().enumerate() {
            let sim = steady(&rec, col);
            let want = (
                g[i][j].re * rec.meta.amplitude,
                g[i][j].im * rec.meta.amplitude,
            );
            let err = cabs(csub(sim, want)) / cabs(want);
            assert!(
                err < 1e-3,
                "G{}{} at {} rad/s: sim {sim:?} response {want:?} rel err {err:.2e}",
                i + 1,
                j + 1,
                rec.meta.omega
            );
        }
    }
}

#[test]
fn command_delay_lags_the_phase_by_omega_tau() {
    let plain = linear_robot();
    let mut delayed = linear_robot();
    let tau = 0.06;
    delayed.axes[0].command_delay = tau;
    let d = design([0.0, 0.0], &[AxisName::X], &[0.005], &[1.0, 5.0, 12.0], 3.0);
    let (a, b) = (simulate(&plain, &d), simulate(&delayed, &d));
    for (ra, rb) in a.iter().zip(&b) {
        let w = ra.meta.omega;
        let ratio = cdiv(steady(rb, &rb.zmp_x), steady(ra, &ra.zmp_x));
        let want = ((-w * tau).cos(), (-w * tau).sin());
        assert!(
            cabs(csub(ratio, want)) < 1e-3,
            "at {w} rad/s delayed/plain = {ratio:?}, want e^(-j w tau) = {want:?}"
        );
    }
}

#[test]
fn sensor_lowpass_is_a_first_order_filter_on_the_zmp() {
    let plain = linear_robot();
    let mut filtered = linear_robot();
    let wc = [20.0, 45.0];
    filtered.sensor.lowpass_cutoff = Some(wc);
    let d = design(
        [0.0, 0.0],
        &[AxisName::Y],
        &[0.005],
        &[2.0, 10.0, 20.0],
        3.0,
    );
    let (a, b) = (simulate(&plain, &d), simulate(&filtered, &d));
    for (ra, rb) in a.iter().zip(&b) {
        let w = ra.meta.omega;
        for (i, (ca, cb)) in [(&ra.zmp_x, &rb.zmp_x), (&ra.zmp_y, &rb.zmp_y)]
            .into_iter()
            .enumerate()
        {
            let ratio = cdiv(steady(rb, cb), steady(ra, ca));
            let want = cdiv((wc[i], 0.0), (wc[i], w));
            assert!(
                cabs(csub(ratio, want)) < 1e-3,
                "output {i} at {w} rad/s: {ratio:?} vs {want:?}"
            );
        }
    }
}

#[test]
fn halving_the_step_changes_nothing_that_matters() {
    // A robot with every event-driven element: play, stick-slip, a flexible link.
    let mut robot = linear_robot();
    robot.axes[0].servo.accel_limit = 1.0;
    robot.axes[0].transmission = Some(Transmission {
        play: 1e-3,
        omega: 250.0,
        zeta: 0.2,
        hardening_deflection: None,
        load_drag_time: Some(0.05),
    });
    robot.axes[0].friction = Some(zmp_indep_sim::Friction {
        kinetic: 0.1,
        static_level: 0.2,
        stribeck_velocity: Some(3e-3),
    });
    robot.axes[0].modes = vec![FlexibleMode {
        omega: 20.0,
        zeta: 0.1,
        mass_fraction: 0.3,
    }];
    // And a hardening transmission on y, whose step follows its tangent stiffness.
    robot.axes[1].servo.accel_limit = 1.0;
    robot.axes[1].transmission = Some(Transmission {
        play: 0.0,
        omega: 60.0,
        zeta: 0.1,
        hardening_deflection: Some(3e-4),
        load_drag_time: None,
    });
    let d = design(
        [0.0, 0.0],
        &[AxisName::X, AxisName::Y],
        &[0.003, 0.008],
        &[1.5, 9.0],
        6.0,
    );
    let fine = zmp_indep_sim::Design {
        min_internal_rate_hz: 60_000.0,
        ..d.clone()
    };
    let (a, b) = (simulate(&robot, &d), simulate(&robot, &fine));
    assert!(
        b[0].truth.substeps >= 3 * a[0].truth.substeps,
        "{} vs {}",
        a[0].truth.substeps,
        b[0].truth.substeps
    );
    for (ra, rb) in a.iter().zip(&b) {
        if ra.meta.excited == AxisName::X {
            assert!(
                ra.truth.events > 0,
                "record {} located no event",
                ra.meta.index
            );
        }
        for (ca, cb) in [(&ra.zmp_x, &rb.zmp_x), (&ra.zmp_y, &rb.zmp_y)] {
            let (za, zb) = (steady(ra, ca), steady(rb, cb));
            let err = cabs(csub(za, zb)) / cabs(zb);
            eprintln!("record {}: default step vs fine step: relative first-harmonic difference {err:.2e}", ra.meta.index);
            assert!(
                err < 1e-3,
                "record {}: default step {za:?} vs fine {zb:?}: {err:.2e}",
                ra.meta.index
            );
        }
    }
}
