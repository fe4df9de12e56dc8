//! The servo's steady periodic response to a reference sine, the run behind every describing
//! function: settle, then simulate whole periods until the one-period phasors repeat (a
//! subharmonic cycle of up to six periods included), jumping to the period map's fixed point
//! when the approach is slow.

use super::{max_step, Servo};
use crate::effect::Effect;
use crate::effects::servo_link::TrunkLink;
use crate::effects::tracking_lowpass::TrackingLowpass;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// Periods compared one by one before the general settling takes over.
const FAST_PERIODS: usize = 60;
/// Longest subharmonic cycle, in input periods, recognised by the fast path.
const FAST_SUBHARMONIC: usize = 6;
/// Relative change of the one-period phasor at which the servo counts as periodic.
const FAST_SETTLED_REL: f64 = 1e-8;

/// Steady-state first harmonic of the servo position with `limits` (none: the linear servo)
/// over the reference's `amplitude`: [`servo_harmonics`](super::servo_harmonics) is its ratio with and
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
pub(super) struct Harmonics {
    pub(super) first: Complex64,
    pub(super) third: Complex64,
}

/// Steps per period of the reference in a describing-function run (fewer where the plant's own
/// step is longer, at the top of the band; more where the limits' stable step is shorter).
/// With 512, every first harmonic of the servo with a Coulomb friction, a force limit, both, a
/// play inside the servo or a flexible trunk link, at 0.5-15 rad/s and 3-8 mm, lies within
/// 1.4e-5 of the run at 8192 steps per period (the third harmonics within 2.5e-6 of the first),
/// a hundredth of the smallest first-harmonic noise of a record (about 1e-3 of its amplitude):
/// `tests::describing_functions_hold_at_512_steps_per_period`. The cost of a run is its
/// steps, and the servo's runs are most of a diagnosis: at 2048 steps per period below
/// 1.2 rad/s (and at most 2.5 plant steps each) the small campaign's diagnosis took 4.3 times
/// as long, to the same verdict.
pub(super) const STEPS_PER_PERIOD: f64 = 512.0;

/// [`servo_first_harmonic_from`] of the servo driving `link` (if any): the CoM's first
/// harmonic. A linked run starts on the linear loop's periodic orbit (a lightly damped link
/// would take many periods to settle from rest) and ignores `start`.
#[allow(clippy::too_many_arguments)]
pub(super) fn first_harmonic(
    omega_n: f64,
    zeta: f64,
    h: f64,
    link: Option<TrunkLink>,
    limits: &mut [Box<dyn Effect>],
    omega: f64,
    amplitude: f64,
    start: Option<PeriodStart>,
) -> (Harmonics, PeriodStart) {
    let grid = PeriodGrid::new(omega_n, zeta, h, limits, omega, STEPS_PER_PERIOD);
    on_grid(&grid, omega_n, zeta, link, limits, amplitude, start)
}

/// [`first_harmonic`] on a grid of `steps` per period (the tests' reference: a finer one).
#[cfg(test)]
#[allow(clippy::too_many_arguments)]
pub(super) fn first_harmonic_with_steps(
    omega_n: f64,
    zeta: f64,
    h: f64,
    link: Option<TrunkLink>,
    limits: &mut [Box<dyn Effect>],
    omega: f64,
    amplitude: f64,
    steps: f64,
) -> Harmonics {
    let grid = PeriodGrid::new(omega_n, zeta, h, limits, omega, steps);
    on_grid(&grid, omega_n, zeta, link, limits, amplitude, None).0
}

/// The run on `grid`: settle (from `start` if given, a linked servo never), then periods.
fn on_grid(
    grid: &PeriodGrid,
    omega_n: f64,
    zeta: f64,
    link: Option<TrunkLink>,
    limits: &mut [Box<dyn Effect>],
    amplitude: f64,
    start: Option<PeriodStart>,
) -> (Harmonics, PeriodStart) {
    let mut servo = Servo::new(omega_n, zeta, grid.h);
    if let Some(l) = link {
        servo = servo.with_link(l);
    }
    let start = if link.is_some() { None } else { start };
    let e = settle(&mut servo, grid, link.is_some(), limits, amplitude, start);
    periodic_response(&mut servo, grid, e, limits, amplitude)
}

/// The time grid of a describing-function run: whole periods of the reference in `per` steps.
struct PeriodGrid {
    /// The reference's angular frequency, rad/s.
    omega: f64,
    /// Steps per period of the reference.
    per: usize,
    /// The step, s: a whole fraction of the period, about `steps` per period
    /// ([`STEPS_PER_PERIOD`]) but no shorter than the plant's step and no longer than the
    /// limits' stable step.
    h: f64,
    /// Steps to settle from rest: eight of the linear servo's slowest time constants, at
    /// least half a period.
    n_settle: usize,
    /// The reference's rotation over one step, `e^{j omega h}`, and the third harmonic's.
    rot: Complex64,
    rot3: Complex64,
}

impl PeriodGrid {
    fn new(
        omega_n: f64,
        zeta: f64,
        h: f64,
        limits: &[Box<dyn Effect>],
        omega: f64,
        steps: f64,
    ) -> Self {
        let period = 2.0 * std::f64::consts::PI / omega;
        let target = h.max(period / steps).min(max_step(limits));
        let per = ((period / target).ceil() as usize).max(16);
        let h_df = period / per as f64;
        let slowest = TrackingLowpass { omega_n, zeta }.slowest_time_constant();
        let n_settle = (((8.0 * slowest).max(0.5 * period)) / h_df).ceil() as usize;
        PeriodGrid {
            omega,
            per,
            h: h_df,
            n_settle,
            rot: Complex64::from_polar(1.0, omega * h_df),
            rot3: Complex64::from_polar(1.0, 3.0 * omega * h_df),
        }
    }
}

/// Brings `servo` to where its periods start: from rest (a linked servo from the linear
/// loop's orbit) over the settling steps, or at `start`. Returns the reference's phase there,
/// `e^{j omega t}` (the reference is `amplitude Im e`).
fn settle(
    servo: &mut Servo,
    grid: &PeriodGrid,
    linked: bool,
    limits: &mut [Box<dyn Effect>],
    amplitude: f64,
    start: Option<PeriodStart>,
) -> Complex64 {
    // The reference by rotation: e^{j w k h}, renormalised once per period.
    let mut e = Complex64::new(1.0, 0.0);
    match start {
        None => {
            servo.reset(0.0);
            if linked {
                servo.set_state(&servo.linear_orbit(grid.omega, amplitude));
            }
            for _ in 0..grid.n_settle {
                e *= grid.rot;
                servo.step(amplitude * e.im, limits);
            }
        }
        Some(s) => {
            // The periods start at the phase the settling ends at.
            e = Complex64::from_polar(1.0, grid.omega * grid.h * grid.n_settle as f64);
            servo.reset(amplitude * e.im);
            servo.x = s.position;
            servo.v = s.velocity;
        }
    }
    e
}
/// The steady-state harmonics of `servo` run over whole periods from the phase `e`, and its
/// state at the end of the last period.
///
/// One-period phasors, newest last. A response periodic over m input periods (a saturated
/// servo can lock into a subharmonic cycle) repeats them with period m; the Fourier
/// coefficient at omega over those m periods is their mean. Only the periods since the last
/// jump of the orbit extrapolation ([`orbit_jump`]) are compared.
fn periodic_response(
    servo: &mut Servo,
    grid: &PeriodGrid,
    mut e: Complex64,
    limits: &mut [Box<dyn Effect>],
    amplitude: f64,
) -> (Harmonics, PeriodStart) {
    let end = |servo: &Servo| PeriodStart {
        position: servo.x,
        velocity: servo.v,
    };
    let dim = servo.state().len();
    let mut history: Vec<Complex64> = Vec::with_capacity(FAST_PERIODS);
    let mut history3: Vec<Complex64> = Vec::with_capacity(FAST_PERIODS);
    let mut since = 0;
    let mut states: Vec<Vec<f64>> = vec![servo.state()];
    // The state the current period started from.
    let mut start = servo.state();
    for period in 0..FAST_PERIODS {
        let (p1, p3) = one_period(servo, grid, &mut e, limits, amplitude);
        history.push(p1);
        history3.push(p3);
        // Back where the period started: the orbit is periodic (the servo effects hold no
        // state of their own), and this period's phasors are its harmonics.
        let now = servo.state();
        if returned(&start, &now, p1.norm(), grid.omega) {
            let h = Harmonics {
                first: p1 / amplitude,
                third: p3 / amplitude,
            };
            return (h, end(servo));
        }
        if let Some(p) = locked_cycle(&history, &history3, since, amplitude) {
            return (p, end(servo));
        }
        // A saturated servo approaches its orbit slowly (tens of periods). Near the orbit the
        // period map is linear, so four successive period-start states give it and its fixed
        // point; the run jumps there and goes on simulating (the test above still decides).
        states.push(servo.state());
        if period < FAST_PERIODS / 2 && states.len() == dim + 2 {
            if let Some(fixed) = orbit_jump(&states) {
                servo.set_state(&fixed);
                since = history.len();
            }
            states.clear();
            states.push(servo.state());
        }
        start = servo.state();
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
        end(servo),
    )
}

/// Runs `servo` over one period of the reference from the phase `e` (advanced to the period's
/// end and renormalised); returns the position's sin-referenced first and third harmonic
/// phasors, `p = (2j/N) sum y_k e^{-j w t_k}`.
#[inline]
fn one_period(
    servo: &mut Servo,
    grid: &PeriodGrid,
    e: &mut Complex64,
    limits: &mut [Box<dyn Effect>],
    amplitude: f64,
) -> (Complex64, Complex64) {
    let mut acc = Complex64::new(0.0, 0.0);
    let mut acc3 = Complex64::new(0.0, 0.0);
    // The third harmonic's rotation by its own recurrence, restarted from e^3 each period.
    let mut e3 = *e * *e * *e;
    for _ in 0..grid.per {
        *e *= grid.rot;
        e3 *= grid.rot3;
        let x = servo.step(amplitude * e.im, limits).position;
        acc += x * e.conj();
        acc3 += x * e3.conj();
    }
    *e /= e.norm();
    let scale = Complex64::new(0.0, 2.0 / grid.per as f64);
    (acc * scale, acc3 * scale)
}

/// Whether the state at a period's end, `now`, is the state it started from, `start`, to
/// [`FAST_SETTLED_REL`] of the orbit's size: positions (even indices of [`Servo::state`])
/// against `size`, the first harmonic's amplitude, velocities against `omega size`. The
/// servo's step depends on its state and the reference alone, so a state that comes back
/// after a whole period starts the same period again: the orbit is periodic from there, and
/// the period just run is one of it (one period instead of the three the phasor test needs).
fn returned(start: &[f64], now: &[f64], size: f64, omega: f64) -> bool {
    let size = size.max(1e-300);
    start.iter().zip(now).enumerate().all(|(i, (a, b))| {
        let scale = if i % 2 == 0 { size } else { omega * size };
        (a - b).abs() <= FAST_SETTLED_REL * scale
    })
}

/// The harmonics over `amplitude` once the phasors since period `since` repeat with a period
/// of `m` periods (up to [`FAST_SUBHARMONIC`]): their mean over the last cycle.
fn locked_cycle(
    history: &[Complex64],
    history3: &[Complex64],
    since: usize,
    amplitude: f64,
) -> Option<Harmonics> {
    let same = |a: Complex64, b: Complex64| {
        (a - b).norm() <= FAST_SETTLED_REL * a.norm().max(b.norm()).max(1e-300)
    };
    let n = history.len();
    (1..=FAST_SUBHARMONIC)
        .find(|&m| {
            n > since + m + 1
                && same(history[n - 1], history[n - 1 - m])
                && (m == 1 || same(history[n - 2], history[n - 2 - m]))
        })
        .map(|m| {
            let mean = |h: &[Complex64]| h[n - m..].iter().sum::<Complex64>() / m as f64;
            Harmonics {
                first: mean(history) / amplitude,
                third: mean(history3) / amplitude,
            }
        })
}

/// The period map's fixed point through `dim + 2` successive period-start states, when
/// jumping there pays: a jump costs `dim + 1` periods before the settling test can pass
/// again, worth it only when plain iteration would take longer than three periods (a
/// fast-contracting map settles by itself).
fn orbit_jump(states: &[Vec<f64>]) -> Option<Vec<f64>> {
    let dim = states.len().checked_sub(2)?;
    let (fixed, radius) = periodic_fixed_point(states)?;
    let (last, before) = (&states[dim + 1], &states[dim]);
    let step: f64 = last.iter().zip(before).map(|(a, b)| (a - b).powi(2)).sum();
    let size: f64 = last.iter().map(|a| a * a).sum();
    let rel = step.sqrt() / size.sqrt().max(1e-300);
    let plain = if rel <= FAST_SETTLED_REL {
        0.0
    } else {
        (FAST_SETTLED_REL / rel).ln() / radius.ln()
    };
    (plain > 3.0).then_some(fixed)
}

/// The fixed point of the linear map `s_{k+1} - s* = J (s_k - s*)` through `n + 2` successive
/// `n`-dimensional states and the spectral radius of `J`, if `J` contracts clearly (radius
/// below 0.95; a map near a flip or an unstable orbit is left to plain iteration).
pub(super) fn periodic_fixed_point(s: &[Vec<f64>]) -> Option<(Vec<f64>, f64)> {
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
