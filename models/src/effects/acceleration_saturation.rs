//! Acceleration saturation of the servo (first seed, sections 4 and 6.3): the CoM cannot
//! accelerate faster than `limit`. At high frequency or amplitude this compresses the gain and
//! adds odd harmonics.

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use crate::effects::servo::servo_describing_function;
use num_complex::Complex64;

pub static PARAMS: [ParamSpec; 1] = [ParamSpec::required(
    "limit",
    "m/s2",
    1e-3,
    1e3,
    "largest CoM acceleration the servo achieves",
)];

pub static INFO: EffectInfo = EffectInfo {
    kind: "acceleration_saturation",
    title: "acceleration saturation",
    doc: "The servo's CoM acceleration is clamped to +-limit.",
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
    servo: (f64, f64),
    h: f64,
}

impl Effect for AccelerationSaturation {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn frequency_response(&self, omega: f64, amplitude: f64) -> Complex64 {
        // The linear servo's steady acceleration is -w^2 H(jw) times the reference: while its
        // amplitude stays below the limit the periodic state is the linear one.
        let (wn, zeta) = self.servo;
        let h = wn * wn / Complex64::new(wn * wn - omega * omega, 2.0 * zeta * wn * omega);
        if omega * omega * h.norm() * amplitude <= 0.999 * self.limit {
            return Complex64::new(1.0, 0.0);
        }
        let mut limits: [Box<dyn Effect>; 1] = [Box::new(self.clone())];
        servo_describing_function(
            self.servo.0,
            self.servo.1,
            self.h,
            &mut limits,
            [2.0, self.limit, 0.0],
            omega,
            amplitude,
        )
    }
    fn reset(&mut self, u: f64) -> f64 {
        u
    }
    #[inline]
    fn servo_acceleration(&mut self, demand: f64, _velocity: f64) -> f64 {
        demand.clamp(-self.limit, self.limit)
    }
}

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    Box::new(AccelerationSaturation {
        limit: v[0],
        servo: ctx.servo.unwrap_or((30.0, 1.0)),
        h: ctx.h,
    })
}
