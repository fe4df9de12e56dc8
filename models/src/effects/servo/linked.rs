//! The servo's step with a flexible trunk inside its loop (the two-body loop of
//! [`crate::effects::servo_link`]): exact while the servo effects add a constant force,
//! the creep where friction holds the joint, RK4 where they switch or clamp.

use super::step::offset;
use super::{Servo, ServoState};
use crate::effect::Effect;

impl Servo {
    /// [`Servo::step`] of the two-body loop: the exact linear step while the servo effects add
    /// a constant force (as the rigid servo's), the creep where friction holds the joint
    /// (`creep.rs`), RK4 where they switch or clamp.
    pub(super) fn step_linked(&mut self, r: f64, limits: &mut [Box<dyn Effect>]) -> ServoState {
        self.step_linked_with(r, limits, true)
    }

    /// [`Servo::step_linked`], creeping only if `creep` (without: the reference of the tests).
    pub(super) fn step_linked_with(
        &mut self,
        r: f64,
        limits: &mut [Box<dyn Effect>],
        creep: bool,
    ) -> ServoState {
        let Some(link) = self.link.take() else {
            unreachable!("step_linked without a link")
        };
        let r0 = self.r_prev;
        let dr = r - r0;
        let s = [self.x, self.v, link.xu, link.vu];
        let c0 = if self.c_end.is_nan() {
            offset(limits, self.demand(r0, s[0], s[1]), s[1])
        } else {
            self.c_end
        };
        // With play, the loop engaged on one flank is the linear loop with the trunk's
        // position shifted by the half play ([`Linked::flank`]): the exact steps below hold
        // while it stays on that flank; in the gap, or where the flanks part, the sub-steps.
        let play = link.has_play();
        let flank = link.flank(&s);
        let shift = |y: &[f64; 4], o: f64| -> [f64; 4] {
            if play {
                [y[0], y[1], y[2] + o, y[3]]
            } else {
                *y
            }
        };
        let unshift = |mut y: [f64; 4], o: f64| -> [f64; 4] {
            if play {
                y[2] -= o;
            }
            y
        };
        let stays = |y: &[f64; 4]| !play || link.flank(y) == flank;
        let exact = flank.and_then(|o| {
            let lin = unshift(link.linear(&shift(&s, o), r0 + c0 / self.wn2, dr), o);
            let c1 = offset(limits, self.demand(r, lin[0], lin[1]), lin[1]);
            if c1 == c0 && (s[1] >= 0.0) == (lin[1] >= 0.0) && stays(&lin) {
                return Some(lin);
            }
            // The force held at a limit: the chain under that constant force, exactly, if
            // the servo effects still give it at the step's end with the velocity's sign
            // kept.
            let d0 = self.demand(r0, s[0], s[1]);
            let f0 = d0 + c0;
            let e = unshift(link.free(&shift(&s, o), f0), o);
            let d1 = self.demand(r, e[0], e[1]);
            let f1 = d1 + offset(limits, d1, e[1]);
            let tol = 1e-12 * (f0.abs() + d0.abs() + d1.abs());
            (c0 != 0.0 && (f1 - f0).abs() <= tol && (s[1] >= 0.0) == (e[1] >= 0.0) && stays(&e))
                .then_some(e)
        });
        let k = if exact.is_none() {
            limits.iter().map(|l| l.stiffness()).sum()
        } else {
            0.0
        };
        let crept = match exact {
            None if creep => self.creep_linked(&link, &s, r0, r, k, limits),
            _ => None,
        };
        let end = if let Some(e) = exact.or(crept) {
            e
        } else {
            let sub = link.substeps(self.h, k);
            let hs = self.h / sub as f64;
            let mut x = s;
            let f = |limits: &mut [Box<dyn Effect>], rr: f64, y: &[f64; 4]| -> [f64; 4] {
                let force = self.accel(limits, rr, y[0], y[1]);
                let (aj, au) = link.accelerations(y, force);
                [y[1], aj, y[3], au]
            };
            // Element by element, without `array::map` closures (which did not inline here
            // and cost a tenth of a friction-heavy loop); the same arithmetic, bit for bit.
            let add = |y: &[f64; 4], d: &[f64; 4], t: f64| -> [f64; 4] {
                [
                    y[0] + t * d[0],
                    y[1] + t * d[1],
                    y[2] + t * d[2],
                    y[3] + t * d[3],
                ]
            };
            let h6 = hs / 6.0;
            for q in 0..sub {
                let ra = r0 + dr * (q as f64 / sub as f64);
                let rm = r0 + dr * ((q as f64 + 0.5) / sub as f64);
                let rb = r0 + dr * ((q + 1) as f64 / sub as f64);
                let k1 = f(limits, ra, &x);
                let k2 = f(limits, rm, &add(&x, &k1, 0.5 * hs));
                let k3 = f(limits, rm, &add(&x, &k2, 0.5 * hs));
                let k4 = f(limits, rb, &add(&x, &k3, hs));
                for i in 0..4 {
                    x[i] += h6 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
                }
            }
            x
        };
        let d = self.demand(r, end[0], end[1]);
        let c = offset(limits, d, end[1]);
        let (position, velocity, acceleration) = link.com(&end, d + c);
        (self.x, self.v) = (end[0], end[1]);
        let mut link = link;
        (link.xu, link.vu) = (end[2], end[3]);
        self.link = Some(link);
        self.c_end = c;
        self.r_prev = r;
        ServoState {
            position,
            velocity,
            acceleration,
        }
    }
}
