//! The servo of one input axis: the CoM follows its reference through the tracking low-pass
//! `x'' = wn^2 (r - x) - 2 zeta wn x'`, and servo effects (acceleration saturation, Coulomb
//! friction) limit the acceleration it achieves.
//!
//! Without servo effects the step is the exact first-order-hold discretisation. With them it
//! stays exact while they only add a constant to the acceleration (see [`Servo::step`]), and is
//! RK4 on four sub-steps, the reference interpolated linearly, where they switch.

use crate::effect::Effect;
use crate::effects::servo_link::{Linked, TrunkLink};
use crate::effects::tracking_lowpass::TrackingLowpass;
use crate::lti::discretise_foh;
use crate::memo::Memo;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

mod creep;

/// CoM state of one axis after a step.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ServoState {
    /// CoM position, m.
    pub position: f64,
    /// CoM velocity, m/s.
    pub velocity: f64,
    /// CoM acceleration, m/s².
    pub acceleration: f64,
}

#[derive(Debug, Clone)]
pub struct Servo {
    h: f64,
    wn2: f64,
    two_zeta_wn: f64,
    phi: [[f64; 2]; 2],
    g0: [f64; 2],
    g1: [f64; 2],
    x: f64,
    v: f64,
    r_prev: f64,
    /// What the servo effects added to the acceleration at the current state (NaN: unknown).
    c_end: f64,
    /// A flexible trunk inside the loop (then `x`, `v` are the joint's; see
    /// [`crate::effects::servo_link`]).
    link: Option<Box<Linked>>,
}

impl Servo {
    pub fn new(omega_n: f64, zeta: f64, h: f64) -> Servo {
        let wn2 = omega_n * omega_n;
        let two_zeta_wn = 2.0 * zeta * omega_n;
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -wn2, -two_zeta_wn]);
        let b = DVector::from_row_slice(&[0.0, wn2]);
        let (phi, g0, g1) = discretise_foh(&a, &b, h);
        Servo {
            h,
            wn2,
            two_zeta_wn,
            phi: [[phi[(0, 0)], phi[(0, 1)]], [phi[(1, 0)], phi[(1, 1)]]],
            g0: [g0[0], g0[1]],
            g1: [g1[0] / h, g1[1] / h],
            x: 0.0,
            v: 0.0,
            r_prev: 0.0,
            c_end: f64::NAN,
            link: None,
        }
    }

    /// The servo driving a flexible trunk `link` (the two-body loop of
    /// [`crate::effects::servo_link`]); its state says where the CoM is.
    pub fn with_link(mut self, link: TrunkLink) -> Servo {
        self.link = Some(Box::new(Linked::new(
            link,
            self.wn2,
            self.two_zeta_wn,
            self.h,
        )));
        self
    }

    /// At rest at the reference `r`.
    pub fn reset(&mut self, r: f64) {
        self.x = r;
        self.v = 0.0;
        self.r_prev = r;
        self.c_end = f64::NAN;
        if let Some(l) = self.link.as_deref_mut() {
            l.xu = r;
            l.vu = 0.0;
        }
    }

    /// The state: joint position and velocity, then the link's (with one).
    fn state(&self) -> Vec<f64> {
        match self.link.as_deref() {
            None => vec![self.x, self.v],
            Some(l) => vec![self.x, self.v, l.xu, l.vu],
        }
    }

    /// Sets the state ([`Servo::state`]'s layout); the servo effects' offset is recomputed.
    fn set_state(&mut self, s: &[f64]) {
        (self.x, self.v) = (s[0], s[1]);
        if let (Some(l), Some(u)) = (self.link.as_deref_mut(), s.get(2..4)) {
            (l.xu, l.vu) = (u[0], u[1]);
        }
        self.c_end = f64::NAN;
    }

    /// The linear loop's periodic state at the start of a reference `amplitude sin(omega t)`.
    fn linear_orbit(&self, omega: f64, amplitude: f64) -> Vec<f64> {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -self.wn2, -self.two_zeta_wn]);
        let b = DVector::from_row_slice(&[0.0, self.wn2]);
        let (a, b) = match self.link.as_deref() {
            None => (a, b),
            Some(l) => l.system(self.wn2, self.two_zeta_wn),
        };
        let n = a.nrows();
        let jw = Complex64::new(0.0, omega);
        let m = DMatrix::<Complex64>::from_fn(n, n, |i, k| {
            let d = if i == k { jw } else { Complex64::new(0.0, 0.0) };
            d - Complex64::new(a[(i, k)], 0.0)
        });
        let rhs = DVector::<Complex64>::from_fn(n, |i, _| Complex64::new(b[i] * amplitude, 0.0));
        // The reference is the imaginary part of amplitude e^{j omega t}: at t = 0 the state
        // is the imaginary part of the phasor.
        m.lu()
            .solve(&rhs)
            .map_or(vec![0.0; n], |x| x.iter().map(|z| z.im).collect())
    }

    /// The CoM acceleration that the servo's force `force` gives at the current state.
    #[inline]
    fn com_acceleration(&self, force: f64) -> f64 {
        match self.link.as_deref() {
            None => force,
            Some(l) => l.com(&[self.x, self.v, l.xu, l.vu], force).2,
        }
    }

    #[inline]
    fn demand(&self, r: f64, x: f64, v: f64) -> f64 {
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
    fn rk4(&self, r0: f64, dr: f64, limits: &mut [Box<dyn Effect>]) -> (f64, f64) {
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

    /// [`Servo::step`] of the two-body loop: the exact linear step while the servo effects add
    /// a constant force (as the rigid servo's), the creep where friction holds the joint
    /// (`creep.rs`), RK4 where they switch or clamp.
    fn step_linked(&mut self, r: f64, limits: &mut [Box<dyn Effect>]) -> ServoState {
        self.step_linked_with(r, limits, true)
    }

    /// [`Servo::step_linked`], creeping only if `creep` (without: the reference of the tests).
    fn step_linked_with(
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

    #[inline]
    fn accel(&self, limits: &mut [Box<dyn Effect>], r: f64, x: f64, v: f64) -> f64 {
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
fn substeps_for(h: f64, k: f64) -> usize {
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
fn offset(limits: &mut [Box<dyn Effect>], demand: f64, v: f64) -> f64 {
    let mut a = demand;
    for l in limits.iter_mut() {
        a = l.servo_acceleration(a, v);
    }
    a - demand
}

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
/// (at most 2.5 h, and at most [`max_step`] of the limits): the linear part is exact at any
/// step, and the RK4 sub-steps follow the effects' stiffness.
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

/// Periods compared one by one before the general settling takes over.
const FAST_PERIODS: usize = 60;
/// Longest subharmonic cycle, in input periods, recognised by the fast path.
const FAST_SUBHARMONIC: usize = 6;
/// Relative change of the one-period phasor at which the servo counts as periodic.
const FAST_SETTLED_REL: f64 = 1e-8;

/// Steady-state first harmonic of the servo position with `limits` (none: the linear servo)
/// over the reference's `amplitude`: [`servo_harmonics`] is its ratio with and
/// without the limits; a caller that evaluates many limits at one `(omega, amplitude)` can
/// compute the linear run once.
pub fn servo_first_harmonic(
    omega_n: f64,
    zeta: f64,
    h: f64,
    limits: &mut [Box<dyn Effect>],
    omega: f64,
    amplitude: f64,
) -> Complex64 {
    first_harmonic(omega_n, zeta, h, None, limits, omega, amplitude, None)
        .0
        .first
}

/// Where a describing-function run's periods start: the servo's position and velocity at
/// that phase of the reference. A run started there from the orbit of nearby limits settles
/// in a few periods instead of the tens a saturated servo needs from rest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodStart {
    position: f64,
    velocity: f64,
}

/// [`servo_first_harmonic`], started at `start` (the state a previous run at the same
/// `omega` and `amplitude` returned) instead of settling from rest; also returns the state
/// at the end of its last period, to start the next run from. The result is the same
/// periodic response, to the settling tolerance (1e-8 relative per period).
pub fn servo_first_harmonic_from(
    omega_n: f64,
    zeta: f64,
    h: f64,
    limits: &mut [Box<dyn Effect>],
    omega: f64,
    amplitude: f64,
    start: Option<PeriodStart>,
) -> (Complex64, PeriodStart) {
    let (p, end) = first_harmonic(omega_n, zeta, h, None, limits, omega, amplitude, start);
    (p.first, end)
}

/// The steady-state first and third harmonics of a servo run over the reference's amplitude
/// (sin-referenced, the reference's phase zero).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Harmonics {
    first: Complex64,
    third: Complex64,
}

/// [`servo_first_harmonic_from`] of the servo driving `link` (if any): the CoM's first
/// harmonic. A linked run starts on the linear loop's periodic orbit (a lightly damped link
/// would take many periods to settle from rest) and ignores `start`.
#[allow(clippy::too_many_arguments)]
fn first_harmonic(
    omega_n: f64,
    zeta: f64,
    h: f64,
    link: Option<TrunkLink>,
    limits: &mut [Box<dyn Effect>],
    omega: f64,
    amplitude: f64,
    start: Option<PeriodStart>,
) -> (Harmonics, PeriodStart) {
    let period = 2.0 * std::f64::consts::PI / omega;
    let target = h.max((period / 2048.0).min(2.5 * h)).min(max_step(limits));
    let per = ((period / target).ceil() as usize).max(16);
    let h_df = period / per as f64;
    let mut servo = Servo::new(omega_n, zeta, h_df);
    if let Some(l) = link {
        servo = servo.with_link(l);
    }
    let slowest = TrackingLowpass { omega_n, zeta }.slowest_time_constant();
    let n_settle = (((8.0 * slowest).max(0.5 * period)) / h_df).ceil() as usize;
    // The reference by rotation: e^{j w k h}, renormalised once per period.
    let rot = Complex64::from_polar(1.0, omega * h_df);
    let rot3 = Complex64::from_polar(1.0, 3.0 * omega * h_df);
    let mut e = Complex64::new(1.0, 0.0);
    let start = if link.is_some() { None } else { start };
    match start {
        None if link.is_some() => {
            servo.reset(0.0);
            servo.set_state(&servo.linear_orbit(omega, amplitude));
            for _ in 0..n_settle {
                e *= rot;
                servo.step(amplitude * e.im, limits);
            }
        }
        None => {
            servo.reset(0.0);
            for _ in 0..n_settle {
                e *= rot;
                servo.step(amplitude * e.im, limits);
            }
        }
        Some(s) => {
            // The periods start at the phase the settling ends at.
            e = Complex64::from_polar(1.0, omega * h_df * n_settle as f64);
            servo.reset(amplitude * e.im);
            servo.x = s.position;
            servo.v = s.velocity;
        }
    }
    let end = |servo: &Servo| PeriodStart {
        position: servo.x,
        velocity: servo.v,
    };
    let dim = servo.state().len();
    // One-period phasors, newest last. A response periodic over m input periods (a saturated
    // servo can lock into a subharmonic cycle) repeats them with period m; the Fourier
    // coefficient at omega over those m periods is their mean. Only the periods since the
    // last jump of the orbit extrapolation (below) are compared.
    let mut history: Vec<Complex64> = Vec::with_capacity(FAST_PERIODS);
    let mut history3: Vec<Complex64> = Vec::with_capacity(FAST_PERIODS);
    let mut since = 0;
    let mut states: Vec<Vec<f64>> = vec![servo.state()];
    let same = |a: Complex64, b: Complex64| {
        (a - b).norm() <= FAST_SETTLED_REL * a.norm().max(b.norm()).max(1e-300)
    };
    for period in 0..FAST_PERIODS {
        // Sin-referenced phasor over one whole period: p = (2j/N) sum y_k e^{-j w t_k}.
        let mut acc = Complex64::new(0.0, 0.0);
        let mut acc3 = Complex64::new(0.0, 0.0);
        // The third harmonic's rotation by its own recurrence, restarted from e^3 each period.
        let mut e3 = e * e * e;
        for _ in 0..per {
            e *= rot;
            e3 *= rot3;
            let x = servo.step(amplitude * e.im, limits).position;
            acc += x * e.conj();
            acc3 += x * e3.conj();
        }
        e /= e.norm();
        history.push(acc * Complex64::new(0.0, 2.0 / per as f64));
        history3.push(acc3 * Complex64::new(0.0, 2.0 / per as f64));
        let n = history.len();
        for m in 1..=FAST_SUBHARMONIC {
            if n > since + m + 1
                && same(history[n - 1], history[n - 1 - m])
                && (m == 1 || same(history[n - 2], history[n - 2 - m]))
            {
                let mean = |h: &[Complex64]| h[n - m..].iter().sum::<Complex64>() / m as f64;
                let p = Harmonics {
                    first: mean(&history) / amplitude,
                    third: mean(&history3) / amplitude,
                };
                return (p, end(&servo));
            }
        }
        // A saturated servo approaches its orbit slowly (tens of periods). Near the orbit the
        // period map is linear, so four successive period-start states give it and its fixed
        // point; the run jumps there and goes on simulating (the test above still decides).
        states.push(servo.state());
        if period < FAST_PERIODS / 2 && states.len() == dim + 2 {
            // A jump costs dim + 1 periods before the test can pass again: worth it only when
            // plain iteration would take longer (a fast-contracting map settles by itself).
            if let Some((fixed, radius)) = periodic_fixed_point(&states) {
                let (last, before) = (&states[dim + 1], &states[dim]);
                let step: f64 = last.iter().zip(before).map(|(a, b)| (a - b).powi(2)).sum();
                let size: f64 = last.iter().map(|a| a * a).sum();
                let rel = step.sqrt() / size.sqrt().max(1e-300);
                let plain = if rel <= FAST_SETTLED_REL {
                    0.0
                } else {
                    (FAST_SETTLED_REL / rel).ln() / radius.ln()
                };
                if plain > 3.0 {
                    servo.set_state(&fixed);
                    since = history.len();
                }
            }
            states.clear();
            states.push(servo.state());
        }
    }
    // Not locked to a cycle of up to six periods within sixty: the Fourier coefficient over
    // the last twelve periods (a whole number of cycles of 1, 2, 3, 4 or 6 periods), the
    // describing function of a response that wanders.
    let n = history.len();
    let mean = |h: &[Complex64]| h[n - 12..].iter().sum::<Complex64>() / (12.0 * amplitude);
    (
        Harmonics {
            first: mean(&history),
            third: mean(&history3),
        },
        end(&servo),
    )
}

/// The fixed point of the linear map `s_{k+1} - s* = J (s_k - s*)` through `n + 2` successive
/// `n`-dimensional states and the spectral radius of `J`, if `J` contracts clearly (radius
/// below 0.95; a map near a flip or an unstable orbit is left to plain iteration).
fn periodic_fixed_point(s: &[Vec<f64>]) -> Option<(Vec<f64>, f64)> {
    let n = s.first()?.len();
    if s.len() != n + 2 {
        return None;
    }
    let d = |k: usize| DVector::from_iterator(n, (0..n).map(|i| s[k + 1][i] - s[k][i]));
    let d0 = DMatrix::from_columns(&(0..n).map(d).collect::<Vec<_>>());
    let d1 = DMatrix::from_columns(&(1..=n).map(d).collect::<Vec<_>>());
    // J D0 = D1, D0 clearly invertible.
    let scale: f64 = (0..n)
        .map(|k| d0.column(k).norm())
        .product::<f64>()
        .max(1e-300);
    if d0.determinant().abs() <= 1e-9 * scale {
        return None;
    }
    let j = &d1 * d0.try_inverse()?;
    let radius = j
        .complex_eigenvalues()
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max);
    if radius.is_nan() || radius >= 0.95 {
        return None;
    }
    // (I - J) s* = s_{n+1} - J s_n.
    let rhs = DVector::from_column_slice(&s[n + 1]) - &j * DVector::from_column_slice(&s[n]);
    let x = (DMatrix::identity(n, n) - j).lu().solve(&rhs)?;
    x.iter()
        .all(|v| v.is_finite())
        .then(|| (x.iter().copied().collect(), radius))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effect::{lookup, Binding, BuildContext};
    use crate::Axis;

    /// The servo effect `kind` with parameter `value`, built for step `h`.
    fn limit(kind: &str, value: f64, h: f64) -> Box<dyn Effect> {
        let ctx = BuildContext {
            h,
            binding: Binding::Axis(Axis::X),
            servo: Some((30.0, 1.0)),
            link: None,
        };
        (lookup(kind).unwrap().build)(&ctx, &[value])
    }

    /// Largest position difference over 5 s between the servo's own step (h = 1 ms) and RK4 on
    /// a 50x finer grid, with the same effect, for a reference sine of `amplitude` at `omega`.
    fn worst_against_fine_rk4(kind: &str, value: f64, amplitude: f64, omega: f64) -> f64 {
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
        let worst = worst_against_fine_rk4("acceleration_saturation", 0.8, 0.008, 15.0);
        assert!(
            worst < 2e-6,
            "fast path departs from fine RK4 by {worst} m (amplitude 8 mm)"
        );
    }

    /// Under friction: the constant-force step.
    #[test]
    fn fast_path_matches_fine_rk4_under_friction() {
        let worst = worst_against_fine_rk4("coulomb_friction", 0.05, 0.005, 3.0);
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
            let mut l = [limit("coulomb_friction", 0.3, h)];
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
            let mut l = [limit("coulomb_friction", 0.3, h)];
            servo_first_harmonic(30.0, 1.0, h, &mut l, 3.0, 0.005)
                / servo_first_harmonic(30.0, 1.0, h, &mut [], 3.0, 0.005)
        };
        let (a, b) = (df(1e-3), df(2e-3));
        assert!(
            (a - b).norm() < 1e-4 * a.norm(),
            "describing function at 1 ms {a} and 2 ms {b}"
        );
    }

    /// The plain steady state: settle from rest for `periods` periods at the describing
    /// function's own step, then one period's Fourier sum (no extrapolation, no early stop).
    fn plain_first_harmonic(
        kind: &str,
        value: f64,
        omega: f64,
        amplitude: f64,
        periods: usize,
    ) -> Complex64 {
        plain_harmonic(kind, value, omega, amplitude, periods, 1)
    }

    /// The `k`-th harmonic of the plain steady state over the reference's amplitude.
    fn plain_harmonic(
        kind: &str,
        value: f64,
        omega: f64,
        amplitude: f64,
        periods: usize,
        harmonic: u32,
    ) -> Complex64 {
        let h: f64 = 1e-3;
        let period = 2.0 * std::f64::consts::PI / omega;
        let per = ((period / h.max((period / 2048.0).min(2.5 * h))).ceil() as usize).max(16);
        let h_df = period / per as f64;
        let mut servo = Servo::new(30.0, 1.0, h_df);
        let mut l = [limit(kind, value, h)];
        servo.reset(0.0);
        let mut acc = Complex64::new(0.0, 0.0);
        for k in 1..=periods * per {
            let t = k as f64 * h_df;
            let x = servo.step(amplitude * (omega * t).sin(), &mut l).position;
            if k > (periods - 1) * per {
                acc += x * Complex64::from_polar(1.0, -f64::from(harmonic) * omega * t);
            }
        }
        acc * Complex64::new(0.0, 2.0 / per as f64) / amplitude
    }

    /// The third harmonic returned beside a describing function is the servo position's own,
    /// from the same periodic run: a plain 400-period run gives the same, and a clamped servo
    /// distorts by percents while a linear one does not at all.
    #[test]
    fn third_harmonic_is_the_plain_steady_states() {
        for (kind, value, omega, amplitude) in [
            ("acceleration_saturation", 0.8, 15.0, 0.008),
            ("acceleration_saturation", 0.2, 6.0, 0.008),
            ("coulomb_friction", 0.05, 3.0, 0.005),
        ] {
            let plain = plain_harmonic(kind, value, omega, amplitude, 400, 3);
            let third = limit(kind, value, 1e-3).third_harmonic(omega, amplitude);
            let rel = (third - plain).norm() / plain.norm();
            assert!(
                rel < 1e-6,
                "{kind} {value}: {third} against {plain} ({rel:e})"
            );
            assert!(
                plain.norm() > 1e-3,
                "{kind} {value}: third harmonic {plain}"
            );
        }
        let (_, none) = servo_harmonics((30.0, 1.0), 1e-3, None, &mut [], [0.0; 3], 6.0, 0.008);
        assert!(none.norm() < 1e-12, "linear servo: {none}");
    }

    /// Deep saturation settles over tens of periods; the orbit extrapolation must land on the
    /// same periodic response as a plain 400-period run, and a run started from another
    /// limit's orbit too.
    #[test]
    fn extrapolated_and_warm_started_runs_find_the_plain_steady_state() {
        let (omega, amplitude) = (15.0, 0.008);
        for value in [0.6, 1.2, 1.6] {
            let plain =
                plain_first_harmonic("acceleration_saturation", value, omega, amplitude, 400);
            let mut l = [limit("acceleration_saturation", value, 1e-3)];
            let (cold, _) =
                servo_first_harmonic_from(30.0, 1.0, 1e-3, &mut l, omega, amplitude, None);
            let mut other = [limit("acceleration_saturation", 1.1 * value, 1e-3)];
            let (_, orbit) =
                servo_first_harmonic_from(30.0, 1.0, 1e-3, &mut other, omega, amplitude, None);
            let (warm, _) =
                servo_first_harmonic_from(30.0, 1.0, 1e-3, &mut l, omega, amplitude, Some(orbit));
            for (what, got) in [("extrapolated", cold), ("warm-started", warm)] {
                let rel = (got - plain).norm() / plain.norm();
                assert!(
                    rel < 1e-7,
                    "limit {value}: {what} run off the plain steady state by {rel:e}"
                );
            }
        }
    }

    #[test]
    fn fixed_point_of_a_linear_period_map_is_exact() {
        let j = [[0.6, 0.2], [-0.1, 0.7]];
        let fixed = [0.3, -1.2];
        let mut s = vec![vec![1.0, 2.0]];
        for _ in 0..3 {
            let d = [
                s.last().unwrap()[0] - fixed[0],
                s.last().unwrap()[1] - fixed[1],
            ];
            s.push(vec![
                fixed[0] + j[0][0] * d[0] + j[0][1] * d[1],
                fixed[1] + j[1][0] * d[0] + j[1][1] * d[1],
            ]);
        }
        let (got, radius) = periodic_fixed_point(&s).unwrap();
        assert!((radius - 0.44f64.sqrt()).abs() < 1e-9, "{radius}");
        assert!(
            (got[0] - fixed[0]).abs() < 1e-12 && (got[1] - fixed[1]).abs() < 1e-12,
            "{got:?}"
        );
        // A flip (eigenvalue -1.05) is left to plain iteration.
        let mut s = vec![vec![1.0, 2.0]];
        for _ in 0..3 {
            let p = s.last().unwrap().clone();
            s.push(vec![-1.05 * p[0], 0.5 * p[1]]);
        }
        assert!(periodic_fixed_point(&s).is_none());
    }
}
