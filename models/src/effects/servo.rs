//! The servo of one input axis: the CoM follows its reference through the tracking low-pass
//! `x'' = wn^2 (r - x) - 2 zeta wn x'`, and servo effects (acceleration saturation, Coulomb
//! friction) limit the acceleration it achieves.
//!
//! Without servo effects the step is the exact first-order-hold discretisation. With them it
//! stays exact while they only add a constant to the acceleration (see [`Servo::step`]), and is
//! RK4 on four sub-steps, the reference interpolated linearly, where they switch.

use crate::effects::servo_link::{Linked, TrunkLink};
use crate::lti::discretise_foh;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

mod creep;
mod describing_function;
mod linked;
mod periodic;
mod step;

pub use describing_function::{
    clear_describing_function_cache, joint_servo_harmonics, part_harmonics, play_harmonics,
    servo_harmonics, ServoPart,
};
use periodic::{first_harmonic, Harmonics};
pub use periodic::{servo_first_harmonic, servo_first_harmonic_from, PeriodStart};
use step::substeps_for;
pub(crate) use step::SUBSTEP_STIFFNESS;
pub use step::{max_step, MAX_SUBSTEPS};

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

/// The servo of one input axis: the tracking low-pass stepped with its servo effects (and the link it drives, if any).
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
    /// The servo of natural frequency `omega_n` (rad/s) and damping `zeta`, stepped at `h` (s), at rest at zero.
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
}

#[cfg(test)]
mod tests {
    use super::periodic::periodic_fixed_point;
    use super::*;
    use crate::effect::{Binding, BuildContext, Effect};
    use crate::Axis;

    /// The describing function's grid ([`periodic::STEPS_PER_PERIOD`]) against one 16 times
    /// finer, over the servo's nonlinear laws and the band: first harmonics within 3e-5 of
    /// their size (1.4e-5 measured: twice that, so a grid change that loses accuracy fails, a
    /// thirtieth of a record's smallest noise), third harmonics within 1e-5 of the first.
    #[test]
    fn describing_functions_hold_at_512_steps_per_period() {
        use crate::effects::servo_link::TrunkLink;
        use crate::EffectKind as K;
        let h = 1e-3;
        let play = TrunkLink {
            omega_m: 150.0,
            zeta_m: 0.2,
            share: 1.0,
            drive: 0.3,
            half_play: 0.15e-3,
            drag: 20.0,
        };
        let flex = TrunkLink::flexible(8.0, 0.08, 0.3, 0.3);
        let fric = |v| (K::CoulombFriction, v);
        let sat = |v| (K::AccelerationSaturation, v);
        // (link inside the servo, limits with their value, amplitude)
        type Case = (Option<TrunkLink>, Vec<(K, f64)>, f64);
        let cases: Vec<Case> = vec![
            (None, vec![fric(0.3)], 0.003),
            (None, vec![fric(0.05)], 0.003),
            (None, vec![sat(0.8)], 0.008),
            (None, vec![fric(0.2), sat(0.5)], 0.008),
            (Some(play), vec![], 0.003),
            (Some(play), vec![sat(0.8)], 0.008),
            (Some(play), vec![fric(0.2)], 0.003),
            (Some(flex), vec![sat(0.8)], 0.008),
        ];
        let mut worst = (0.0f64, 0.0f64);
        for omega in [0.5, 1.15, 2.65, 6.1, 15.0] {
            for (link, ls, a) in &cases {
                let mut l: Vec<Box<dyn Effect>> =
                    ls.iter().map(|(k, v)| limit(*k, *v, h)).collect();
                let grid = periodic::first_harmonic(30.0, 1.0, h, *link, &mut l, omega, *a, None).0;
                let mut l: Vec<Box<dyn Effect>> =
                    ls.iter().map(|(k, v)| limit(*k, *v, h)).collect();
                let fine = periodic::first_harmonic_with_steps(
                    30.0,
                    1.0,
                    h,
                    *link,
                    &mut l,
                    omega,
                    *a,
                    16.0 * periodic::STEPS_PER_PERIOD,
                );
                let size = fine.first.norm();
                worst.0 = worst.0.max((grid.first - fine.first).norm() / size);
                worst.1 = worst.1.max((grid.third - fine.third).norm() / size);
            }
        }
        assert!(worst.0 < 3e-5, "first harmonics off by {:.1e}", worst.0);
        assert!(worst.1 < 1e-5, "third harmonics off by {:.1e}", worst.1);
        assert!(worst.0 > 0.0, "the finer grid changed nothing: no test");
    }

    /// The servo effect `kind` with parameter `value`, built for step `h`.
    pub(super) fn limit(kind: crate::EffectKind, value: f64, h: f64) -> Box<dyn Effect> {
        let ctx = BuildContext {
            h,
            binding: Binding::Axis(Axis::X),
            servo: Some((30.0, 1.0)),
            link: None,
        };
        (kind.info().build)(&ctx, &[value])
    }

    /// The plain steady state: settle from rest for `periods` periods at the describing
    /// function's own step, then one period's Fourier sum (no extrapolation, no early stop).
    fn plain_first_harmonic(
        kind: crate::EffectKind,
        value: f64,
        omega: f64,
        amplitude: f64,
        periods: usize,
    ) -> Complex64 {
        plain_harmonic(kind, value, omega, amplitude, periods, 1)
    }

    /// The `k`-th harmonic of the plain steady state over the reference's amplitude.
    fn plain_harmonic(
        kind: crate::EffectKind,
        value: f64,
        omega: f64,
        amplitude: f64,
        periods: usize,
        harmonic: u32,
    ) -> Complex64 {
        let h: f64 = 1e-3;
        let period = 2.0 * std::f64::consts::PI / omega;
        let per = ((period / h.max(period / periodic::STEPS_PER_PERIOD)).ceil() as usize).max(16);
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
            (crate::EffectKind::AccelerationSaturation, 0.8, 15.0, 0.008),
            (crate::EffectKind::AccelerationSaturation, 0.2, 6.0, 0.008),
            (crate::EffectKind::CoulombFriction, 0.05, 3.0, 0.005),
            // A slow sweep's record: half a period settles it, so the run ends where its
            // first period comes back to its start.
            (crate::EffectKind::CoulombFriction, 0.3, 0.5, 0.003),
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
            // The describing function against the plain runs' ratio, with and without the
            // effect (a friction of level zero is the linear servo).
            let linear = crate::EffectKind::CoulombFriction;
            let plain1 = plain_first_harmonic(kind, value, omega, amplitude, 400)
                / plain_first_harmonic(linear, 0.0, omega, amplitude, 400);
            let first = limit(kind, value, 1e-3).frequency_response(omega, amplitude);
            let rel = (first - plain1).norm() / plain1.norm();
            assert!(
                rel < 1e-6,
                "{kind} {value}: describing function {first} against {plain1} ({rel:e})"
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
            let plain = plain_first_harmonic(
                crate::EffectKind::AccelerationSaturation,
                value,
                omega,
                amplitude,
                400,
            );
            let mut l = [limit(
                crate::EffectKind::AccelerationSaturation,
                value,
                1e-3,
            )];
            let (cold, _) =
                servo_first_harmonic_from(30.0, 1.0, 1e-3, &mut l, omega, amplitude, None);
            let mut other = [limit(
                crate::EffectKind::AccelerationSaturation,
                1.1 * value,
                1e-3,
            )];
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
