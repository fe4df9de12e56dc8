//! The stuck servo. Where a stiff servo effect (Coulomb friction regularised over a speed
//! `v_s` far below the motion's) holds the velocity inside its narrow band, the velocity
//! relaxes to the balance of the forces within a small fraction of a step (the rate is the
//! friction's slope `level / v_s`, thousands per second) and then follows it: the position
//! creeps at the balancing velocity (the regularised law's own creep, `v_s atanh(d / level)`
//! for a demand `d` below the friction). RK4 would need hundreds of sub-steps per step there
//! for stability alone; the creep step solves the balance three times instead (midpoint rule
//! on the slow motion). It is taken only when the velocity is already at the balance and the
//! relaxation is fast at the step's start, middle and end; entering and leaving the stick,
//! where the velocity leaves the band, RK4 takes the step as before.

use super::{substeps_for, Servo};
use crate::effect::Effect;
use crate::effects::servo_link::Linked;

/// RK4 sub-steps a step would need before the creep step is tried (below, RK4 is cheap and
/// the step's results stay exactly those of RK4).
pub(super) const CREEP_MIN_SUBSTEPS: usize = 16;
/// Step times the relaxation rate at the balance, at least: the velocity's transient is then
/// down to e^-10 by the step's end.
const CREEP_MIN_RELAXATION: f64 = 10.0;
/// Largest displacement, m, that the velocity's distance from the balance at the step's start
/// may still cause (it is added).
const CREEP_SETTLED: f64 = 1e-10;

impl Servo {
    /// The creep step from the current state, the reference moving from `r0` to `r1` (the
    /// effects' summed [`Effect::stiffness`] is `stiffness`): the end position and velocity,
    /// or `None` where the servo is not stuck (then RK4).
    pub(super) fn creep(
        &self,
        r0: f64,
        r1: f64,
        stiffness: f64,
        limits: &mut [Box<dyn Effect>],
    ) -> Option<(f64, f64)> {
        if substeps_for(self.h, stiffness) < CREEP_MIN_SUBSTEPS {
            return None;
        }
        let h = self.h;
        let k = stiffness + self.two_zeta_wn;
        let (va, sa) = self.balance(limits, r0, self.x, self.v, k, k)?;
        let settled = (self.v - va) / sa;
        if h * sa < CREEP_MIN_RELAXATION || settled.abs() > CREEP_SETTLED {
            return None;
        }
        let x0 = self.x + settled;
        let (vm, sm) = self.balance(limits, 0.5 * (r0 + r1), x0 + 0.5 * h * va, va, sa, k)?;
        let x1 = x0 + h * vm;
        let (v1, s1) = self.balance(limits, r1, x1, vm, sm, k)?;
        (h * sm.min(s1) >= CREEP_MIN_RELAXATION).then_some((x1, v1))
    }

    /// [`Servo::creep`] of the two-body loop (a link without play): the joint is the stuck,
    /// fast part (its velocity at the balance of the servo's force, friction and the link's
    /// pull), the link's part the slow one, stepped exactly behind the joint's creep (a ramp at
    /// the midpoint's balancing velocity). `s` is `[x_J, v_J, x_U, v_U]`; the end state, or
    /// `None` where the joint is not stuck.
    pub(super) fn creep_linked(
        &self,
        link: &Linked,
        s: &[f64; 4],
        r0: f64,
        r1: f64,
        stiffness: f64,
        limits: &mut [Box<dyn Effect>],
    ) -> Option<[f64; 4]> {
        let ij = link.inv_joint();
        // Only where the friction is what makes RK4 costly (the link's own speed does not
        // make the joint stick).
        if substeps_for(self.h, stiffness * ij) < CREEP_MIN_SUBSTEPS {
            return None;
        }
        let h = self.h;
        let load = link.pull(s)?;
        let k = stiffness + self.two_zeta_wn + load.1;
        let (va, sa) = self.balance_against(limits, r0, s[0], Some(load), s[1], k, k)?;
        // The joint's velocity relaxes at `slope / (1 - u)`.
        let settled = (s[1] - va) / (sa * ij);
        if h * sa * ij < CREEP_MIN_RELAXATION || settled.abs() > CREEP_SETTLED {
            return None;
        }
        let x0 = s[0] + settled;
        let xm = x0 + 0.5 * h * va;
        let (um, wm) = link.follow(true, (s[2], s[3]), x0, va);
        let mid = [xm, va, um, wm];
        let (vm, sm) =
            self.balance_against(limits, 0.5 * (r0 + r1), xm, link.pull(&mid), va, sa, k)?;
        let x1 = x0 + h * vm;
        let (u1, w1) = link.follow(false, (s[2], s[3]), x0, vm);
        let end = [x1, vm, u1, w1];
        let (v1, s1) = self.balance_against(limits, r1, x1, link.pull(&end), vm, sm, k)?;
        (h * sm.min(s1) * ij >= CREEP_MIN_RELAXATION).then_some([x1, v1, u1, w1])
    }

    /// The velocity at which the servo's acceleration vanishes at reference `r` and position
    /// `x`, and the acceleration's slope there, `-da/dv` (1/s), from a nearby `guess` and its
    /// `slope`. The acceleration falls with the velocity (damping, friction and the
    /// saturation's clamp all do): secant steps from the guess converge in a few evaluations;
    /// should they not, a bracket grows from zero (its first width from the steepest slope
    /// `k`) until the sign changes and bisection closes it.
    fn balance(
        &self,
        limits: &mut [Box<dyn Effect>],
        r: f64,
        x: f64,
        guess: f64,
        slope: f64,
        k: f64,
    ) -> Option<(f64, f64)> {
        self.balance_against(limits, r, x, None, guess, slope, k)
    }

    /// [`Servo::balance`] with a load `c0 + c1 v` subtracted from the servo's force (a linked
    /// trunk's pull, [`Linked::pull`]).
    #[allow(clippy::too_many_arguments)]
    fn balance_against(
        &self,
        limits: &mut [Box<dyn Effect>],
        r: f64,
        x: f64,
        load: Option<(f64, f64)>,
        guess: f64,
        slope: f64,
        k: f64,
    ) -> Option<(f64, f64)> {
        let mut g = |v: f64| match load {
            None => self.accel(limits, r, x, v),
            Some((c0, c1)) => self.accel(limits, r, x, v) - (c0 + c1 * v),
        };
        let converged = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs()) + 1e-18;
        let mut root = None;
        let (mut v0, mut g0, mut s) = (guess, g(guess), slope);
        for _ in 0..12 {
            if !(g0.is_finite() && s.is_finite() && s > 0.0) {
                break;
            }
            let v1 = v0 + g0 / s;
            let g1 = g(v1);
            if converged(v0, v1) || g1 == 0.0 {
                root = Some(v1);
                break;
            }
            let secant = (g0 - g1) / (v1 - v0);
            if secant > 0.0 {
                s = secant;
            }
            (v0, g0) = (v1, g1);
        }
        let v = match root {
            Some(v) => v,
            None => {
                let g0 = g(0.0);
                if !g0.is_finite() {
                    return None;
                }
                let dir = if g0 >= 0.0 { 1.0 } else { -1.0 };
                // [a, b]: g(a) has g0's sign, g(b) the other (or is zero).
                let (mut a, mut b) = (0.0, dir * (g0.abs() / k).max(1e-300));
                let mut expansions = 0;
                while g(b) * dir > 0.0 {
                    a = b;
                    b *= 2.0;
                    expansions += 1;
                    if expansions > 200 {
                        return None;
                    }
                }
                while !converged(a, b) {
                    let m = 0.5 * (a + b);
                    if m == a || m == b {
                        break;
                    }
                    if g(m) * dir > 0.0 {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                0.5 * (a + b)
            }
        };
        let dv = 1e-6 * v.abs().max(1e-12);
        let slope = (g(v - dv) - g(v + dv)) / (2.0 * dv);
        (slope.is_finite() && slope > 0.0).then_some((v, slope))
    }
}

#[cfg(test)]
mod tests {
    use crate::effect::{BuildContext, Effect};
    use crate::effects::servo::Servo;
    use crate::effects::servo_link::TrunkLink;
    use crate::{Axis, Binding};

    const H: f64 = 0.005;

    fn friction(level: f64, v_s: f64) -> Vec<Box<dyn Effect>> {
        let ctx = BuildContext {
            h: H,
            binding: Binding::Axis(Axis::X),
            servo: Some((30.0, 1.0)),
            link: None,
        };
        vec![(crate::EffectKind::CoulombFriction.info().build)(
            &ctx,
            &[level, v_s],
        )]
    }

    /// Two periods of the reference `amplitude sin(omega t)` through `servo_step` (the
    /// servo's position after a step to `r`, and whether the creep took that step) and
    /// `reference_step` (the reference integration's position). Where the friction holds the
    /// servo most of the time (`sticks`) the creep must be taken on a quarter of the steps at
    /// least (it is what is being tested), and the positions must agree to 1e-4 of the
    /// amplitude (RK4's own sub-step error is of that order).
    fn follows_reference(
        (level, v_s, omega, amplitude, sticks): (f64, f64, f64, f64, bool),
        mut servo_step: impl FnMut(f64) -> (f64, bool),
        mut reference_step: impl FnMut(f64) -> f64,
    ) {
        let steps = (2.0 * 2.0 * std::f64::consts::PI / omega / H) as usize;
        let (mut worst, mut crept) = (0.0f64, 0);
        for k in 1..=steps {
            let r = amplitude * (omega * k as f64 * H).sin();
            let (x, creeping) = servo_step(r);
            crept += usize::from(creeping);
            worst = worst.max((x - reference_step(r)).abs());
        }
        assert!(
            !sticks || crept >= steps / 4,
            "level {level} omega {omega}: crept {crept} of {steps} steps"
        );
        assert!(
            worst <= 1e-4 * amplitude,
            "level {level} v_s {v_s} omega {omega}: {worst:e} m apart (amplitude {amplitude})"
        );
    }

    /// Sticking and slipping runs: the servo's steps (creeping where stuck, RK4 on the
    /// sub-steps of the step's speeds where it slips) against RK4 on every step with the
    /// sub-steps of zero velocity ([`follows_reference`]).
    #[test]
    fn creeping_and_speed_stepped_servo_follows_rk4_through_stick_and_slip() {
        for &case in &[
            (2.5, 1e-4, 0.5, 0.003, true),
            (1.0, 1e-4, 2.0, 0.003, false),
            (2.0, 1e-5, 1.0, 0.004, true),
            (0.5, 1e-4, 6.0, 0.002, false),
        ] {
            let mut limits = friction(case.0, case.1);
            let mut reference = friction(case.0, case.1);
            let mut servo = Servo::new(30.0, 1.0, H);
            let mut plain = Servo::new(30.0, 1.0, H);
            servo.reset(0.0);
            plain.reset(0.0);
            follows_reference(
                case,
                |r| {
                    let stiffness: f64 = limits.iter().map(|l| l.stiffness()).sum();
                    let crept = servo
                        .creep(servo.r_prev, r, stiffness, &mut limits)
                        .is_some();
                    (servo.step(r, &mut limits).position, crept)
                },
                |r| {
                    (plain.x, plain.v) = plain.rk4(plain.r_prev, r - plain.r_prev, &mut reference);
                    plain.r_prev = r;
                    plain.x
                },
            );
        }
    }

    /// The flexible trunk inside the servo, its joint held by friction and slipping: the
    /// loop's steps (creeping where the joint is stuck) against the same loop without the
    /// creep (RK4 on the sub-steps of zero velocity); the CoM (joint and ringing trunk) is
    /// compared ([`follows_reference`]).
    #[test]
    fn creeping_linked_servo_follows_rk4_through_stick_and_slip() {
        for &(level, v_s, omega, amplitude, link, sticks) in &[
            (2.5, 1e-4, 0.5, 0.003, (14.0, 0.08, 0.35, 0.29), true),
            (2.5, 1e-4, 3.0, 0.003, (14.0, 0.08, 0.35, 0.29), true),
            (2.0, 1e-5, 1.0, 0.004, (40.0, 0.2, 0.6, 0.1), true),
            (1.0, 1e-4, 2.0, 0.003, (14.0, 0.08, 0.35, 0.29), false),
            (0.5, 1e-4, 6.0, 0.002, (25.0, 0.05, 0.5, 0.0), false),
        ] {
            let link = TrunkLink::flexible(link.0, link.1, link.2, link.3);
            let mut limits = friction(level, v_s);
            let mut reference = friction(level, v_s);
            let mut servo = Servo::new(30.0, 1.0, H).with_link(link);
            let mut plain = Servo::new(30.0, 1.0, H).with_link(link);
            servo.reset(0.0);
            plain.reset(0.0);
            follows_reference(
                (level, v_s, omega, amplitude, sticks),
                |r| {
                    let stiffness: f64 = limits.iter().map(|l| l.stiffness()).sum();
                    let l = servo.link.as_deref().unwrap();
                    let s = [servo.x, servo.v, l.xu, l.vu];
                    let crept = servo
                        .creep_linked(l, &s, servo.r_prev, r, stiffness, &mut limits)
                        .is_some();
                    (servo.step(r, &mut limits).position, crept)
                },
                |r| plain.step_linked_with(r, &mut reference, false).position,
            );
        }
    }
}
