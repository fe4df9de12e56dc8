//! The plant's predicted third harmonic (`Plant::describing_harmonics`) against the third
//! harmonic of its own simulated steady state: each nonlinear effect's distortion, carried
//! through what follows it at three times the frequency, with the phase of the first harmonic
//! reaching it.

mod support;

use num_complex::Complex64;
use support::*;
use zmp_models::harmonic::first_harmonic;
use zmp_models::{Axis, Channel};

/// Third harmonic of both outputs of a steady sine `amplitude sin(omega t)` on x (phase zero
/// at t = 0), over the amplitude.
fn simulated_third(extra: &str, omega: f64, amplitude: f64, settle: f64) -> [Complex64; 2] {
    let mut p = plant(extra);
    let (out, t0) = record(&mut p, [0.0; 2], Axis::X, omega, amplitude, settle, 4);
    [0, 1].map(|i| {
        let y: Vec<f64> = out.iter().map(|o| o.zmp[i]).collect();
        first_harmonic(&y, 3.0 * omega, H, t0) / amplitude
    })
}

fn check(extra: &str, omega: f64, amplitude: f64, mag_tol: f64, phase_tol_deg: f64) {
    let (omega, _) = whole_period(omega);
    let sim = simulated_third(extra, omega, amplitude, 25.0);
    let p = plant(extra);
    for (i, ch) in [(0, Channel::ALL[0]), (1, Channel::ALL[2])] {
        let (g1, g3) = p.describing_harmonics(ch, omega, amplitude);
        assert_eq!(g1, p.describing_response(ch, omega, amplitude));
        let r = g3 / sim[i];
        let (m, ph) = (r.norm() - 1.0, r.arg().to_degrees());
        assert!(
            m.abs() <= mag_tol && ph.abs() <= phase_tol_deg,
            "{extra} at {omega:.3} rad/s, {ch}: predicted {g3}, simulated {}: magnitude {m:.3e}, \
             phase {ph:.2} deg",
            sim[i]
        );
        // The distortion is real: a few percent of the first harmonic, far above numerics.
        assert!(
            sim[i].norm() > 1e-3 * g1.norm(),
            "{extra}: third harmonic {} against first {}",
            sim[i].norm(),
            g1.norm()
        );
    }
}

#[test]
fn clamped_servo_third_harmonic_is_the_simulated_one() {
    check(
        "[acceleration_saturation]\nlimit = 0.8\n",
        15.0,
        0.008,
        0.02,
        1.5,
    );
}

#[test]
fn friction_third_harmonic_is_the_simulated_one() {
    check("[coulomb_friction]\nlevel = 0.5\n", 2.0, 0.005, 0.02, 1.5);
}

/// A delay ahead of the play turns its distortion by three times its phase; the servo and a
/// sensor low-pass after it filter the distortion at three times the frequency.
#[test]
fn play_third_harmonic_follows_the_chain() {
    check(
        "[time_delay]\ndelay = 0.03\n[backlash]\nwidth = 0.004\n[sensor_lowpass]\ncutoff = 40.0\n",
        3.0,
        0.005,
        0.03,
        2.0,
    );
}

/// A linear plant has no third harmonic at all.
#[test]
fn linear_plant_has_none() {
    let p = plant("[time_delay]\ndelay = 0.03\n[sensor_lowpass]\ncutoff = 40.0\n");
    let (_, g3) = p.describing_harmonics(Channel::ALL[0], 3.0, 0.005);
    assert_eq!(g3, Complex64::new(0.0, 0.0));
}
