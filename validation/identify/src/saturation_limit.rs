//! Step 6: the acceleration limit estimated from the saturated records (the servo's
//! describing function matched by Brent's minimisation).

use super::fit::{self, Point, NP};
use super::RecordFit;
use num_complex::Complex64;
use std::sync::Mutex;
use zmp_campaign::par::parallel_map;
use zmp_models::effect::BuildContext;
use zmp_models::effects::servo::{servo_first_harmonic_from, PeriodStart};
use zmp_models::{Axis, Binding};

/// Step 6: the acceleration limit that makes the servo's describing function match the
/// saturated records; golden-section search on `log(limit)`.
pub(super) fn estimate_limit(
    records: &[RecordFit],
    sat: &[usize],
    p: &[f64; NP],
    factors: &[[Complex64; 2]],
    linear_demand: f64,
    threads: usize,
) -> (Option<f64>, Option<f64>, bool) {
    let info = zmp_models::EffectKind::AccelerationSaturation.info();
    let h = zmp_models::DEFAULT_STEP;
    let ctx = BuildContext {
        h,
        binding: Binding::Axis(Axis::X),
        servo: Some((p[8], p[9])),
        link: None,
    };
    let demand: Vec<f64> = sat
        .iter()
        .map(|&c| {
            let r = &records[c];
            r.amplitude * r.omega * r.omega * fit::lowpass(r.omega, p[8], p[9]).norm()
        })
        .collect();
    let top = demand.iter().cloned().fold(0.0, f64::max);
    if top.is_nan() || top <= 0.0 {
        return (None, None, false);
    }
    // Distinct (omega, amplitude) pairs share a describing function.
    let mut keys: Vec<(f64, f64)> = Vec::new();
    for &c in sat {
        let k = (records[c].omega, records[c].amplitude);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    // The describing function of the limit at each key is the servo's first harmonic with the
    // limit over the linear servo's (what `frequency_response` of the effect computes); the
    // linear runs do not depend on the limit, so they are done once, and the runs of one
    // evaluation are shared out over the worker threads (each one is a long simulation).
    // A saturated servo settles slowly from rest, so each run of the search starts from the
    // periodic orbit of the search's previous limit (the linear orbit for the first).
    let starts: Mutex<Vec<Option<PeriodStart>>> = Mutex::new(vec![None; keys.len()]);
    let first_harmonics = |limit: Option<f64>, keep_orbit: bool| -> Vec<Complex64> {
        let from = starts.lock().unwrap_or_else(|p| p.into_inner()).clone();
        let run = |k: usize| {
            let (w, a) = keys[k];
            let mut limits: Vec<Box<dyn zmp_models::Effect>> =
                limit.iter().map(|&l| (info.build)(&ctx, &[l])).collect();
            servo_first_harmonic_from(p[8], p[9], h, &mut limits, w, a, from[k])
        };
        let out = parallel_map(keys.len(), threads, run);
        if keep_orbit {
            *starts.lock().unwrap_or_else(|p| p.into_inner()) =
                out.iter().map(|o| Some(o.1)).collect();
        }
        out.into_iter().map(|o| o.0).collect()
    };
    let linear = first_harmonics(None, true);
    // `keep_orbit`: the search's own evaluations pass their orbit on; the two curvature points,
    // evaluated at once, start from the search's last and leave it alone (deterministic).
    let chi2 = |limit: f64, keep_orbit: bool| -> f64 {
        let nf: Vec<Complex64> = first_harmonics(Some(limit), keep_orbit)
            .iter()
            .zip(&linear)
            .map(|(with, without)| with / without)
            .collect();
        let mut s = 0.0;
        for &c in sat {
            let r = &records[c];
            let k = keys
                .iter()
                .position(|&k| k == (r.omega, r.amplitude))
                .expect("key");
            for i in 0..2 {
                let gm = fit::model(
                    p,
                    &Point {
                        i,
                        j: r.excited.index(),
                        omega: r.omega_fit,
                        g: r.g[i],
                        sigma: r.sigma[i],
                        factor: factors[c][i],
                    },
                ) * nf[k];
                s += (r.g[i] - gm).norm_sqr() / r.sigma[i].powi(2);
            }
        }
        s
    };
    // Brent's minimisation over log(limit), to within 1e-4 (relative) of the limit: each
    // evaluation is a long saturated simulation, and parabolic steps need fewer of them than
    // golden sections alone.
    // The limit lies near or above the demands of the axis's records that stay linear (a
    // mild clip deviates less than the noise).
    let lo = (0.05 * top).max(0.7 * linear_demand.min(top));
    let (a, b) = bracket(lo.ln(), (1.2 * top).ln(), |x| chi2(x.exp(), false));
    let (x, c0) = brent_minimise(a, b, 5e-5, 60, |x| chi2(x.exp(), true));
    let l = x.exp();
    // Standard error from the curvature of chi-square, scaled by the reduced chi-square (the
    // two side evaluations at once).
    let d = 0.01 * l;
    let side = parallel_map(2, threads, |i| {
        chi2(if i == 0 { l - d } else { l + d }, false)
    });
    let (cm, cp) = (side[0], side[1]);
    let curv = (cm - 2.0 * c0 + cp) / (d * d);
    let dof = (2 * sat.len()).saturating_sub(1).max(1) as f64;
    let se = if curv > 0.0 {
        Some((2.0 / curv * (c0 / dof).max(1.0)).sqrt())
    } else {
        None
    };
    // A minimum on the search's lower end: the data ask for a limit below the linear demands.
    let at_floor = linear_demand.is_finite() && linear_demand > 0.0 && l <= 1.01 * lo;
    (Some(l), se, at_floor)
}

/// Points of the coarse grid [`bracket`] lays over the limit's range before Brent's search.
const GRID: usize = 9;

/// The part of `[a, b]` around the lowest of [`GRID`] evenly spaced values of `f` (the
/// neighbouring grid points; the grid's ends at its ends). The chi-square of a limit is not
/// unimodal: where a force limit stands in for another effect that bends the response of
/// several records (held-out draw 1120002: Coulomb friction on a 39 rad/s servo, the records
/// above a third of the largest demand off the linear model), Brent's search from its first
/// golden point settled at 0.309 m/s2, chi-square 2.6e8, against 13 071 at the drawn 1.255.
fn bracket(a: f64, b: f64, f: impl Fn(f64) -> f64) -> (f64, f64) {
    let at = |k: usize| a + (b - a) * k as f64 / (GRID - 1) as f64;
    let values: Vec<f64> = (0..GRID).map(|k| f(at(k))).collect();
    let best = (0..GRID)
        .min_by(|&i, &j| values[i].total_cmp(&values[j]))
        .unwrap_or(0);
    (at(best.saturating_sub(1)), at((best + 1).min(GRID - 1)))
}

/// Brent's method: a minimum of `f` on `[a, b]` to within about `2 tol` (absolute), and `f`
/// there, by
/// parabolic interpolation through the best three points where that step is safe and golden
/// sections otherwise (Brent 1973, "Algorithms for Minimization without Derivatives", ch. 5).
pub(super) fn brent_minimise(
    mut a: f64,
    mut b: f64,
    tol: f64,
    max_evals: usize,
    f: impl Fn(f64) -> f64,
) -> (f64, f64) {
    const CGOLD: f64 = 0.381_966_011_250_105_1; // (3 - sqrt 5) / 2
    let mut x = a + CGOLD * (b - a);
    let (mut w, mut v) = (x, x);
    let mut fx = f(x);
    let (mut fw, mut fv) = (fx, fx);
    // The last step and the one before it.
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 1..max_evals {
        let xm = 0.5 * (a + b);
        if (x - xm).abs() <= 2.0 * tol - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol {
            // Parabola through (x, fx), (w, fw), (v, fv): its minimum at x + p / q.
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            // Accept it if it lies inside [a, b] and moves less than half the step before last.
            if p.abs() < (0.5 * q * e).abs() && p > q * (a - x) && p < q * (b - x) {
                e = d;
                d = p / q;
                let u = x + d;
                if u - a < 2.0 * tol || b - u < 2.0 * tol {
                    d = tol.copysign(xm - x);
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= xm { a - x } else { b - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol {
            x + d
        } else {
            x + tol.copysign(d)
        };
        let fu = f(u);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, fv) = (w, fw);
            (w, fw) = (x, fx);
            (x, fx) = (u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv) = (w, fw);
                (w, fw) = (u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (x, fx)
}

#[cfg(test)]
mod tests {
    use super::*;
    use zmp_models::effects::servo::servo_first_harmonic;

    /// `estimate_limit` splits the effect's describing function into a run with the limit and
    /// a linear run it does once: the ratio must be the effect's own `frequency_response`.
    #[test]
    fn limit_runs_match_the_effects_describing_function() {
        let info = zmp_models::EffectKind::AccelerationSaturation.info();
        let h = zmp_models::DEFAULT_STEP;
        let (wn, zeta) = (28.0, 0.9);
        let ctx = BuildContext {
            h,
            binding: Binding::Axis(Axis::X),
            servo: Some((wn, zeta)),
            link: None,
        };
        for (limit, w, a) in [(1.2, 6.0, 0.05), (0.8, 12.0, 0.02), (3.0, 2.0, 0.01)] {
            let e = (info.build)(&ctx, &[limit]);
            let mut limits = vec![(info.build)(&ctx, &[limit])];
            let with = servo_first_harmonic(wn, zeta, h, &mut limits, w, a);
            let without = servo_first_harmonic(wn, zeta, h, &mut [], w, a);
            // Equal up to rounding: the effect computes its linear run at unit amplitude (a
            // limit never reached: 1 exactly, against the ratio of two runs of some thousand
            // steps, each rounding in the last bits).
            let (df, own) = (with / without, e.frequency_response(w, a));
            assert!((df - own).norm() <= 1e-11 * own.norm(), "{df} vs {own}");
        }
    }

    #[test]
    fn brent_finds_minima() {
        let calls = std::cell::Cell::new(0);
        let f = |x: f64| {
            calls.set(calls.get() + 1);
            (x - 0.3).powi(2) * (1.0 + 0.5 * x.sin()) + 2.0
        };
        let (x, _) = brent_minimise(-3.0, 3.0, 5e-5, 60, f);
        assert!((x - 0.3).abs() < 2e-4, "{x}");
        assert!(calls.get() < 20, "{} evaluations", calls.get());
        // A minimum at the end of the interval and a flat function.
        let (x, _) = brent_minimise(0.0, 1.0, 5e-5, 60, |x| -x);
        assert!(x > 1.0 - 2e-4, "{x}");
        let (x, _) = brent_minimise(0.0, 1.0, 5e-5, 60, |_| 1.0);
        assert!((0.0..=1.0).contains(&x));
    }

    #[test]
    fn the_grid_brackets_the_lowest_of_two_minima() {
        // 1120002's shape on log(limit) over [ln 0.097, ln 1.99]: a shallow valley around the
        // first golden point (0.31 m/s2) and the deep one at the drawn 1.255 m/s2.
        let (a, b) = (0.097f64.ln(), 1.99f64.ln());
        let deep = 1.255f64.ln();
        let f = |x: f64| {
            let shallow = 2.0e8 + 1.0e8 * (x - 0.309f64.ln()).powi(2);
            let valley = 1.3e4 + 2.0e9 * (x - deep).powi(2);
            shallow.min(valley)
        };
        // Brent alone settles in the shallow valley.
        let (x, _) = brent_minimise(a, b, 5e-5, 60, f);
        assert!((x - deep).abs() > 0.5, "{}", x.exp());
        let (lo, hi) = bracket(a, b, f);
        assert!(lo < deep && deep < hi, "{} {}", lo.exp(), hi.exp());
        let (x, _) = brent_minimise(lo, hi, 5e-5, 60, f);
        assert!((x - deep).abs() < 2e-4, "{}", x.exp());
        // A minimum at an end: the bracket keeps that end.
        let (lo, hi) = bracket(0.0, 1.0, |x| -x);
        assert_eq!(hi, 1.0);
        assert!(lo < 1.0);
        let (lo, _) = bracket(0.0, 1.0, |x| x);
        assert_eq!(lo, 0.0);
    }
}
