//! Coulomb friction in the servo: a constant force against the motion, written as the
//! acceleration it removes. Regularised as `level * tanh(v / v_s)`: `v_s` (m/s) is a physical
//! parameter, the speed below which the friction force builds up (the width of the
//! stick-slip transition; default 0.1 mm/s, far below the trunk speeds of a stepped-sine
//! campaign). It does not depend on the plant's step: the servo integrates the stiff part with
//! as many RK4 sub-steps as `level / v_s` needs (see [`CoulombFriction::stiffness`]). Small
//! motions lag and shrink, large ones barely notice.

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use crate::effects::servo::{part_harmonics, ServoPart};
use crate::effects::servo_link::TrunkLink;
use num_complex::Complex64;

/// Default regularisation speed, m/s.
pub const DEFAULT_V_S: f64 = 1e-4;

pub static PARAMS: [ParamSpec; 2] = [
    ParamSpec::required(
        "level",
        "m/s2",
        0.0,
        100.0,
        "friction force over the moving mass: the CoM deceleration it causes",
    ),
    ParamSpec::optional(
        "v_s",
        "m/s",
        1e-6,
        1.0,
        DEFAULT_V_S,
        "regularisation speed: the friction is level tanh(v / v_s), full beyond a few v_s",
    ),
];

pub static INFO: EffectInfo = EffectInfo {
    kind: crate::EffectKind::CoulombFriction,
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
    /// Regularisation speed, m/s.
    pub v_s: f64,
    inv_v_s: f64,
    servo: (f64, f64),
    /// The flexible trunk the servo drives (inside its loop), if any.
    pub link: Option<TrunkLink>,
    h: f64,
}

impl CoulombFriction {
    pub fn new(level: f64, v_s: f64, servo: (f64, f64), h: f64) -> CoulombFriction {
        CoulombFriction {
            level,
            v_s,
            inv_v_s: 1.0 / v_s,
            servo,
            link: None,
            h,
        }
    }
}

impl CoulombFriction {
    /// The describing function and the servo's third harmonic (see [`crate::effects::servo::servo_harmonics`]).
    fn servo_harmonics(&self, omega: f64, amplitude: f64) -> (Complex64, Complex64) {
        part_harmonics(self.part(), omega, amplitude)
    }

    /// What the servo simulation needs of this effect (see [`ServoPart`]).
    fn part(&self) -> ServoPart {
        ServoPart {
            effect: Box::new(self.clone()),
            servo: self.servo,
            h: self.h,
            link: self.link,
            identity: [1.0, self.level, self.v_s],
        }
    }
}

impl Effect for CoulombFriction {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn servo_part(&self) -> Option<ServoPart> {
        Some(self.part())
    }
    fn servo_force_bound(&self) -> f64 {
        self.level
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
        demand - self.level * friction_shape(velocity * self.inv_v_s)
    }
    /// The steepest slope of the friction against velocity: `level / v_s`, 1/s.
    fn stiffness(&self) -> f64 {
        self.level * self.inv_v_s
    }
    /// The slope `level / v_s sech^2(v / v_s)` at the lowest speed: it only falls above it.
    fn stiffness_at(&self, speed: f64) -> f64 {
        let c = (speed * self.inv_v_s).min(300.0).cosh();
        self.stiffness() / (c * c)
    }
}

/// `tanh(z)`, exactly +-1 beyond |z| = 19.5 (a constant force, which lets the servo take its
/// exact linear step), otherwise `(1 - e) / (1 + e)` with `e = exp(-2|z|)`: within 4e-16 of
/// `tanh` everywhere (the friction force is `level` times it, so that is its absolute error,
/// not a relative one), at a third of the cost of the library's `tanh` (which goes through
/// `expm1` for relative accuracy at tiny `z`). A loop whose search refits a servo with
/// friction spends most of its time here: RK4 evaluates it four times per sub-step.
#[inline]
pub fn friction_shape(z: f64) -> f64 {
    let a = z.abs();
    if a > 19.5 {
        return 1.0f64.copysign(z);
    }
    let e = (-2.0 * a).exp();
    ((1.0 - e) / (1.0 + e)).copysign(z)
}

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    let mut f = CoulombFriction::new(
        v[0],
        v.get(1).copied().unwrap_or(DEFAULT_V_S),
        ctx.servo.unwrap_or((30.0, 1.0)),
        ctx.h,
    );
    f.link = ctx.link;
    Box::new(f)
}

#[cfg(test)]
mod tests {
    use super::friction_shape;

    /// Against the library's `tanh` on a dense grid, tiny arguments and both signs included:
    /// the absolute error bound the friction force relies on, oddness, monotonicity, and the
    /// exact +-1 beyond 19.5 that the servo's exact step needs.
    #[test]
    fn friction_shape_is_tanh_to_the_last_bits() {
        let mut zs: Vec<f64> = (-250_000..=250_000).map(|k| k as f64 * 1e-4).collect();
        zs.extend((1..300).map(|k| 10f64.powf(-(k as f64) / 10.0)));
        zs.extend([0.0, 1e-300, 5e-324, 19.49999, 19.5, 19.50001, 1e3, f64::MAX]);
        let mut worst = 0.0f64;
        for &z in &zs {
            for z in [z, -z] {
                let (f, t) = (friction_shape(z), z.tanh());
                worst = worst.max((f - t).abs());
                assert_eq!(friction_shape(-z), -f, "odd at {z}");
                if z.abs() > 19.5 {
                    assert_eq!(f, 1.0f64.copysign(z), "saturated at {z}");
                }
            }
        }
        assert!(worst <= 4e-16, "worst absolute error {worst:e}");
        assert_eq!(friction_shape(0.0), 0.0);
        // Nondecreasing through the grid (a friction that pushed back less at a higher speed
        // would be a numerical artefact).
        let grid: Vec<f64> = (-250_000..=250_000).map(|k| k as f64 * 1e-4).collect();
        for w in grid.windows(2) {
            assert!(friction_shape(w[1]) >= friction_shape(w[0]), "at {}", w[0]);
        }
    }
}
