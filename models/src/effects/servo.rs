//! The servo of one input axis: the CoM follows its reference through the tracking low-pass
//! `x'' = wn^2 (r - x) - 2 zeta wn x'`, and servo effects (acceleration saturation, Coulomb
//! friction) limit the acceleration it achieves.
//!
//! Without servo effects the step is the exact first-order-hold discretisation. With them it is
//! RK4 on four sub-steps, the reference interpolated linearly; if the limits would not act
//! at either end of the step, the exact linear step is kept.

use crate::effect::Effect;
use crate::effects::tracking_lowpass::TrackingLowpass;
use crate::harmonic::steady_first_harmonics;
use crate::lti::discretise_foh;
use crate::plant::{MAX_SETTLE_PERIODS, MAX_SETTLE_STEPS};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

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
        }
    }

    /// At rest at the reference `r`.
    pub fn reset(&mut self, r: f64) {
        self.x = r;
        self.v = 0.0;
        self.r_prev = r;
    }

    #[inline]
    fn demand(&self, r: f64, x: f64, v: f64) -> f64 {
        self.wn2 * (r - x) - self.two_zeta_wn * v
    }

    /// Advances one step; the reference has moved linearly from the previous value to `r`.
    #[inline]
    pub fn step(&mut self, r: f64, limits: &mut [Box<dyn Effect>]) -> ServoState {
        let r0 = self.r_prev;
        let dr = r - r0;
        let xl =
            self.phi[0][0] * self.x + self.phi[0][1] * self.v + self.g0[0] * r0 + self.g1[0] * dr;
        let vl =
            self.phi[1][0] * self.x + self.phi[1][1] * self.v + self.g0[1] * r0 + self.g1[1] * dr;
        if limits.is_empty()
            || (inactive(limits, self.demand(r0, self.x, self.v), self.v)
                && inactive(limits, self.demand(r, xl, vl), vl))
        {
            self.x = xl;
            self.v = vl;
        } else {
            const SUB: usize = 4;
            let hs = self.h / SUB as f64;
            let (mut x, mut v) = (self.x, self.v);
            for k in 0..SUB {
                let ra = r0 + dr * (k as f64 / SUB as f64);
                let rm = r0 + dr * ((k as f64 + 0.5) / SUB as f64);
                let rb = r0 + dr * ((k + 1) as f64 / SUB as f64);
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
            }
            self.x = x;
            self.v = v;
        }
        self.r_prev = r;
        let acceleration = self.accel(limits, r, self.x, self.v);
        ServoState {
            position: self.x,
            velocity: self.v,
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

#[inline]
fn inactive(limits: &mut [Box<dyn Effect>], demand: f64, v: f64) -> bool {
    let mut a = demand;
    for l in limits.iter_mut() {
        a = l.servo_acceleration(a, v);
    }
    a == demand
}

/// First harmonic of the servo position with `limits`, divided by the linear servo's, for a
/// reference sine of `amplitude` at `omega`: the describing function of a servo effect.
pub fn servo_describing_function(
    omega_n: f64,
    zeta: f64,
    h: f64,
    limits: &mut [Box<dyn Effect>],
    omega: f64,
    amplitude: f64,
) -> Complex64 {
    let run = |limits: &mut [Box<dyn Effect>]| -> Complex64 {
        let mut servo = Servo::new(omega_n, zeta, h);
        servo.reset(0.0);
        let period = 2.0 * std::f64::consts::PI / omega;
        let slowest = TrackingLowpass { omega_n, zeta }.slowest_time_constant();
        let settle = (8.0 * slowest).max(3.0 * period);
        let n_settle = (settle / h).ceil() as usize;
        let per = (period / h).round().max(8.0) as usize;
        let n_max = n_settle + (per * MAX_SETTLE_PERIODS).min(MAX_SETTLE_STEPS);
        let [x] = steady_first_harmonics(omega, h, n_settle, n_max, |k| {
            let t = k as f64 * h;
            [servo.step(amplitude * (omega * t).sin(), limits).position]
        });
        x / amplitude
    };
    let with = run(limits);
    let without = run(&mut []);
    with / without
}
