//! Steps 4-5: the pendulum and tracking low-pass fitted to the records' `G` columns (with a
//! start model's other linear effects as fixed factors), and the same fit with a pure delay.

use super::fit::{self, Point, NP};
use super::saturation_limit::brent_minimise;
use super::{DelayAlternative, IdentifyError, RecordFit};
use num_complex::Complex64;
use zmp_models::{Axis, Channel, ModelSpec, Plant};

/// Chi-square drop that one added parameter must bring to be kept (likelihood-ratio test at
/// p = 0.001).
const LIKELIHOOD_RATIO_1DOF: f64 = 10.83;

/// The fixed complex factor of the start model's extra linear effects, per record and output.
pub(super) fn start_factors(
    start: Option<&ModelSpec>,
    records: &[RecordFit],
) -> Vec<[Complex64; 2]> {
    let one = [Complex64::new(1.0, 0.0); 2];
    let Some(spec) = start else {
        return vec![one; records.len()];
    };
    let Ok(mut plant) = Plant::new(spec, zmp_models::DEFAULT_STEP) else {
        return vec![one; records.len()];
    };
    let lp = |a: Axis| *plant.tracking_lowpass(a);
    let pend = *plant.pendulum();
    let lps = [lp(Axis::X), lp(Axis::Y)];
    records
        .iter()
        .map(|r| {
            if r.excluded.is_some() {
                return one;
            }
            plant.set_operating_point([0.0, 0.0]);
            let j = r.excited.index();
            plant.set_operating_point(r.operating_point);
            let full = plant.frequency_response(r.omega);
            let mut f = one;
            for i in 0..2 {
                let ch = Channel {
                    output: Axis::from_index(i).expect("0 or 1"),
                    input: r.excited,
                };
                let core = pend.response(ch, r.omega) * lps[j].freq(r.omega);
                if core.norm() > 0.0 {
                    f[i] = full[i][j] / core;
                }
            }
            f
        })
        .collect()
}

pub(super) fn points(
    records: &[RecordFit],
    factors: &[[Complex64; 2]],
    skip: &[usize],
) -> Vec<Point> {
    let mut pts = Vec::new();
    for r in records {
        if r.excluded.is_some() || skip.contains(&r.index) {
            continue;
        }
        for i in 0..2 {
            if r.sigma[i] > 0.0 && r.g[i].re.is_finite() && r.g[i].im.is_finite() {
                pts.push(Point {
                    i,
                    j: r.excited.index(),
                    omega: r.omega_fit,
                    g: r.g[i],
                    sigma: r.sigma[i],
                    factor: factors[r.index][i],
                });
            }
        }
    }
    pts
}

/// Steps 4-5: returns the fit, whether the bandwidth was estimated, and a note.
pub(super) fn pendulum_fit(
    pts: &[Point],
    (wn0, z0): (f64, f64),
    fix: bool,
) -> Result<(fit::LmResult, bool, String), IdentifyError> {
    if pts.is_empty() {
        return Err(IdentifyError::FitFailed("no data points".into()));
    }
    let all: Vec<usize> = (0..NP).collect();
    let core: Vec<usize> = (0..8).collect();
    let start = fit::linear_start(pts, wn0, z0);
    let fixed = fit::levenberg_marquardt(start, pts, &core);
    if fix {
        return Ok((
            fixed,
            false,
            format!("tracking low-pass given (omega_n = {wn0} rad/s, zeta = {z0}), not estimated"),
        ));
    }
    // Parameter `k` of a fit is determined: finite, in its plausible range, relative standard
    // error below 25 %.
    let determined = |lm: &fit::LmResult, k: usize, (lo, hi): (f64, f64)| {
        lm.params.iter().all(|v| v.is_finite())
            && lm.params[k] > lo
            && lm.params[k] < hi
            && lm.stderr[k] / lm.params[k] < 0.25
    };
    const WN_RANGE: (f64, f64) = (0.5, 1e4);
    let free = fit::levenberg_marquardt(fixed.params, pts, &all);
    let p = free.params;
    if determined(&free, 8, WN_RANGE) && determined(&free, 9, (0.01, 100.0)) {
        let note = format!(
            "tracking low-pass estimated from the data: omega_n = {:.2} +- {:.2} rad/s, zeta = \
             {:.3} +- {:.3}",
            p[8], free.stderr[8], p[9], free.stderr[9]
        );
        return Ok((free, true, note));
    }
    // A band that ends well below omega_n determines the low-pass's phase lag, about
    // 2 zeta w / omega_n, but not omega_n and zeta apart: fit omega_n with zeta held, and keep it
    // when it is determined and the likelihood-ratio test prefers it to the given low-pass
    // (chi-square drop above 10.83, p = 0.001 for one parameter, in units of the reduced
    // chi-square when the fit is worse than its noise).
    let mut with_wn = core.clone();
    with_wn.push(8);
    let one = fit::levenberg_marquardt(fixed.params, pts, &with_wn);
    let scale = if one.dof > 0 {
        (one.chi2 / one.dof as f64).max(1.0)
    } else {
        f64::INFINITY
    };
    let wn = one.params[8];
    if determined(&one, 8, WN_RANGE) && (fixed.chi2 - one.chi2) / scale > LIKELIHOOD_RATIO_1DOF {
        let note = format!(
            "tracking low-pass: omega_n = {:.2} +- {:.2} rad/s estimated from the data with \
             zeta held at {z0} (the data determine the phase lag, not omega_n and zeta apart: \
             both free gave omega_n = {:.3e} +- {:.1e}, zeta = {:.3e} +- {:.1e}); the errors of \
             a, b do not include zeta's uncertainty",
            wn, one.stderr[8], p[8], free.stderr[8], p[9], free.stderr[9]
        );
        Ok((one, true, note))
    } else {
        Ok((
            fixed,
            false,
            format!(
                "the data do not determine the tracking low-pass (estimate omega_n = {:.3e} +- \
                 {:.1e} rad/s, zeta = {:.3e} +- {:.1e}); the given omega_n = {wn0} rad/s, zeta = \
                 {z0} are used (set them with --bandwidth WN,ZETA), and the errors of a, b do \
                 not include their uncertainty",
                p[8], free.stderr[8], p[9], free.stderr[9]
            ),
        ))
    }
}

/// The pendulum fit with a pure delay `tau` as a fixed factor `e^{-j w tau}` of every point,
/// `tau` chosen by Brent's method on the chi-square within `[0, min(0.5 s, 3 / omega_n)]`.
pub(super) fn delay_alternative_fit(
    pts: &[Point],
    (wn0, z0): (f64, f64),
    wn_fit: f64,
) -> Option<DelayAlternative> {
    let with_delay = |tau: f64| -> Vec<Point> {
        pts.iter()
            .map(|p| Point {
                factor: p.factor * Complex64::from_polar(1.0, -p.omega * tau),
                ..*p
            })
            .collect()
    };
    let fit_at = |tau: f64| pendulum_fit(&with_delay(tau), (wn0.max(wn_fit), z0), false).ok();
    let chi = |tau: f64| fit_at(tau).map_or(f64::INFINITY, |(l, _, _)| l.chi2);
    let hi = (3.0 / wn_fit.max(1.0)).min(0.5);
    let (tau, _) = brent_minimise(0.0, hi, 1e-5, 40, chi);
    let (l, _, _) = fit_at(tau)?;
    (l.dof > 0).then(|| DelayAlternative {
        delay_s: tau,
        omega_n: l.params[8],
        zeta: l.params[9],
        reduced_chi2: l.chi2 / l.dof as f64,
    })
}
