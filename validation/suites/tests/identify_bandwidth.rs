//! The tracking low-pass is identified when the campaign's band ends well below it, on data
//! from the independent simulator (`zmp-indep-sim`, which shares no code with `zmp-models`).
//!
//! Below `omega_n` the band determines the low-pass's phase lag, about `2 zeta w / omega_n`,
//! but not `omega_n` and `zeta` apart: the fit of both has standard errors of tens of percent.
//! The identification then fits `omega_n` with `zeta` held, and keeps it when it is determined
//! and the likelihood-ratio test prefers it to the given low-pass; it used to fall back to the
//! seed's 30 rad/s, so a robot with a faster servo was handed to the diagnosis with a wrong
//! phase lag that the diagnosis then had to explain.

use zmp_campaign::read_campaign;
use zmp_identify::{identify, Bandwidth, IdentifyOptions};
use zmp_indep_sim::{draw_with, write_campaign, CouplingForm, Design, DrawOptions, Scenario};

/// A clean robot of the independent simulator with the servo `(omega_n, zeta)` on both axes
/// and no saturation, identified with the default options.
fn identified_bandwidth(omega_n: f64, zeta: f64) -> Bandwidth {
    let scenario: Scenario = "clean".parse().unwrap();
    // A band that ends at 2 rad/s and 2 mm of noise: the low-pass's phase lag (0.1 rad at the
    // top) is measured, its magnitude curvature is not (the default design's band to
    // 15 rad/s determines both, as a misfit's inflated errors on it may not).
    let design = Design {
        omegas: (0..9).map(|k| 0.5 * 4f64.powf(k as f64 / 8.0)).collect(),
        zmp_noise_std: Some(2e-3),
        ..Design::default()
    };
    let mut robot = draw_with(
        3,
        &scenario,
        &design,
        &DrawOptions {
            coupling_form: Some(CouplingForm::Pendulum),
        },
    );
    for axis in &mut robot.axes {
        axis.servo.omega_n = omega_n;
        axis.servo.zeta = zeta;
        axis.servo.accel_limit = 1e3;
    }
    let dir = tempfile::tempdir().unwrap();
    let camp_dir = dir.path().join("campaign");
    write_campaign(&robot, &design, &camp_dir, false).unwrap();
    let camp = read_campaign(&camp_dir).unwrap();
    let id = identify(&camp, &IdentifyOptions::default()).unwrap();
    eprintln!(
        "truth omega_n {omega_n}, zeta {zeta}: identified {:.3} +- {:.3} rad/s, zeta {:.3} \
         (estimated {}): {}",
        id.bandwidth.omega_n,
        id.bandwidth.omega_n_stderr,
        id.bandwidth.zeta,
        id.bandwidth.estimated,
        id.bandwidth.note
    );
    id.bandwidth
}

#[test]
fn a_faster_servo_than_the_seeds_is_identified_with_zeta_held() {
    let bw = identified_bandwidth(40.0, 1.0);
    // This campaign does not determine omega_n and zeta apart (the path under test).
    assert!(bw.estimated, "{}", bw.note);
    assert!(bw.note.contains("zeta held"), "{}", bw.note);
    assert_eq!(bw.zeta, 1.0);
    // The seed's 30 rad/s (what the identification used to keep) is 25 % off. (Measured:
    // 38.7 +- 0.4, 3 % low, on this simulator's data.)
    assert!(
        (bw.omega_n / 40.0 - 1.0).abs() < 0.06,
        "omega_n {} +- {}",
        bw.omega_n,
        bw.omega_n_stderr
    );
    assert!(bw.omega_n_stderr > 0.0 && bw.omega_n_stderr < 0.05 * bw.omega_n);
}

#[test]
fn the_seeds_servo_stays_the_seeds() {
    // The robot's servo is the given one: whether or not the data move it, it stays close
    // (measured: 29.2 +- 0.2).
    let bw = identified_bandwidth(30.0, 1.0);
    assert!(
        (bw.omega_n / 30.0 - 1.0).abs() < 0.06,
        "omega_n {} ({})",
        bw.omega_n,
        bw.note
    );
}
