//! Nominal stability of the closed loop by the argument principle (the generalised Nyquist
//! criterion): the number of closed-loop poles in the open right half-plane is
//!
//! ```text
//! Z = P - Phi / (2 pi),   Phi = change of arg det(I + G(s) K(s)) along the Nyquist contour,
//! ```
//!
//! the contour running up the imaginary axis and closing through the right half-plane. `P`,
//! the open-loop poles inside it, is zero: every catalogued effect of the plant is stable (the
//! pendulum's `a - b s^2` has zeros only; low-passes, modes and weights have stable poles), and
//! the controller's poles at `s = 0` (integrators) are kept outside by a small semicircle
//! `s = eps e^(j theta)`, `theta` from `-pi/2` to `pi/2`, on which the plant is taken at its
//! value at `j eps` (`eps` is three decades below the analysis grid, where the plant is flat).
//! The negative imaginary axis mirrors the positive one (`det(I + G K)` at `-j w` is the
//! conjugate of its value at `j w`), and the large arc adds nothing when the loop gain vanishes
//! at high frequency (the evaluation extends the upper end by decades until `|det - 1| < 0.5`).
//!
//! The phase is followed on a logarithmic grid, bisected wherever it moves more than
//! [`MAX_PHASE_STEP`] between neighbours, so a lightly damped mode cannot slip between points.
//! A closed-loop pole on the imaginary axis makes `Z` non-integral: reported as `None`.

use super::{Grid, LoopController, Response2};
use nalgebra::Matrix2;
use num_complex::Complex64;
use std::f64::consts::PI;

/// Largest phase change of `det(I + G K)` between two evaluation points, rad.
pub const MAX_PHASE_STEP: f64 = 0.3;
/// Bisections of one grid interval at most (a ratio of `10^(1/per_decade) / 2^30`).
const MAX_DEPTH: u32 = 30;
/// Points on the semicircle around `s = 0`.
const ARC_POINTS: usize = 720;

fn det_return_difference(g: &Response2, k: &Response2) -> Complex64 {
    (Matrix2::identity() + g * k).determinant()
}

/// The principal difference `arg b - arg a`, in (-pi, pi].
fn phase_step(a: Complex64, b: Complex64) -> f64 {
    (b / a).arg()
}

/// Phase change of `det(I + G K)` from `j w0` to `j w1` along the axis, refined by bisection.
fn axis_change(
    d: &mut dyn FnMut(f64) -> Complex64,
    w0: f64,
    d0: Complex64,
    w1: f64,
    d1: Complex64,
    depth: u32,
) -> f64 {
    let step = phase_step(d0, d1);
    if step.abs() <= MAX_PHASE_STEP || depth >= MAX_DEPTH {
        return step;
    }
    let wm = (w0 * w1).sqrt();
    let dm = d(wm);
    axis_change(d, w0, d0, wm, dm, depth + 1) + axis_change(d, wm, dm, w1, d1, depth + 1)
}

/// Closed-loop poles in the open right half-plane, `None` when the count is not integral (a
/// pole on the imaginary axis, or a response that is not finite).
pub fn unstable_poles(
    plant: &dyn Fn(f64) -> Response2,
    ctrl: &dyn LoopController,
    grid: &Grid,
) -> Option<usize> {
    let eps = grid.lo * 1e-3;
    let g0 = plant(eps);
    // The semicircle around the controller's poles at the origin.
    let arc = |theta: f64| {
        let s = Complex64::from_polar(eps, theta);
        det_return_difference(&g0, &ctrl.at(s))
    };
    let mut arc_change = 0.0;
    let mut prev = arc(-PI / 2.0);
    for n in 1..=ARC_POINTS {
        let theta = -PI / 2.0 + PI * n as f64 / ARC_POINTS as f64;
        let next = arc(theta);
        arc_change += phase_step(prev, next);
        prev = next;
    }
    let mut d = |w: f64| det_return_difference(&plant(w), &ctrl.at(Complex64::new(0.0, w)));
    // The upper end: where the loop gain has died out.
    let mut hi = grid.hi;
    while (d(hi) - 1.0).norm() >= 0.5 && hi < 1e9 {
        hi *= 10.0;
    }
    let decades = (hi / eps).log10();
    let n = (decades * grid.per_decade as f64).ceil().max(2.0) as usize;
    let mut axis = 0.0;
    let mut w0 = eps;
    let mut d0 = d(w0);
    for k in 1..=n {
        let w1 = eps * 10f64.powf(decades * k as f64 / n as f64);
        let d1 = d(w1);
        axis += axis_change(&mut d, w0, d0, w1, d1, 0);
        w0 = w1;
        d0 = d1;
    }
    // From j hi to j infinity, where det(I + G K) -> 1.
    axis += phase_step(d0, Complex64::new(1.0, 0.0));
    let phi = 2.0 * axis + arc_change;
    let z = -phi / (2.0 * PI);
    if !z.is_finite() || (z - z.round()).abs() > 0.1 || z.round() < 0.0 {
        return None;
    }
    Some(z.round() as usize)
}
