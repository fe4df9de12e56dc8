//! The servo's acceleration (force) limit, per axis: the seed's structure has it; the
//! catalogue adds it to a model without one.

use super::{instance_frees, per_axis, servo_of, DataRange, Profile, Start};
use crate::fit::Free;
use crate::structure::Candidate;
use zmp_models::{Axis, Binding, EffectKind, ModelSpec};

pub struct Saturation;

const K: EffectKind = EffectKind::AccelerationSaturation;

/// The largest acceleration the campaign demands of `spec`'s linear servo: the largest
/// amplitude at the top frequency through the tracking low-pass.
pub fn demanded_acceleration(spec: &ModelSpec, r: &DataRange) -> f64 {
    let (wn, zeta) = servo_of(spec, Binding::Axis(Axis::X));
    let w = r.omega_max;
    let h = wn * wn / ((wn * wn - w * w).powi(2) + (2.0 * zeta * wn * w).powi(2)).sqrt();
    (w * w * h * r.amplitude_max).max(1e-6)
}

impl Profile for Saturation {
    fn kind(&self) -> EffectKind {
        K
    }

    fn model_kinds(&self) -> &'static [EffectKind] {
        &[K]
    }

    /// Eight and four tenths of the largest demand (the first typical); between 2 % and twice
    /// the demand (a limit above it never acts).
    fn starts(&self, spec: &ModelSpec, _c: &Candidate, r: &DataRange) -> Vec<Start> {
        let d = demanded_acceleration(spec, r);
        per_axis(
            spec,
            r,
            K,
            &[d],
            "limit",
            &[0.8 * d, 0.4 * d],
            (0.02 * d, 2.0 * d),
        )
    }

    /// Every limit within the registry's range, and a passive damping the model has, up to the
    /// servo's damping `2 zeta omega_n` it is part of (beyond, the servo's own would be
    /// negative). A passive damping the model does not have is the user's to set: free in every
    /// fit, it turns the force limit into a speed limit, which explains a rate-limited servo
    /// outside the catalogue.
    fn frees(&self, spec: &ModelSpec, _r: &DataRange) -> Vec<Free> {
        let mut out = instance_frees(spec, K, "limit", (1e-3, 1e3));
        for e in spec.effects.iter().filter(|e| e.info.kind == K) {
            let Some(c) = e.value("passive_damping").filter(|c| *c > 0.0) else {
                continue;
            };
            let (w, z) = servo_of(spec, e.binding);
            let max = 2.0 * z * w;
            out.push(Free::new(
                K,
                vec![e.binding],
                "passive_damping",
                c,
                0.0,
                max,
            ));
        }
        out
    }

    fn costly(&self, _c: &Candidate) -> bool {
        true
    }

    fn signature(&self, _c: &Candidate) -> &'static str {
        "large, fast sines losing gain and lagging, with odd harmonics, the small ones untouched"
    }

    fn evidence(&self, _c: &Candidate, e: &crate::words::Evidence) -> String {
        let (_, _, mag) = e.ratio_parts();
        let h3 = e
            .obs
            .iter()
            .map(|o| {
                let j = o.excited.index();
                o.y3[j].norm() / o.y1[j].norm().max(1e-300)
            })
            .fold(0.0, f64::max);
        let loss = mag.iter().map(|m| 1.0 - m).fold(0.0, f64::max);
        format!(
            "records with large amplitude x omega^2 lose up to {:.1} % of gain and carry a third \
             harmonic of up to {:.1} % of the fundamental, small ones do not: the servo's \
             acceleration is limited ({})",
            100.0 * loss,
            100.0 * h3,
            e.params_text()
        )
    }
}
