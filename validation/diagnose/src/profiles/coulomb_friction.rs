//! Coulomb friction against the servo's motion, per axis.

use super::{instance_frees, per_axis, servo_of, DataRange, Profile, Start};
use crate::structure::Candidate;
use crate::words::{amplitude_evidence, Evidence};
use zmp_models::{Axis, Binding, EffectKind, ModelSpec};

pub struct CoulombFriction;

/// A friction `F` shifts the servo by about `F / wn^2`: comparable with the smallest
/// amplitude at `F = A_min wn^2`, beyond which the smallest sines barely move (a stuck servo,
/// not friction).
fn scale(spec: &ModelSpec, r: &DataRange) -> f64 {
    let (wn, _) = servo_of(spec, Binding::Axis(Axis::X));
    (r.amplitude_min * wn * wn).min(100.0)
}

impl Profile for CoulombFriction {
    fn kind(&self) -> EffectKind {
        EffectKind::CoulombFriction
    }

    fn model_kinds(&self) -> &'static [EffectKind] {
        &[EffectKind::CoulombFriction]
    }

    /// Three and ten per cent of that scale (the first typical).
    fn starts(&self, spec: &ModelSpec, _c: &Candidate, r: &DataRange) -> Vec<Start> {
        let f0 = scale(spec, r);
        let k = EffectKind::CoulombFriction;
        per_axis(
            spec,
            r,
            k,
            &[0.0],
            "level",
            &[0.03 * f0, 0.1 * f0],
            (0.0, f0),
        )
    }

    fn frees(&self, spec: &ModelSpec, r: &DataRange) -> Vec<crate::fit::Free> {
        let k = EffectKind::CoulombFriction;
        instance_frees(spec, k, "level", (0.0, scale(spec, r)))
    }

    fn costly(&self, _c: &Candidate) -> bool {
        true
    }

    fn signature(&self, _c: &Candidate) -> &'static str {
        "small sines responding less and later than large ones, most at low frequency where \
         the servo's force is small, with odd harmonics"
    }

    fn evidence(&self, _c: &Candidate, e: &Evidence) -> String {
        amplitude_evidence("Coulomb friction decelerating the CoM", e)
    }
}
