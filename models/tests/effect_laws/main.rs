//! One test per effect's defining law, checked through the composed plant where that is
//! natural: the effect's plant against the same plant without it.
//!
//! One module per effect, named by its key in the model file.

// Index loops read as the matrix algebra they check.
#![allow(clippy::needless_range_loop)]

use num_complex::Complex64;
use zmp_models::harmonic::first_harmonic;

#[path = "../support/mod.rs"]
mod support;
use support::H;

mod acceleration_saturation;
mod backlash;
mod coulomb_friction;
mod operating_point_dependence;
mod sensor_drift;
mod sensor_lowpass;
mod structural_mode;
mod time_delay;
mod tracking_lowpass;
mod uncertainty;

fn harmonic(y: &[f64], omega: f64, t0: f64) -> Complex64 {
    first_harmonic(y, omega, H, t0)
}

fn assert_close(got: Complex64, want: Complex64, mag_tol: f64, phase_tol_deg: f64, what: &str) {
    let r = got / want;
    let (m, p) = (r.norm() - 1.0, r.arg().to_degrees());
    assert!(
        m.abs() <= mag_tol && p.abs() <= phase_tol_deg,
        "{what}: got {got}, want {want}: magnitude error {m:.3e}, phase error {p:.4} deg"
    );
}
