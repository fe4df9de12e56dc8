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
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

mod creep;
mod describing_function;
mod linked;
mod step;

pub use describing_function::{
    clear_describing_function_cache, joint_servo_harmonics, part_harmonics, play_harmonics,
    servo_harmonics, ServoPart,
};
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
    let radius = crate::lti::spectral_radius(&j)?;
    if radius >= 0.95 {
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
    use crate::effect::{Binding, BuildContext};
    use crate::Axis;

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
            (crate::EffectKind::AccelerationSaturation, 0.8, 15.0, 0.008),
            (crate::EffectKind::AccelerationSaturation, 0.2, 6.0, 0.008),
            (crate::EffectKind::CoulombFriction, 0.05, 3.0, 0.005),
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
