//! The describing functions of servo effects and of a play inside the servo: the ratio of
//! the servo's steady harmonics with and without them, cached by their exact inputs.

use super::{first_harmonic, Harmonics};
use crate::effect::Effect;
use crate::effects::servo_link::TrunkLink;
use crate::memo::Memo;
use num_complex::Complex64;

/// Describing functions already computed, by their exact inputs: fits evaluate the same servo
/// at the same frequencies and amplitudes many times (once per output, per operating point,
/// per Jacobian column of a parameter the servo ignores).
static DF_CACHE: Memo<[u64; 14], Harmonics> = Memo::new(200_000);

/// Forgets every cached describing function (a new campaign or a timed run starts afresh).
pub fn clear_describing_function_cache() {
    DF_CACHE.clear();
}

fn cached(key: [f64; 14], compute: impl FnOnce() -> Harmonics) -> Harmonics {
    DF_CACHE.get_or(key.map(f64::to_bits), compute)
}

/// The steady harmonics of the servo `(omega_n, zeta)` driving `link` with `limits` named by
/// `identity`, cached.
fn run_cached(
    (omega_n, zeta): (f64, f64),
    h: f64,
    link: Option<TrunkLink>,
    limits: &mut [Box<dyn Effect>],
    identity: [f64; 3],
    omega: f64,
    amplitude: f64,
) -> Harmonics {
    let l = link.map_or([0.0; 6], |l| {
        [l.omega_m, l.zeta_m, l.share, l.drive, l.half_play, l.drag]
    });
    cached(
        [
            omega_n,
            zeta,
            h,
            omega,
            amplitude,
            identity[0],
            identity[1],
            identity[2],
            l[0],
            l[1],
            l[2],
            l[3],
            l[4],
            l[5],
        ],
        || first_harmonic(omega_n, zeta, h, link, limits, omega, amplitude, None).0,
    )
}

/// First harmonic of the servo position with `limits`, divided by the linear servo's, for a
/// reference sine of `amplitude` at `omega` (the describing function of a servo effect), and,
/// from the same run, the servo position's third harmonic over the reference's amplitude
/// (absolute: the linear servo has none; sin-referenced like every phasor here,
/// `x_3(t) = Im(X_3 e^{3 j omega t})` for the reference `amplitude sin(omega t)`). The servo
/// `(omega_n, zeta)` drives `link` if there is one (then the CoM's harmonics, the first over
/// the linear two-body loop's; over the loop's own run at the same amplitude if the link has
/// play, whose third harmonic is then taken off: the play's own harmonics are
/// [`play_harmonics`]). `identity` names the limits exactly (effect id and parameters) for
/// the cache.
///
/// The step divides the period exactly (so one period's Fourier sum is exact for a periodic
/// response) and is about the servo's `h`, lengthened at low frequency to 1/2048 of a period
/// (at most 2.5 h, and at most [`max_step`](super::max_step) of the limits): the linear part is
/// exact at any step, and the RK4 sub-steps follow the effects' stiffness.
/// Both runs use the same step, so the sampling's own small effect on the first harmonic
/// cancels in the ratio.
pub fn servo_harmonics(
    servo: (f64, f64),
    h: f64,
    link: Option<TrunkLink>,
    limits: &mut [Box<dyn Effect>],
    identity: [f64; 3],
    omega: f64,
    amplitude: f64,
) -> (Complex64, Complex64) {
    let with = run_cached(servo, h, link, limits, identity, omega, amplitude);
    let play = link.is_some_and(|l| l.half_play > 0.0);
    // The linear servo's response does not depend on the amplitude (run at 1); a play's does.
    let without = run_cached(
        servo,
        h,
        link,
        &mut [],
        [0.0; 3],
        omega,
        if play { amplitude } else { 1.0 },
    );
    let third = if play {
        with.third - without.third
    } else {
        with.third
    };
    (with.first / without.first, third)
}

/// The harmonics of a servo driving a `link` with play (a backlash inside the servo), over
/// the rigid servo's: the first harmonic's ratio (the play's describing function, with the
/// link's own small-signal filter) and the CoM's third harmonic over the reference's
/// amplitude, as [`servo_harmonics`] gives them for a servo effect.
pub fn play_harmonics(
    servo: (f64, f64),
    h: f64,
    link: TrunkLink,
    omega: f64,
    amplitude: f64,
) -> (Complex64, Complex64) {
    let with = run_cached(servo, h, Some(link), &mut [], [0.0; 3], omega, amplitude);
    let rigid = run_cached(servo, h, None, &mut [], [0.0; 3], omega, 1.0);
    (with.first / rigid.first, with.third)
}
