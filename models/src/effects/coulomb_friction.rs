//! Coulomb friction in the servo: a constant force against the motion, written as the
//! acceleration it removes. Regularised as `level * tanh(v / v_s)` with `v_s` tied to the
//! step so the integration stays stable; small motions lag and shrink, large ones barely notice.

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use crate::effects::servo::servo_describing_function;
use num_complex::Complex64;

pub static PARAMS: [ParamSpec; 1] = [ParamSpec::required(
    "level",
    "m/s2",
    0.0,
    100.0,
    "friction force over the moving mass: the CoM deceleration it causes",
)];

pub static INFO: EffectInfo = EffectInfo {
    kind: "coulomb_friction",
    title: "Coulomb friction in the servo",
    doc: "The servo's acceleration is reduced by level*sign(velocity) (regularised).",
    site: Site::Servo,
    core: false,
    linear: false,
    params: &PARAMS,
    validate: None,
    build,
};

#[derive(Debug, Clone)]
pub struct CoulombFriction {
    pub level: f64,
    inv_v_s: f64,
    servo: (f64, f64),
    h: f64,
}

impl Effect for CoulombFriction {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn frequency_response(&self, omega: f64, amplitude: f64) -> Complex64 {
        let mut limits: [Box<dyn Effect>; 1] = [Box::new(self.clone())];
        servo_describing_function(
            self.servo.0,
            self.servo.1,
            self.h,
            &mut limits,
            [1.0, self.level],
            omega,
            amplitude,
        )
    }
    fn reset(&mut self, u: f64) -> f64 {
        u
    }
    #[inline]
    fn servo_acceleration(&mut self, demand: f64, velocity: f64) -> f64 {
        let z = velocity * self.inv_v_s;
        // tanh is exactly +-1 in f64 beyond |z| = 19.1: a constant force, which lets the servo
        // take its exact linear step.
        let f = if z > 19.5 {
            1.0
        } else if z < -19.5 {
            -1.0
        } else {
            z.tanh()
        };
        demand - self.level * f
    }
}

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    // The friction slope level/v_s times the RK4 sub-step (h/4) stays at 0.5: well inside
    // RK4's stability region.
    let v_s = (v[0] * ctx.h * 0.5).max(1e-9);
    Box::new(CoulombFriction {
        level: v[0],
        inv_v_s: 1.0 / v_s,
        servo: ctx.servo.unwrap_or((30.0, 1.0)),
        h: ctx.h,
    })
}
