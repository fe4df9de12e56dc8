//! `coulomb_friction`: small amplitudes shrink more, and lag.

use crate::support::plant;
use zmp_models::Axis;

/// Friction takes a fixed acceleration, so it matters more for small motions: their gain
/// shrinks more, and the phase lags.
#[test]
fn coulomb_friction_shrinks_small_amplitudes_more_and_lags() {
    let mut p = plant("[coulomb_friction]\nlevel = 0.5\n");
    for omega in [1.0, 2.0, 6.0] {
        let lin = p.frequency_response(omega);
        let small = p.simulated_response(Axis::X, omega, 0.002)[0] / lin[0][0];
        let large = p.simulated_response(Axis::X, omega, 0.05)[0] / lin[0][0];
        assert!(
            small.norm() < large.norm() && large.norm() <= 1.0,
            "{omega} rad/s: gain small {} large {}",
            small.norm(),
            large.norm()
        );
        assert!(
            small.norm() < 0.9,
            "{omega} rad/s: small-amplitude gain {}",
            small.norm()
        );
        assert!(
            small.arg() < 0.0 && large.arg() < 0.0 && small.arg() < large.arg(),
            "{omega} rad/s: phase small {} large {} deg",
            small.arg().to_degrees(),
            large.arg().to_degrees()
        );
        assert!((large - 1.0).norm() < (small - 1.0).norm());
    }
}
