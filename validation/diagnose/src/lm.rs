//! A small bounded Levenberg-Marquardt: forward-difference Jacobians, Broyden's secant update
//! between them.

use nalgebra::{DMatrix, DVector};

/// A scalar the fit may change, with bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounded {
    /// The current value (the start, before a fit).
    pub value: f64,
    /// Lowest value the fit may give it.
    pub min: f64,
    /// Highest value the fit may give it.
    pub max: f64,
}

/// Minimises `|r(theta)|^2` in at most `max_iter` iterations, and up to `extra` more while the
/// cost still falls by more than a statistically meaningful amount (over the last
/// [`DESCENT_WINDOW`] iterations, by more than [`NEGLIGIBLE_CHI2`] per iteration scaled by the
/// mismatch factor: a fit in a long curved valley descends steadily but slowly). `r` returns
/// `None` for parameters it cannot evaluate (treated as a failed step). Once `stop()` says so (a time limit), the fit ends
/// with the best parameters so far: checked before each iteration and where `r` fails while
/// the Jacobian is formed (`r` may fail because of the limit). Returns the best parameters,
/// the final cost and the Gauss-Newton covariance diagonal `(J^T J)^{-1}` scaled by the
/// residual variance, from a forward-difference Jacobian at the parameters returned (infinite
/// for a parameter the residuals do not move).
pub fn minimise(
    theta0: &[Bounded],
    max_iter: usize,
    extra: usize,
    r: &mut dyn FnMut(&[f64]) -> Option<Vec<f64>>,
    stop: &dyn Fn() -> bool,
) -> Option<(Vec<f64>, f64, Vec<f64>)> {
    let n = theta0.len();
    let clamp = |v: &mut [f64]| {
        for (x, b) in v.iter_mut().zip(theta0) {
            *x = x.clamp(b.min, b.max);
        }
    };
    let mut theta: Vec<f64> = theta0.iter().map(|b| b.value).collect();
    clamp(&mut theta);
    let mut res = r(&theta)?;
    let mut cost: f64 = res.iter().map(|x| x * x).sum();
    let mut lambda = 1e-3;
    let m = res.len();
    let mut jac = DMatrix::<f64>::zeros(m, n);
    // Whether `jac` is the forward-difference Jacobian at `theta` (else a secant update of
    // one, or nothing yet).
    let mut fresh = false;
    // The cost after each iteration, for the descent past `max_iter`.
    let mut costs = vec![cost];
    let mut iter = 0;
    while iter < max_iter + extra {
        if (iter >= max_iter && !still_descending(&costs, m, n)) || stop() {
            break;
        }
        if !fresh && (iter % REFRESH == 0 || costs.len() == 1) {
            match jacobian(theta0, &theta, &res, r) {
                Some(j) => jac = j,
                None if stop() => return Some(finish(theta, cost, &jac, m)),
                None => return None,
            }
            fresh = true;
        }
        let jtj = jac.transpose() * &jac;
        let g = jac.transpose() * DVector::from_vec(res.clone());
        let mut improved = None;
        for _ in 0..12 {
            let mut a = jtj.clone();
            for k in 0..n {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(step) = a.lu().solve(&(-&g)) else {
                lambda *= 10.0;
                continue;
            };
            let mut trial: Vec<f64> = theta.iter().zip(step.iter()).map(|(t, s)| t + s).collect();
            clamp(&mut trial);
            if let Some(rt) = r(&trial) {
                let ct: f64 = rt.iter().map(|x| x * x).sum();
                if ct < cost {
                    improved = Some((trial, rt, ct));
                    lambda = (lambda * 0.3).max(1e-9);
                    break;
                }
            }
            lambda *= 10.0;
        }
        let Some((trial, rt, ct)) = improved else {
            // A secant Jacobian that finds no descent is refreshed before the fit gives up.
            if fresh {
                break;
            }
            lambda = (lambda * 1e-12).max(1e-3);
            match jacobian(theta0, &theta, &res, r) {
                Some(j) => jac = j,
                None if stop() => return Some(finish(theta, cost, &jac, m)),
                None => return None,
            }
            fresh = true;
            continue;
        };
        // Broyden's rank-one update along the step taken (Madsen, Nielsen and Tingleff,
        // *Methods for non-linear least squares problems*, 2004, section 3.4): the Jacobian
        // is differenced afresh every [`REFRESH`] iterations and where the update leads
        // nowhere.
        let s = DVector::from_iterator(n, trial.iter().zip(&theta).map(|(a, b)| a - b));
        let ss = s.dot(&s);
        if ss > 0.0 {
            let y = DVector::from_iterator(m, rt.iter().zip(&res).map(|(a, b)| a - b));
            let u = (y - &jac * &s) / ss;
            jac += u * s.transpose();
        }
        fresh = false;
        let rel = (cost - ct) / cost.max(1e-300);
        theta = trial;
        res = rt;
        cost = ct;
        costs.push(cost);
        iter += 1;
        if rel < 1e-5 {
            break;
        }
    }
    if !fresh {
        // The covariance from the Jacobian at the parameters returned.
        if let Some(j) = jacobian(theta0, &theta, &res, r) {
            jac = j;
        }
    }
    Some(finish(theta, cost, &jac, m))
}

/// Iterations between forward-difference Jacobians; the secant (Broyden) update in between.
pub const REFRESH: usize = 4;

/// The forward-difference Jacobian of `r` at `theta` (residuals `res` there); `None` where
/// `r` fails.
fn jacobian(
    theta0: &[Bounded],
    theta: &[f64],
    res: &[f64],
    r: &mut dyn FnMut(&[f64]) -> Option<Vec<f64>>,
) -> Option<DMatrix<f64>> {
    let (m, n) = (res.len(), theta.len());
    let mut jac = DMatrix::<f64>::zeros(m, n);
    for k in 0..n {
        let span = theta0[k].max - theta0[k].min;
        let mut hstep = 1e-6 * theta[k].abs().max(1e-3 * span.min(1.0)).max(1e-9);
        if theta[k] + hstep > theta0[k].max {
            hstep = -hstep;
        }
        let mut tp = theta.to_vec();
        tp[k] += hstep;
        let rp = r(&tp)?;
        for i in 0..m.min(rp.len()) {
            jac[(i, k)] = (rp[i] - res[i]) / hstep;
        }
    }
    Some(jac)
}

/// Iterations over which a fit's descent is measured to decide whether it goes on past its
/// iteration count ([`minimise`]).
pub const DESCENT_WINDOW: usize = 5;

/// Smallest fall of the chi-square per iteration, in units of the mismatch factor, that keeps
/// a fit going past its iteration count: a tenth of one (a difference of 0.1 in a chi-square is
/// no evidence for anything; Press et al., *Numerical Recipes*, section 15.5).
pub const NEGLIGIBLE_CHI2: f64 = 0.1;

/// Whether the cost (a chi-square of `m` whitened residuals in `n` parameters, after each
/// iteration: `costs`) fell over the last [`DESCENT_WINDOW`] iterations by more than
/// [`NEGLIGIBLE_CHI2`] per iteration, scaled by the mismatch factor `cost / (m - n)` (at least
/// one). A fit cut off while it still falls by more than that would credit the next structure,
/// which starts from it, with the descent it did not finish.
fn still_descending(costs: &[f64], m: usize, n: usize) -> bool {
    let done = costs.len() - 1;
    let c = (costs[done] / (m as f64 - n as f64).max(1.0)).max(1.0);
    done >= DESCENT_WINDOW
        && costs[done - DESCENT_WINDOW] - costs[done] > DESCENT_WINDOW as f64 * NEGLIGIBLE_CHI2 * c
}

/// The parameters, the cost and the Gauss-Newton variance of each parameter. A parameter the
/// residuals do not move at all (a force limit no record reaches) has infinite variance and
/// leaves the others' as they are (its row and column of `J^T J` are zero: the matrix is
/// block-diagonal); the others' come from the inverse over them (all infinite where that
/// is singular too).
fn finish(theta: Vec<f64>, cost: f64, jac: &DMatrix<f64>, m: usize) -> (Vec<f64>, f64, Vec<f64>) {
    let n = theta.len();
    let jtj = jac.transpose() * jac;
    // Unweighted residuals: the residual variance scales the covariance.
    let chi2 = cost / (m as f64 - n as f64).max(1.0);
    let seen: Vec<usize> = (0..n)
        .filter(|&k| jtj[(k, k)] > 0.0 && jtj[(k, k)].is_finite())
        .collect();
    let sub = DMatrix::from_fn(seen.len(), seen.len(), |i, j| jtj[(seen[i], seen[j])]);
    let mut var = vec![f64::INFINITY; n];
    if let Some(inv) = sub.try_inverse() {
        for (i, &k) in seen.iter().enumerate() {
            var[k] = inv[(i, i)].abs() * chi2;
        }
    }
    (theta, cost, var)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `2 exp(-1.3 t)` on 50 samples fitted from `(a, k)`, in `max_iter` iterations and up to
    /// `extra` more while it descends: the parameters and the cost.
    fn exponential(a: f64, k: f64, max_iter: usize, extra: usize) -> (Vec<f64>, f64) {
        let t: Vec<f64> = (0..50).map(|k| k as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 2.0 * (-1.3 * t).exp()).collect();
        let mut r = |p: &[f64]| {
            Some(
                t.iter()
                    .zip(&y)
                    .map(|(t, y)| p[0] * (-p[1] * t).exp() - y)
                    .collect(),
            )
        };
        let b = |value| Bounded {
            value,
            min: 0.0,
            max: 10.0,
        };
        let (p, cost, _) = minimise(&[b(a), b(k)], max_iter, extra, &mut r, &|| false).unwrap();
        (p, cost)
    }

    #[test]
    fn fits_an_exponential() {
        let (p, cost) = exponential(1.0, 0.5, 100, 0);
        assert!(cost < 1e-16, "{cost}");
        assert!((p[0] - 2.0).abs() < 1e-6 && (p[1] - 1.3).abs() < 1e-6);
    }

    /// A parameter the residuals ignore has infinite variance; the other keeps the variance
    /// of its fit alone (`y = a t` on 10 samples: `1 / sum t^2` times the residual variance).
    #[test]
    fn an_ignored_parameter_leaves_the_others_determined() {
        let t: Vec<f64> = (1..=10).map(f64::from).collect();
        let noise = [0.1, -0.2, 0.05, 0.0, 0.3, -0.1, -0.05, 0.2, -0.3, 0.1];
        let mut r = |p: &[f64]| {
            Some(
                t.iter()
                    .zip(&noise)
                    .map(|(t, e)| p[0] * t - (2.0 * t + e))
                    .collect::<Vec<f64>>(),
            )
        };
        let b = |value| Bounded {
            value,
            min: -10.0,
            max: 10.0,
        };
        let (p, cost, var) = minimise(&[b(1.0), b(0.5)], 20, 0, &mut r, &|| false).unwrap();
        let stt: f64 = t.iter().map(|t| t * t).sum();
        let expected = cost / (10.0 - 2.0) / stt;
        assert!((p[0] - 2.0).abs() < 0.05, "{p:?}");
        assert!(
            (var[0] / expected - 1.0).abs() < 1e-6,
            "{} vs {expected}",
            var[0]
        );
        assert!(var[1].is_infinite(), "{var:?}");
    }

    #[test]
    fn respects_bounds() {
        let mut r = |p: &[f64]| Some(vec![p[0] - 5.0]);
        let (p, _, _) = minimise(
            &[Bounded {
                value: 0.0,
                min: -1.0,
                max: 1.0,
            }],
            50,
            0,
            &mut r,
            &|| false,
        )
        .unwrap();
        assert_eq!(p[0], 1.0);
    }

    #[test]
    fn goes_on_while_descending() {
        // Five iterations from far away leave it short of the minimum; the descent goes on to the exact fit.
        let (_, short) = exponential(0.05, 8.0, 5, 0);
        let (_, long) = exponential(0.05, 8.0, 5, 100);
        assert!(short > 0.1, "5 iterations already at {short}");
        assert!(long < 1e-16, "still at {long} with the descent allowed");
    }

    #[test]
    fn stops_where_nothing_is_left_to_descend() {
        // Started at the minimum: the extra iterations are not used.
        let mut calls = [0; 2];
        for (k, extra) in [0, 200].into_iter().enumerate() {
            let mut r = |p: &[f64]| {
                calls[k] += 1;
                Some(vec![p[0] - 1.0, 2.0 * (p[1] + 0.5)])
            };
            let b = |value| Bounded {
                value,
                min: -5.0,
                max: 5.0,
            };
            minimise(&[b(1.0), b(-0.5)], 3, extra, &mut r, &|| false).unwrap();
        }
        assert_eq!(calls[0], calls[1]);
    }

    #[test]
    fn a_stop_ends_the_fit_with_the_best_so_far() {
        // The exponential of `exponential`, stopped once `r` has been called 10 times: `r`
        // fails from then on (as a fit's residuals do past its time limit), and the fit ends
        // with what it had, better than the start, short of the minimum, without failing.
        let t: Vec<f64> = (0..50).map(|k| k as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 2.0 * (-1.3 * t).exp()).collect();
        let calls = std::cell::Cell::new(0);
        let stopped = || calls.get() >= 10;
        let mut r = |p: &[f64]| {
            if stopped() {
                return None;
            }
            calls.set(calls.get() + 1);
            Some(
                t.iter()
                    .zip(&y)
                    .map(|(t, y)| p[0] * (-p[1] * t).exp() - y)
                    .collect::<Vec<f64>>(),
            )
        };
        let b = |value| Bounded {
            value,
            min: 0.0,
            max: 10.0,
        };
        let start: f64 = t
            .iter()
            .zip(&y)
            .map(|(t, y)| (0.2 * (-3.0 * t).exp() - y).powi(2))
            .sum();
        let (p, cost, _) = minimise(&[b(0.2), b(3.0)], 100, 0, &mut r, &stopped).unwrap();
        assert_eq!(calls.get(), 10);
        assert!(cost < start && cost > 1e-6, "{cost} from {start}");
        assert!(p[0] != 0.2 || p[1] != 3.0);
    }
}
