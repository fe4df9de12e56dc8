//! `tracking_lowpass`: at rest after a reset, its response at `omega_n`, and the slowest time
//! constant that bounds it.

use crate::support::{plant, record};
use crate::{assert_close, harmonic};
use num_complex::Complex64;
use std::f64::consts::PI;
use zmp_models::lti::slowest_time_constant;
use zmp_models::Axis;

/// `reset` puts the plant at rest: stepping the same reference changes nothing, the CoM is the
/// reference, its acceleration zero, and the ZMP is `a x_c` (with every linear effect on).
#[test]
fn tracking_lowpass_reset_is_at_rest_and_zmp_is_a_times_com() {
    let all_linear = "[uncertainty]\ndelta = 0.7\ndelta_seed = 9\nk = 2.0\nz = 1.0\np = 5.0\n\
                      [time_delay]\ndelay = 0.02\n\
                      [structural_mode]\nomega_n = 50.0\nzeta = 0.05\n\
                      [sensor_lowpass]\ncutoff = 40.0\n";
    for extra in ["", all_linear] {
        let mut p = plant(extra);
        let a = p.pendulum().a;
        for r in [[0.0, 0.0], [0.12, -0.03], [-0.2, 0.15]] {
            let rest = p.reset(r);
            for j in 0..2 {
                assert!((rest.com[j] - r[j]).abs() <= 1e-15);
                assert_eq!(rest.com_acceleration[j], 0.0);
            }
            // At rest the ZMP is the DC gain times the CoM: `a x_c` for the nominal model,
            // `a (1 + W(0) Delta(0)) x_c` with the uncertainty.
            let g0 = p.frequency_response(0.0);
            for i in 0..2 {
                let want = g0[i][0].re * r[0] + g0[i][1].re * r[1];
                assert!(
                    (rest.zmp[i] - want).abs() <= 1e-12,
                    "{} vs {want}",
                    rest.zmp[i]
                );
                if extra.is_empty() {
                    let want = a[i][0] * r[0] + a[i][1] * r[1];
                    assert!(
                        (rest.zmp[i] - want).abs() <= 1e-15,
                        "{} vs {want}",
                        rest.zmp[i]
                    );
                }
            }
            for _ in 0..2000 {
                let o = p.step(r);
                for i in 0..2 {
                    assert!((o.zmp[i] - rest.zmp[i]).abs() <= 1e-12, "{o:?} vs {rest:?}");
                    assert!((o.com[i] - r[i]).abs() <= 1e-12);
                    assert!(o.com_acceleration[i].abs() <= 1e-9);
                }
            }
        }
    }
}

/// The CoM follows its reference through `wn^2/(s^2 + 2 zeta wn s + wn^2)`: at `wn` the gain is
/// `1/(2 zeta)` and the phase -90 degrees.
#[test]
fn tracking_lowpass_at_omega_n() {
    for (wn, zeta) in [(30.0, 1.0), (12.0, 0.3), (50.0, 0.7)] {
        let mut p = plant(&format!(
            "[tracking_lowpass.x]\nomega_n = {wn}\nzeta = {zeta}\n\
             [tracking_lowpass.y]\nomega_n = 30.0\nzeta = 1.0\n"
        ));
        let omega = wn;
        let settle = 10.0 * p.slowest_time_constant();
        let (out, t0) = record(&mut p, [0.0; 2], Axis::X, omega, 0.01, settle, 4);
        let com: Vec<f64> = out.iter().map(|o| o.com[0]).collect();
        let g = harmonic(&com, omega, t0) / 0.01;
        let want = Complex64::from_polar(0.5 / zeta, -PI / 2.0);
        assert_close(g, want, 0.005, 0.5, &format!("wn {wn} zeta {zeta}"));
    }
}

/// `slowest_time_constant` is a bound on the slowest linear time constant, also for an
/// overdamped tracking low-pass (zeta > 1), whose slow pole is `wn (zeta - sqrt(zeta^2 - 1))`.
#[test]
fn slowest_time_constant_bounds_the_tracking_lowpass() {
    for zeta in [0.2, 0.7, 1.0, 1.5, 2.0, 5.0] {
        let wn = 10.0;
        let p = plant(&format!(
            "[tracking_lowpass.x]\nomega_n = {wn}\nzeta = {zeta}\n\
             [tracking_lowpass.y]\nomega_n = {wn}\nzeta = {zeta}\n"
        ));
        let exact = slowest_time_constant(&p.tracking_lowpass(Axis::X).tf().den);
        let got = p.slowest_time_constant();
        assert!(
            got >= exact * (1.0 - 1e-9),
            "zeta {zeta}: slowest_time_constant {got} s below the slow pole's {exact} s"
        );
        assert!(
            got <= exact * 1.5,
            "zeta {zeta}: {got} s is far above {exact} s"
        );
    }
}
