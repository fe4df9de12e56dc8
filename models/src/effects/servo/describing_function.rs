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
static DF_CACHE: Memo<[u64; 17], Harmonics> = Memo::new(200_000);

/// Forgets every cached describing function (a new campaign or a timed run starts afresh).
pub fn clear_describing_function_cache() {
    DF_CACHE.clear();
}

fn cached(key: [f64; 17], compute: impl FnOnce() -> Harmonics) -> Harmonics {
    DF_CACHE.get_or(key.map(f64::to_bits), compute)
}

/// The steady harmonics of the servo `(omega_n, zeta)` driving `link` with `limits` named by
/// `identity`, cached.
fn run_cached(
    (omega_n, zeta): (f64, f64),
    h: f64,
    link: Option<TrunkLink>,
    limits: &mut [Box<dyn Effect>],
    identity: [f64; 6],
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
            identity[3],
            identity[4],
            identity[5],
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
    let [a, b, c] = identity;
    ratio(
        servo,
        h,
        link,
        limits,
        [a, b, c, 0.0, 0.0, 0.0],
        omega,
        amplitude,
    )
}

/// What one servo effect brings to a servo simulation shared with the axis's other servo
/// effects ([`joint_servo_harmonics`]): a copy of it to run, the servo it acts in and its
/// identity (kind and parameters) for the cache.
#[derive(Debug)]
pub struct ServoPart {
    /// The servo effect to run.
    pub effect: Box<dyn Effect>,
    /// The servo it acts in: `(omega_n rad/s, zeta)`.
    pub servo: (f64, f64),
    /// The plant's internal step, s.
    pub h: f64,
    /// The link the servo drives inside its loop, if any.
    pub link: Option<TrunkLink>,
    /// The effect's kind and parameters as numbers, the cache key.
    pub identity: [f64; 3],
}

/// [`servo_harmonics`] of one servo effect, as its [`ServoPart`] names it.
pub fn part_harmonics(part: ServoPart, omega: f64, amplitude: f64) -> (Complex64, Complex64) {
    let [a, b, c] = part.identity;
    ratio(
        part.servo,
        part.h,
        part.link,
        &mut [part.effect],
        [a, b, c, 0.0, 0.0, 0.0],
        omega,
        amplitude,
    )
}

/// The describing function and third harmonic of two servo effects acting together (a
/// friction in a servo that saturates): one servo simulation with both, over the linear
/// servo's, as [`servo_harmonics`] gives them for one. The product of their own describing
/// functions is only a first-order approximation: where the force limit clips, the friction
/// takes its share of a force that no longer grows with the demand. On the independent
/// simulator's held-out draw 1180037 (a friction of 0.089 m/s² in a servo limited to
/// 1.11 m/s²), the model with the drawn values was 14 500 chi-square per record off on the
/// three most saturated records with the product and within the noise elsewhere. `None` when
/// the parts do not share one servo or there are not two.
pub fn joint_servo_harmonics(
    mut parts: Vec<ServoPart>,
    omega: f64,
    amplitude: f64,
) -> Option<(Complex64, Complex64)> {
    if parts.len() != 2 {
        return None;
    }
    let (servo, h, link) = (parts[0].servo, parts[0].h, parts[0].link);
    if parts[1].servo != servo || parts[1].h != h || parts[1].link != link {
        return None;
    }
    let [a, b, c] = parts[0].identity;
    let [d, e, f] = parts[1].identity;
    let mut limits: Vec<Box<dyn Effect>> = parts.drain(..).map(|p| p.effect).collect();
    Some(ratio(
        servo,
        h,
        link,
        &mut limits,
        [a, b, c, d, e, f],
        omega,
        amplitude,
    ))
}

/// [`servo_harmonics`] with the identity of up to two effects.
fn ratio(
    servo: (f64, f64),
    h: f64,
    link: Option<TrunkLink>,
    limits: &mut [Box<dyn Effect>],
    identity: [f64; 6],
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
        [0.0; 6],
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
    let with = run_cached(servo, h, Some(link), &mut [], [0.0; 6], omega, amplitude);
    let rigid = run_cached(servo, h, None, &mut [], [0.0; 6], omega, 1.0);
    (with.first / rigid.first, with.third)
}
