//! `time_delay`: the phase falls by `omega tau`, the magnitude stays.

use crate::assert_close;
use crate::support::plant;
use num_complex::Complex64;
use zmp_models::Axis;

/// `e^{-s tau}`: the phase falls by `omega tau`, the magnitude stays. Time simulation against
/// the delay-free plant. With a step of 1 ms the fractional delay's linear interpolation costs
/// at most `(omega h)^2/8` in magnitude (2e-4 at 40 rad/s), so 0.1 % and 0.1 degree hold.
#[test]
fn time_delay_shifts_phase_by_omega_tau_and_keeps_magnitude() {
    let mut base = plant("");
    for tau in [0.0375, 0.0123, 0.2] {
        let mut delayed = plant(&format!("[time_delay]\ndelay = {tau}\n"));
        for omega in [0.5, 2.0, 8.0, 20.0, 40.0] {
            let want_shift = Complex64::from_polar(1.0, -omega * tau);
            let g0 = base.frequency_response(omega);
            let g1 = delayed.frequency_response(omega);
            for i in 0..2 {
                for j in 0..2 {
                    assert!((g1[i][j] - g0[i][j] * want_shift).norm() <= 1e-12 * g0[i][j].norm());
                }
            }
            for axis in Axis::BOTH {
                let s0 = base.simulated_response(axis, omega, 0.01);
                let s1 = delayed.simulated_response(axis, omega, 0.01);
                for i in 0..2 {
                    assert_close(
                        s1[i] / s0[i],
                        want_shift,
                        1e-3,
                        0.1,
                        &format!("delay {tau} s, {omega} rad/s, output {i} from {axis}"),
                    );
                }
            }
        }
    }
}
