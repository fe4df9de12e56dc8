//! The twin's stance resonance, measured, against the structural mode the diagnosis names.
//!
//! The leg servos and the soft contacts let the whole robot sway on its stance: the load-cell
//! ZMP then differs from the rigid robot's by a factor that grows with frequency into a
//! resonance. [`sweep`] measures that factor directly on the model file
//! ([`super::crosscheck::stance_factor`]: the ZMP over the rigid prediction from
//! the measured trunk motion, so the trunk's own servo is divided out), noise-free, small
//! amplitude, from 5 to 100 rad/s; [`fit_mode`] fits the catalogue's `structural_mode` law
//! `(1 - share) + share wm^2 / (s^2 + 2 zeta wm s + wm^2)` to it.
//!
//! **Surrogate or physical.** Below a mode, its factor is `1 + (share / wm^2) w^2 + ...` (the
//! same for a `structural_mode` on the ZMP and a `flexible_trunk` in the servo's path): a
//! campaign that ends well below the resonance determines `share / wm^2` (the in-band
//! curvature) and little else, so a mode of lower frequency and smaller share can stand in for
//! one above the band. [`judge`] calls the named mode the physical resonance only when its
//! frequency is within [`FREQUENCY_TOLERANCE`] of the swept resonance's **and** the model with
//! it predicts the twin's measured response at that frequency within [`RESPONSE_TOLERANCE`];
//! otherwise it is an in-band surrogate, and the report gives both curvatures.

use super::campaign::response;
use super::crosscheck::stance_factor;
use super::props::MassProperties;
use super::summary::DiagnosisSummary;
use super::Silo2;
use crate::mj::TwinError;
use num_complex::Complex64;
use serde::Serialize;
use zmp_models::{Axis, ModelSpec, Plant};

/// Frequencies of the sweep, rad/s: from the campaign's band to twice the stance resonance.
pub fn sweep_omegas() -> Vec<f64> {
    zmp_models::logspace(5.0, 100.0, 16)
}

/// The swept resonance's damping is about 0.2: its half-power width (`2 zeta`) is 40 % of its
/// frequency; a named mode within 15 % of it sits well inside the resonance.
pub const FREQUENCY_TOLERANCE: f64 = 0.15;
/// A model whose mode is the resonance must also predict the twin's response at the mode's
/// frequency: within 30 % in magnitude (the fitted law misses the swept factor by up to about
/// 20 %, the stance being three compliant joints per leg and the contact, not one mode).
pub const RESPONSE_TOLERANCE: f64 = 0.3;

/// The ZMP swing the sweep aims for, m: far inside the support polygon (half-length 0.11 m).
const SWING: f64 = 0.02;

/// One swept point.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct StancePoint {
    pub axis: Axis,
    /// rad/s.
    pub omega: f64,
    pub magnitude: f64,
    pub phase_deg: f64,
}

impl StancePoint {
    fn value(&self) -> Complex64 {
        Complex64::from_polar(self.magnitude, self.phase_deg.to_radians())
    }
}

/// A mode: `structural_mode`'s law, or a named effect's mode parameters: rad/s, 1, 1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Mode {
    pub omega_n: f64,
    pub zeta: f64,
    pub share: f64,
}

impl Mode {
    pub fn factor(&self, omega: f64) -> Complex64 {
        let s = Complex64::new(0.0, omega);
        let w2 = self.omega_n * self.omega_n;
        (1.0 - self.share) + self.share * w2 / (s * s + 2.0 * self.zeta * self.omega_n * s + w2)
    }

    /// `share / wm^2`, s²: the coefficient of `w^2` below the mode.
    pub fn curvature(&self) -> f64 {
        self.share / (self.omega_n * self.omega_n)
    }
}

/// Sweeps the stance factor on both axes at `omegas` (CoM amplitude sized for a ZMP swing of
/// about 2 cm with the predicted `b`), on `threads` threads.
pub fn sweep(
    twin: &Silo2,
    props: &MassProperties,
    b: f64,
    omegas: &[f64],
    threads: usize,
) -> Result<Vec<StancePoint>, TwinError> {
    let jobs: Vec<(Axis, f64)> = Axis::BOTH
        .iter()
        .flat_map(|&a| omegas.iter().map(move |&w| (a, w)))
        .collect();
    zmp_campaign::par::try_parallel_map(jobs.len(), threads, |k| {
        let (axis, omega) = jobs[k];
        let amplitude = (SWING / (1.0 + b * omega * omega)).min(0.0035);
        let r = stance_factor(twin, props, axis, omega, amplitude)?;
        Ok(StancePoint {
            axis,
            omega,
            magnitude: r.norm(),
            phase_deg: r.arg().to_degrees(),
        })
    })
}

/// The least-squares `structural_mode` through the points (complex residuals): `share` solved
/// for each `(wm, zeta)` on a logarithmic grid, then finer grids around the best. Returns the
/// mode and the RMS of `|measured - fitted|`.
pub fn fit_mode(points: &[StancePoint]) -> (Mode, f64) {
    let cost = |wm: f64, zeta: f64| -> (f64, f64) {
        let probe = Mode {
            omega_n: wm,
            zeta,
            share: 1.0,
        };
        let (mut num, mut den) = (0.0, 0.0);
        for p in points {
            let m = probe.factor(p.omega) - 1.0;
            num += (m.conj() * (p.value() - 1.0)).re;
            den += m.norm_sqr();
        }
        let share = if den > 0.0 { num / den } else { 0.0 };
        let mode = Mode { share, ..probe };
        let sse: f64 = points
            .iter()
            .map(|p| (p.value() - mode.factor(p.omega)).norm_sqr())
            .sum();
        (sse, share)
    };
    // (sse, wm, zeta, share) of the best grid point in a box.
    let search = |best: (f64, f64, f64, f64), w: (f64, f64), z: (f64, f64), n: usize| {
        let mut best = best;
        for i in 0..n {
            let wm = w.0 * (w.1 / w.0).powf(i as f64 / (n - 1) as f64);
            for j in 0..n {
                let zeta = z.0 * (z.1 / z.0).powf(j as f64 / (n - 1) as f64);
                let (sse, share) = cost(wm, zeta);
                if sse < best.0 {
                    best = (sse, wm, zeta, share);
                }
            }
        }
        best
    };
    let best = search(
        (f64::INFINITY, 0.0, 0.0, 0.0),
        (5.0, 200.0),
        (0.01, 2.0),
        200,
    );
    // Zoom in three times, each box a tenth of the last (the coarse grid's steps are 1.9 % in
    // wm and 2.7 % in zeta).
    let mut best = best;
    for span in [1.05f64, 1.005, 1.0005] {
        let (w, z) = (best.1, best.2);
        best = search(best, (w / span, w * span), (z / span, z * span), 41);
    }
    let mode = Mode {
        omega_n: best.1,
        zeta: best.2,
        share: best.3,
    };
    (mode, (best.0 / points.len().max(1) as f64).sqrt())
}

/// The catalogued effects that are a mode of the robot: a `structural_mode` on the ZMP, or a
/// `flexible_trunk` (the diagnosis loop may move a mode into the servo's path).
pub const MODE_EFFECTS: [&str; 2] = ["structural_mode", "flexible_trunk"];

/// The mode the diagnosis added on `axis`, if any, with the effect's name.
pub fn named_mode(d: &DiagnosisSummary, axis: Axis) -> Option<(String, Mode)> {
    MODE_EFFECTS.iter().find_map(|effect| {
        let get = |p: &str| {
            let key = format!("{effect}.{}.{p}", axis.name());
            d.parameters
                .iter()
                .find(|(n, _)| *n == key)
                .map(|(_, v)| *v)
        };
        Some((
            effect.to_string(),
            Mode {
                omega_n: get("omega_n")?,
                zeta: get("zeta")?,
                share: get("share").unwrap_or(1.0),
            },
        ))
    })
}

/// What the stance of one axis is, and what the named mode is of it.
#[derive(Debug, Clone, Serialize)]
pub struct AxisStance {
    pub axis: Axis,
    pub swept: Vec<StancePoint>,
    /// Largest swept factor and where, rad/s.
    pub peak_magnitude: f64,
    pub peak_omega: f64,
    /// The law fitted to the sweep and its RMS misfit.
    pub fitted: Mode,
    pub fit_rms: f64,
    /// The diagnosis's mode on this axis and its effect.
    pub named: Option<Mode>,
    pub named_effect: Option<String>,
    /// At the named mode's frequency, `|ZMP_i / x_cr,i|`: the twin's (measured) and the model's
    /// with the mode (predicted).
    pub at_named: Option<(f64, f64)>,
    /// `physical`, `in-band surrogate`, or `none named`.
    pub verdict: String,
    pub why: String,
}

/// The verdict for one axis (see the module docs). `at_named`: the twin's and the model's
/// response magnitudes at the named mode's frequency.
pub fn judge(
    axis: Axis,
    swept: Vec<StancePoint>,
    named: Option<(String, Mode)>,
    at_named: Option<(f64, f64)>,
) -> AxisStance {
    let (fitted, fit_rms) = fit_mode(&swept);
    let peak = swept
        .iter()
        .copied()
        .max_by(|a, b| a.magnitude.total_cmp(&b.magnitude));
    let (peak_magnitude, peak_omega) =
        peak.map_or((f64::NAN, f64::NAN), |p| (p.magnitude, p.omega));
    let (verdict, why) = match (&named, at_named) {
        (Some((effect, m)), Some((meas, pred))) => {
            let freq_ok = (m.omega_n / fitted.omega_n - 1.0).abs() <= FREQUENCY_TOLERANCE;
            let response_ok = (pred / meas - 1.0).abs() <= RESPONSE_TOLERANCE;
            let verdict = if freq_ok && response_ok {
                "physical"
            } else {
                "in-band surrogate"
            };
            let why = format!(
                "{effect} at {:.1} rad/s (zeta {:.3}, share {:.3}): at that frequency the model \
                 predicts |G| = {:.1}, the twin measures {:.1}; the swept stance resonance is at \
                 {:.1} rad/s (zeta {:.3}, share {:.2}, peak {:.2} at {:.1} rad/s); in-band \
                 curvature share/wm^2: named {:.2e} s^2, swept {:.2e} s^2",
                m.omega_n,
                m.zeta,
                m.share,
                pred,
                meas,
                fitted.omega_n,
                fitted.zeta,
                fitted.share,
                peak_magnitude,
                peak_omega,
                m.curvature(),
                fitted.curvature()
            );
            (verdict, why)
        }
        _ => (
            "none named",
            format!(
                "the swept stance resonance is at {:.1} rad/s (zeta {:.3}, share {:.2})",
                fitted.omega_n, fitted.zeta, fitted.share
            ),
        ),
    };
    AxisStance {
        axis,
        swept,
        peak_magnitude,
        peak_omega,
        fitted,
        fit_rms,
        named: named.as_ref().map(|n| n.1),
        named_effect: named.map(|n| n.0),
        at_named,
        verdict: verdict.into(),
        why,
    }
}

/// The sweep, the fit and the verdict on both axes against the diagnosis `d` and the model it
/// ended with (`final_model`, `None` when it added nothing).
pub fn stance(
    twin: &Silo2,
    props: &MassProperties,
    b: f64,
    d: &DiagnosisSummary,
    final_model: Option<&ModelSpec>,
    threads: usize,
) -> Result<Vec<AxisStance>, TwinError> {
    let points = sweep(twin, props, b, &sweep_omegas(), threads)?;
    let mut out = Vec::new();
    for axis in Axis::BOTH {
        let swept: Vec<StancePoint> = points.iter().copied().filter(|p| p.axis == axis).collect();
        let named = named_mode(d, axis);
        let at_named = match (&named, final_model) {
            (Some((_, m)), Some(model)) => {
                let amplitude = (SWING / (1.0 + b * m.omega_n * m.omega_n)).min(0.0035);
                let meas = response(twin, props, axis, m.omega_n, amplitude)?;
                let plant =
                    Plant::new(model, zmp_models::DEFAULT_STEP).map_err(|e| TwinError::Model {
                        path: "the diagnosis's model".into(),
                        message: e.to_string(),
                    })?;
                let i = axis.index();
                let pred = plant.frequency_response(m.omega_n)[i][i];
                Some((meas.norm(), pred.norm()))
            }
            _ => None,
        };
        out.push(judge(axis, swept, named, at_named));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fit recovers a mode from its own noise-free factor, and a mode of lower frequency
    /// with the same in-band curvature is told apart from it.
    #[test]
    fn fit_recovers_a_mode_and_judge_tells_a_surrogate() {
        let truth = Mode {
            omega_n: 45.0,
            zeta: 0.2,
            share: 1.0,
        };
        let pts: Vec<StancePoint> = sweep_omegas()
            .iter()
            .map(|&w| {
                let v = truth.factor(w);
                StancePoint {
                    axis: Axis::Y,
                    omega: w,
                    magnitude: v.norm(),
                    phase_deg: v.arg().to_degrees(),
                }
            })
            .collect();
        let (m, rms) = fit_mode(&pts);
        assert!((m.omega_n / 45.0 - 1.0).abs() < 0.005, "{m:?}");
        assert!(
            (m.zeta / 0.2 - 1.0).abs() < 0.02 && (m.share - 1.0).abs() < 0.01,
            "{m:?}"
        );
        assert!(rms < 1e-3);
        // Same curvature below 12 rad/s, a quarter of the share: a surrogate.
        let surrogate = Mode {
            omega_n: 22.5,
            zeta: 0.04,
            share: 0.25,
        };
        assert!((surrogate.curvature() / truth.curvature() - 1.0).abs() < 1e-12);
        // A twin whose stance is `truth` measures `truth`'s factor; a model with the surrogate
        // predicts its own at its frequency.
        let at = |m: Mode| Some((truth.factor(m.omega_n).norm(), m.factor(m.omega_n).norm()));
        let named = |m: Mode| Some(("structural_mode".to_string(), m));
        let s = judge(Axis::Y, pts.clone(), named(surrogate), at(surrogate));
        assert_eq!(s.verdict, "in-band surrogate", "{}", s.why);
        let p = judge(Axis::Y, pts, named(truth), at(truth));
        assert_eq!(p.verdict, "physical", "{}", p.why);
    }
}
