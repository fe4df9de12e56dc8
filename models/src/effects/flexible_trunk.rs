//! A flexible trunk: a `share` of the moving mass sits on a lightly damped link (spring and
//! damper, mode `omega_m`, `zeta_m`) above the servoed joint, the rest moves with the joint.
//! The CoM rings and the link's reaction loads the servo, which is tuned for the whole mass
//! (the seed's `H = wn^2/(s^2 + 2 zeta wn s + wn^2)` on a rigid trunk).
//!
//! Per input axis, with the joint at `x_J`, the link's part at `x_U = M x_J`,
//! `M = (2 zeta_m w_m s + w_m^2)/(s^2 + 2 zeta_m w_m s + w_m^2)`, and the CoM
//! `x_c = Q x_J`, `Q = (1 - share) + share M` (`share` of the load's mass on the link). The
//! servo's force `wn^2 (r - x_J) - 2 zeta wn x_J'` (per unit of the axis's inertia, which may
//! include a `drive` fraction, the motor's reflected inertia, that moves with the joint but
//! is not part of the CoM) accelerates the inertia: `s^2 Q' x_J = wn^2 (r - x_J) - 2 zeta wn
//! s x_J` with `Q' = (1 - share') + share' M`, `share' = share (1 - drive)`. So
//! `x_c = Q wn^2 / (s^2 Q' + 2 zeta wn s + wn^2) r`, and this effect's frequency response is
//! the factor that turns the rigid trunk's `H` into that:
//! `F = Q (s^2 + 2 zeta wn s + wn^2) / (s^2 Q' + 2 zeta wn s + wn^2)`, a linear filter of the
//! CoM reference (unit gain at rest) built from the axis's tracking low-pass. With
//! `in_servo = 1` the plant steps the two bodies inside the servo's loop instead
//! ([`crate::effects::servo_link`]), so that a force limit or friction acts on the servo's
//! force, as on the robot; the linear response is the same. Where the structural mode acts on
//! the ZMP measurement instead (`structural_mode`), the mode does not feed back into the
//! servo.

use crate::effect::{check_switch, BuildContext, Effect, EffectInfo, ParamSpec, Site};
use crate::lti::{Poly, TransferFunction};
use crate::lti_effect::LtiEffect;

pub static PARAMS: [ParamSpec; 5] = [
    ParamSpec::required("omega_n", "rad/s", 0.1, 2000.0, "mode of the flexible link"),
    ParamSpec::required("zeta", "1", 1e-3, 1.0, "damping ratio of the flexible link"),
    ParamSpec::optional(
        "share",
        "1",
        0.0,
        1.0,
        0.5,
        "part of the axis's moving mass on the flexible link",
    ),
    ParamSpec::optional(
        "drive",
        "1",
        0.0,
        0.9,
        0.0,
        "part of the axis's inertia in the drive (moves with the joint, not in the CoM)",
    ),
    ParamSpec::optional(
        "in_servo",
        "1",
        0.0,
        1.0,
        0.0,
        "1: the two bodies stepped inside the servo's loop, so a force limit or friction acts on the force that drives them; 0: the small-signal filter before the servo",
    ),
];

/// `in_servo` is a switch between two laws, 0 or 1.
fn validate(v: &[f64]) -> Result<(), (usize, String)> {
    check_switch(
        v,
        4,
        "a filter of the CoM reference before the servo",
        "stepped inside the servo's loop",
    )
}

pub static INFO: EffectInfo = EffectInfo {
    kind: crate::EffectKind::FlexibleTrunk,
    title: "flexible trunk (a share of the mass on a flexible link, in the servo loop)",
    doc: "x_c = Q wn^2/(s^2 Q + 2 zeta wn s + wn^2) x_cr, Q = (1-share) + share M(s), per input axis.",
    site: Site::Command,
    core: false,
    linear: true,
    params: &PARAMS,
    validate: Some(validate),
    build,
};

/// The filter `F(s)` for the servo `(wn, zeta)` and the link `(w_m, zeta_m, share, drive)`.
pub fn tf(
    servo: (f64, f64),
    omega_m: f64,
    zeta_m: f64,
    share: f64,
    drive: f64,
) -> TransferFunction {
    let (wn, zeta) = servo;
    let wm2 = omega_m * omega_m;
    let c = 2.0 * zeta_m * omega_m;
    let share_i = share * (1.0 - drive);
    // Q = N_q / D_m, Q' = N_i / D_m: (1 - sh) D_m + sh (c s + wm2) = wm2 + c s + (1 - sh) s^2.
    let d_m = Poly::new(&[wm2, c, 1.0]);
    let n_q = Poly::new(&[wm2, c, 1.0 - share]);
    let n_i = Poly::new(&[wm2, c, 1.0 - share_i]);
    let h_den = Poly::new(&[wn * wn, 2.0 * zeta * wn, 1.0]);
    let s2 = Poly::new(&[0.0, 0.0, 1.0]);
    let servo_term = Poly::new(&[wn * wn, 2.0 * zeta * wn]);
    TransferFunction::new(n_q.mul(&h_den), s2.mul(&n_i).add(&servo_term.mul(&d_m)))
}

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    let servo = ctx.servo.unwrap_or((30.0, 1.0));
    let share = v.get(2).copied().unwrap_or(0.5);
    let drive = v.get(3).copied().unwrap_or(0.0);
    Box::new(LtiEffect::new(
        &INFO,
        tf(servo, v[0], v[1], share, drive),
        ctx.h,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex64;

    /// The CoM response `H F` equals the two-body servo loop solved directly at each
    /// frequency, and a rigid link (share 0) changes nothing.
    #[test]
    fn equals_the_two_body_servo_loop() {
        let (wn, zeta) = (30.0, 0.9);
        let (wm, zm, share, drive) = (18.0, 0.05, 0.4, 0.3);
        let f = tf((wn, zeta), wm, zm, share, drive);
        for w in [0.3, 5.0, 17.0, 18.0, 25.0, 60.0] {
            // Two bodies solved directly: drive + joint (inertia 1 - u) and the link's part
            // (inertia u), the CoM weighting joint and link by their load masses.
            let s = Complex64::new(0.0, w);
            let u = share * (1.0 - drive);
            let m = (2.0 * zm * wm * s + wm * wm) / (s * s + 2.0 * zm * wm * s + wm * wm);
            let q = (1.0 - share) + share * m;
            let x_j = wn * wn / (s * s * ((1.0 - u) + u * m) + 2.0 * zeta * wn * s + wn * wn);
            let direct = q * x_j;
            let h = wn * wn / (s * s + 2.0 * zeta * wn * s + wn * wn);
            let got = h * f.freq(w);
            assert!(
                (got - direct).norm() < 1e-12 * direct.norm().max(1.0),
                "{w}"
            );
        }
        assert!((f.freq(1e-6) - 1.0).norm() < 1e-9);
        let rigid = tf((wn, zeta), wm, zm, 0.0, drive);
        for w in [0.5, 20.0, 80.0] {
            assert!((rigid.freq(w) - 1.0).norm() < 1e-12);
        }
    }
}
