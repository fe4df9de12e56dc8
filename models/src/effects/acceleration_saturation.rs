//! Acceleration saturation of the servo (first seed, sections 4 and 6.3): the CoM cannot
//! accelerate faster than `limit`. At high frequency or amplitude this compresses the gain and
//! adds odd harmonics.
//!
//! The limit is the servo's force limit. Part of the tracking damping `2 zeta omega_n` may be
//! the mechanism's own viscous friction (a joint's bearing, a gear's oil, the drag of a load),
//! which keeps acting when the motor's force is at its limit: with `passive_damping = c`
//! (1/s) the servo's force is `demand + c v` clamped to `+-limit`, and the CoM acceleration
//! that force minus `c v`. In the linear range nothing changes (the total damping is the
//! tracking low-pass's); once the limit acts, a damping outside it brakes the fast, large
//! sines further than the clamp alone (`c = 0`, the seed's law).

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use crate::effects::servo::{part_harmonics, ServoPart};
use crate::effects::servo_link::{joint_response, TrunkLink};
use num_complex::Complex64;

pub static PARAMS: [ParamSpec; 2] = [
    ParamSpec::required(
        "limit",
        "m/s2",
        1e-3,
        1e3,
        "largest CoM acceleration the servo's force achieves",
    ),
    ParamSpec::optional(
        "passive_damping",
        "1/s",
        0.0,
        200.0,
        0.0,
        "viscous damping of the mechanism that acts beyond the force limit (part of 2 zeta wn)",
    ),
];

pub static INFO: EffectInfo = EffectInfo {
    kind: crate::EffectKind::AccelerationSaturation,
    title: "acceleration saturation",
    doc: "The servo's force (over the moved mass) is clamped to +-limit; passive_damping acts beyond it.",
    site: Site::Servo,
    core: false,
    linear: false,
    params: &PARAMS,
    validate: None,
    build,
};

#[derive(Debug, Clone)]
pub struct AccelerationSaturation {
    pub limit: f64,
    /// Viscous damping outside the limit, 1/s.
    pub passive_damping: f64,
    servo: (f64, f64),
    link: Option<TrunkLink>,
    h: f64,
}

impl AccelerationSaturation {
    /// The describing function and the servo's third harmonic (see [`crate::effects::servo::servo_harmonics`]).
    fn servo_harmonics(&self, omega: f64, amplitude: f64) -> (Complex64, Complex64) {
        // The linear servo's steady force (demand plus passive damping) for the joint's
        // response X_J (H on a rigid trunk): while its amplitude stays below the limit the
        // periodic state is the linear one.
        if self.servo_idle(omega, amplitude, 0.0) {
            return (Complex64::new(1.0, 0.0), Complex64::new(0.0, 0.0));
        }
        part_harmonics(self.part(), omega, amplitude)
    }

    /// What the servo simulation needs of this effect (see [`ServoPart`]).
    fn part(&self) -> ServoPart {
        ServoPart {
            effect: Box::new(self.clone()),
            servo: self.servo,
            h: self.h,
            link: self.link,
            identity: [2.0, self.limit, self.passive_damping],
        }
    }
}

impl Effect for AccelerationSaturation {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn servo_part(&self) -> Option<ServoPart> {
        Some(self.part())
    }
    /// The linear servo's steady force (demand plus passive damping) for the joint's response
    /// X_J (H on a rigid trunk), with `extra` on top, stays below the limit: the periodic state
    /// is then the one without the saturation.
    fn servo_idle(&self, omega: f64, amplitude: f64, extra: f64) -> bool {
        let (wn, zeta) = self.servo;
        let xj = joint_response(self.link, wn, zeta, omega);
        let jw = Complex64::new(0.0, omega);
        let force = wn * wn * (1.0 - xj) + jw * (self.passive_damping - 2.0 * zeta * wn) * xj;
        force.norm() * amplitude + extra <= 0.999 * self.limit
    }
    fn frequency_response(&self, omega: f64, amplitude: f64) -> Complex64 {
        self.servo_harmonics(omega, amplitude).0
    }
    fn third_harmonic(&self, omega: f64, amplitude: f64) -> Complex64 {
        self.servo_harmonics(omega, amplitude).1
    }
    fn harmonics(&self, omega: f64, amplitude: f64) -> (Complex64, Complex64) {
        self.servo_harmonics(omega, amplitude)
    }
    fn reset(&mut self, u: f64) -> f64 {
        u
    }
    #[inline]
    fn servo_acceleration(&mut self, demand: f64, velocity: f64) -> f64 {
        let c = self.passive_damping * velocity;
        (demand + c).clamp(-self.limit, self.limit) - c
    }
}

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    Box::new(AccelerationSaturation {
        limit: v[0],
        passive_damping: v.get(1).copied().unwrap_or(0.0),
        servo: ctx.servo.unwrap_or((30.0, 1.0)),
        link: ctx.link,
        h: ctx.h,
    })
}
