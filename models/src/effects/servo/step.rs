//! The servo's step: the exact linear step while the servo effects add a constant to the
//! acceleration, the exact constant-acceleration step where they clamp it, RK4 on as many
//! sub-steps as their stiffness needs where they switch; the sub-step limits.

use super::{Servo, ServoState};
use crate::effect::Effect;

impl Servo {
    /// The CoM acceleration that the servo's force `force` gives at the current state.
    #[inline]
    fn com_acceleration(&self, force: f64) -> f64 {
        match self.link.as_deref() {
            None => force,
            Some(l) => l.com(&[self.x, self.v, l.xu, l.vu], force).2,
        }
    }

    #[inline]
    pub(super) fn demand(&self, r: f64, x: f64, v: f64) -> f64 {
        self.wn2 * (r - x) - self.two_zeta_wn * v
    }

    /// The exact linear step from the current state, the reference moving linearly from `r0`
    /// to `r0 + dr`.
    #[inline]
    fn linear(&self, r0: f64, dr: f64) -> (f64, f64) {
        (
            self.phi[0][0] * self.x + self.phi[0][1] * self.v + self.g0[0] * r0 + self.g1[0] * dr,
            self.phi[1][0] * self.x + self.phi[1][1] * self.v + self.g0[1] * r0 + self.g1[1] * dr,
        )
    }

    /// [`Servo::step`] with the reference jumping to `jump` at the step's start (a held
    /// command switching): the position and velocity are continuous, the acceleration jumps.
    /// Returns the acceleration just after the jump (`None` without one) and the state at the
    /// step's end.
    #[inline]
    pub fn step_span(
        &mut self,
        jump: Option<f64>,
        r: f64,
        limits: &mut [Box<dyn Effect>],
    ) -> (Option<f64>, ServoState) {
        let start = jump.map(|r0| {
            self.r_prev = r0;
            self.c_end = f64::NAN;
            let d = self.demand(r0, self.x, self.v);
            self.com_acceleration(d + offset(limits, d, self.v))
        });
        (start, self.step(r, limits))
    }

    /// Advances one step; the reference has moved linearly from the previous value to `r`.
    ///
    /// When the servo effects only add a constant `c` to the acceleration through the step (the
    /// saturation not acting, friction keeping its sign), the servo is linear with the reference
    /// shifted by `c / wn^2`, and the exact step is taken. A servo stuck by a stiff friction
    /// creeps at the balance of forces (`creep.rs`). Otherwise RK4, on as many sub-steps as the
    /// effects' stiffness at this step's speeds needs (at least four).
    #[inline]
    pub fn step(&mut self, r: f64, limits: &mut [Box<dyn Effect>]) -> ServoState {
        if self.link.is_some() {
            return self.step_linked(r, limits);
        }
        let r0 = self.r_prev;
        let dr = r - r0;
        let acceleration;
        if limits.is_empty() {
            (self.x, self.v) = self.linear(r0, dr);
            acceleration = self.demand(r, self.x, self.v);
        } else {
            // The offset at the end of the last step is the one at the start of this one.
            let c0 = if self.c_end.is_nan() {
                offset(limits, self.demand(r0, self.x, self.v), self.v)
            } else {
                self.c_end
            };
            let (xl, vl) = self.linear(r0 + c0 / self.wn2, dr);
            let d1 = self.demand(r, xl, vl);
            let c1 = offset(limits, d1, vl);
            let same_sign = (self.v >= 0.0) == (vl >= 0.0);
            if c1 == c0 && same_sign {
                (self.x, self.v) = (xl, vl);
                acceleration = d1 + c1;
                self.c_end = c1;
            } else if let Some((x, v, c)) = self.constant_acceleration(r0, r, c0, limits) {
                (self.x, self.v) = (x, v);
                acceleration = self.demand(r, x, v) + c;
                self.c_end = c;
            } else {
                let stiffness: f64 = limits.iter().map(|l| l.stiffness()).sum();
                (self.x, self.v) = match self.creep(r0, r, stiffness, limits) {
                    Some(end) => end,
                    None => self.rk4_at_speed(r0, dr, vl, stiffness, limits),
                };
                let d = self.demand(r, self.x, self.v);
                let c = offset(limits, d, self.v);
                acceleration = d + c;
                self.c_end = c;
            }
        }
        self.r_prev = r;
        ServoState {
            position: self.x,
            velocity: self.v,
            acceleration,
        }
    }

    /// The exact step when the servo effects hold the acceleration itself constant (the
    /// saturation clamping, with friction keeping its sign): the same acceleration at both
    /// ends of the step, velocity sign unchanged. Returns the end state and offset.
    #[inline]
    fn constant_acceleration(
        &self,
        r0: f64,
        r: f64,
        c0: f64,
        limits: &mut [Box<dyn Effect>],
    ) -> Option<(f64, f64, f64)> {
        let d0 = self.demand(r0, self.x, self.v);
        let a0 = d0 + c0;
        if c0 == 0.0 {
            return None;
        }
        let h = self.h;
        let (x, v) = (self.x + h * (self.v + 0.5 * a0 * h), self.v + a0 * h);
        let d1 = self.demand(r, x, v);
        let c1 = offset(limits, d1, v);
        let a1 = d1 + c1;
        let tol = 1e-12 * (a0.abs() + d0.abs() + d1.abs());
        ((a1 - a0).abs() <= tol && (self.v >= 0.0) == (v >= 0.0)).then_some((x, v, c1))
    }

    /// [`Servo::rk4`] with the sub-steps the effects need at the speeds of this step: where the
    /// velocity keeps its sign and stays away from zero (the start and the linear loop's end
    /// `v_linear` both), friction is nearly constant and far less stiff than at zero velocity
    /// (the slope of `tanh` falls as `e^{-2|v|/v_s}`). The run is kept only if every sub-step
    /// stayed above half that speed with the same sign; otherwise the step is taken again with
    /// the sub-steps of zero velocity (`stiffness`, the effects' summed [`Effect::stiffness`]).
    fn rk4_at_speed(
        &self,
        r0: f64,
        dr: f64,
        v_linear: f64,
        stiffness: f64,
        limits: &mut [Box<dyn Effect>],
    ) -> (f64, f64) {
        let full = substeps_for(self.h, stiffness);
        if full > MIN_SUBSTEPS && (self.v > 0.0) == (v_linear > 0.0) {
            let speed = 0.5 * self.v.abs().min(v_linear.abs());
            let k: f64 = limits.iter().map(|l| l.stiffness_at(speed)).sum();
            let sub = substeps_for(self.h, k);
            if sub < full {
                let (x, v, slowest) = self.rk4_with(r0, dr, sub, limits);
                if slowest >= speed && (v > 0.0) == (self.v > 0.0) {
                    return (x, v);
                }
            }
        }
        let (x, v, _) = self.rk4_with(r0, dr, full, limits);
        (x, v)
    }

    /// RK4 with the sub-steps of zero velocity on every step (the reference of the tests).
    #[cfg(test)]
    pub(super) fn rk4(&self, r0: f64, dr: f64, limits: &mut [Box<dyn Effect>]) -> (f64, f64) {
        let k: f64 = limits.iter().map(|l| l.stiffness()).sum();
        let (x, v, _) = self.rk4_with(r0, dr, substeps_for(self.h, k), limits);
        (x, v)
    }

    /// RK4 on `sub` sub-steps: the end position and velocity, and the lowest speed at a
    /// sub-step's end with the starting velocity's sign (0 if the sign changed).
    fn rk4_with(
        &self,
        r0: f64,
        dr: f64,
        sub: usize,
        limits: &mut [Box<dyn Effect>],
    ) -> (f64, f64, f64) {
        let hs = self.h / sub as f64;
        let (mut x, mut v) = (self.x, self.v);
        let sign = if self.v >= 0.0 { 1.0 } else { -1.0 };
        let mut slowest = f64::INFINITY;
        for k in 0..sub {
            let ra = r0 + dr * (k as f64 / sub as f64);
            let rm = r0 + dr * ((k as f64 + 0.5) / sub as f64);
            let rb = r0 + dr * ((k + 1) as f64 / sub as f64);
            let k1v = self.accel(limits, ra, x, v);
            let k1x = v;
            let k2v = self.accel(limits, rm, x + 0.5 * hs * k1x, v + 0.5 * hs * k1v);
            let k2x = v + 0.5 * hs * k1v;
            let k3v = self.accel(limits, rm, x + 0.5 * hs * k2x, v + 0.5 * hs * k2v);
            let k3x = v + 0.5 * hs * k2v;
            let k4v = self.accel(limits, rb, x + hs * k3x, v + hs * k3v);
            let k4x = v + hs * k3v;
            x += hs / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
            v += hs / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
            slowest = slowest.min((sign * v).max(0.0));
        }
        (x, v, slowest)
    }

    #[inline]
    pub(super) fn accel(&self, limits: &mut [Box<dyn Effect>], r: f64, x: f64, v: f64) -> f64 {
        let mut a = self.demand(r, x, v);
        for l in limits.iter_mut() {
            a = l.servo_acceleration(a, v);
        }
        a
    }
}

/// Fewest RK4 sub-steps of a servo step.
const MIN_SUBSTEPS: usize = 4;
/// Most RK4 sub-steps of a servo step; [`max_step`] keeps a plant's step within them.
pub const MAX_SUBSTEPS: usize = 4096;
/// Sub-step times the servo effects' stiffness: 2 is inside RK4's stability region on the
/// negative real axis (2.78) with the stiff part damped (amplification 1/3 per sub-step); the
/// stiffness is friction's slope at zero velocity, felt only while the velocity crosses
/// zero, and the describing functions agree with a four times finer sub-step to 1e-4
/// (`models/examples/dfbench.rs`) at a quarter of the cost.
pub(crate) const SUBSTEP_STIFFNESS: f64 = 2.0;

/// RK4 sub-steps of a step `h` for the servo effects' stiffness `k` (1/s): at least
/// [`MIN_SUBSTEPS`], more when a stiff effect (regularised friction) needs them, at most
/// [`MAX_SUBSTEPS`].
#[inline]
pub(super) fn substeps_for(h: f64, k: f64) -> usize {
    let n = (h * k / SUBSTEP_STIFFNESS).ceil();
    if n.is_finite() {
        (n as usize).clamp(MIN_SUBSTEPS, MAX_SUBSTEPS)
    } else {
        MAX_SUBSTEPS
    }
}

/// The longest servo step the effects `limits` allow: RK4 with [`MAX_SUBSTEPS`] sub-steps
/// stays within its stability margin (infinite without stiff effects).
pub fn max_step(limits: &[Box<dyn Effect>]) -> f64 {
    let k: f64 = limits.iter().map(|l| l.stiffness()).sum();
    if k > 0.0 {
        SUBSTEP_STIFFNESS * MAX_SUBSTEPS as f64 / k
    } else {
        f64::INFINITY
    }
}

/// What the servo effects add to the demanded acceleration.
#[inline]
pub(super) fn offset(limits: &mut [Box<dyn Effect>], demand: f64, v: f64) -> f64 {
    let mut a = demand;
    for l in limits.iter_mut() {
        a = l.servo_acceleration(a, v);
    }
    a - demand
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::servo::servo_first_harmonic;
    use crate::effects::servo::tests::limit;

    /// Largest position difference over 5 s between the servo's own step (h = 1 ms) and RK4 on
    /// a 50x finer grid, with the same effect, for a reference sine of `amplitude` at `omega`.
    fn worst_against_fine_rk4(
        kind: crate::EffectKind,
        value: f64,
        amplitude: f64,
        omega: f64,
    ) -> f64 {
        let (h, fine) = (1e-3, 50);
        let mut fast = Servo::new(30.0, 1.0, h);
        let mut lf = [limit(kind, value, h)];
        let mut reference = Servo::new(30.0, 1.0, h / fine as f64);
        let mut lr = [limit(kind, value, h)];
        fast.reset(0.0);
        reference.reset(0.0);
        let mut worst: f64 = 0.0;
        for k in 1..=5000 {
            let t = k as f64 * h;
            let a = fast.step(amplitude * (omega * t).sin(), &mut lf);
            for m in 1..=fine {
                let tm = (k - 1) as f64 * h + m as f64 * h / fine as f64;
                let r = amplitude * (omega * tm).sin();
                let r0 = reference.r_prev;
                (reference.x, reference.v) = reference.rk4(r0, r - r0, &mut lr);
                reference.r_prev = r;
            }
            worst = worst.max((a.position - reference.x).abs());
        }
        worst
    }

    /// Deep in saturation (the servo clamped most of each period, bang-bang): the
    /// constant-acceleration step.
    #[test]
    fn constant_acceleration_path_matches_fine_rk4_in_saturation() {
        let worst =
            worst_against_fine_rk4(crate::EffectKind::AccelerationSaturation, 0.8, 0.008, 15.0);
        assert!(
            worst < 2e-6,
            "fast path departs from fine RK4 by {worst} m (amplitude 8 mm)"
        );
    }

    /// Under friction: the constant-force step.
    #[test]
    fn fast_path_matches_fine_rk4_under_friction() {
        let worst = worst_against_fine_rk4(crate::EffectKind::CoulombFriction, 0.05, 0.005, 3.0);
        assert!(
            worst < 2e-7,
            "fast path departs from fine RK4 by {worst} m (amplitude 5 mm)"
        );
    }

    /// The friction's regularisation is physics (`v_s`), not numerics: the servo with
    /// friction stepped at 1 ms and at 0.1 ms follows the same trajectory (within 0.1 um on a
    /// 5 mm sine), and its describing function does not move with the plant's step.
    #[test]
    fn friction_does_not_depend_on_the_step() {
        let run = |h: f64| -> Vec<f64> {
            let mut servo = Servo::new(30.0, 1.0, h);
            let mut l = [limit(crate::EffectKind::CoulombFriction, 0.3, h)];
            servo.reset(0.0);
            let per_ms = (1e-3 / h).round() as usize;
            let mut out = Vec::new();
            for k in 1..=3000 * per_ms {
                let t = k as f64 * h;
                let x = servo.step(0.005 * (3.0 * t).sin(), &mut l).position;
                if k % per_ms == 0 {
                    out.push(x);
                }
            }
            out
        };
        let (coarse, fine) = (run(1e-3), run(1e-4));
        let worst = coarse
            .iter()
            .zip(&fine)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(
            worst < 1e-7,
            "1 ms and 0.1 ms trajectories differ by {worst} m"
        );
        let df = |h: f64| {
            let mut l = [limit(crate::EffectKind::CoulombFriction, 0.3, h)];
            servo_first_harmonic(30.0, 1.0, h, &mut l, 3.0, 0.005)
                / servo_first_harmonic(30.0, 1.0, h, &mut [], 3.0, 0.005)
        };
        let (a, b) = (df(1e-3), df(2e-3));
        assert!(
            (a - b).norm() < 1e-4 * a.norm(),
            "describing function at 1 ms {a} and 2 ms {b}"
        );
    }
}
