//! The acceleration-saturation candidate: the servo's force limit per axis, started below
//! what the campaign demands, an identified limit that never acts restarted from there.

use super::{add_effect, per_axis, servo_params, DataRange, Free, Start, AXES};
use zmp_models::EffectKind;
use zmp_models::{Binding, ModelSpec};

/// The largest acceleration the campaign demands of `spec`'s linear servo: the largest
/// amplitude at the top frequency through the tracking low-pass.
pub fn demanded_acceleration(spec: &ModelSpec, r: &DataRange) -> f64 {
    let (wn, zeta) = servo_params(spec);
    let w = r.omega_max;
    let h = wn * wn / ((wn * wn - w * w).powi(2) + (2.0 * zeta * wn * w).powi(2)).sqrt();
    (w * w * h * r.amplitude_max).max(1e-6)
}

/// The force limits (their bindings: an axis, or both) on excited axes that lie at or above
/// everything the campaign demands: a limit that never acts, which a fit cannot move (no
/// gradient).
pub fn inactive_limits(spec: &ModelSpec, r: &DataRange) -> Vec<Binding> {
    let acc = demanded_acceleration(spec, r);
    let excited = |b: Binding| match b {
        Binding::Axis(a) => AXES
            .iter()
            .zip(r.axes_excited)
            .any(|(x, e)| e && *x == Binding::Axis(a)),
        _ => r.axes_excited.iter().any(|e| *e),
    };
    spec.effects
        .iter()
        .filter(|e| e.info.kind == EffectKind::AccelerationSaturation && excited(e.binding))
        .filter(|e| e.value("limit").is_some_and(|l| l >= acc))
        .map(|e| e.binding)
        .collect()
}

pub(super) fn acceleration_saturation(spec: &ModelSpec, r: &DataRange) -> Vec<Start> {
    let acc = demanded_acceleration(spec, r);
    let (min, max) = (0.02 * acc, 2.0 * acc);
    if !spec.has(EffectKind::AccelerationSaturation) {
        return per_axis(
            spec,
            r,
            EffectKind::AccelerationSaturation,
            "limit",
            &[0.4 * acc, 0.8 * acc],
            min,
            max,
        );
    }
    // The model has a limit already (the identification's, from records it judged saturated).
    // A limit above everything the campaign demands of an axis never acts, so a fit cannot
    // move it (no gradient): restart such an axis from below the demand, the active axes
    // from their values. Physical reason: the servo's force limit is an acceleration limit
    // that differs per axis with the inertia it moves (a flexible link, a heavier drive).
    // Per axis (a limit shared by both axes is left as it is).
    let mut inactive = inactive_limits(spec, r);
    inactive.retain(|b| matches!(b, Binding::Axis(_)));
    if inactive.is_empty() {
        return Vec::new();
    }
    [0.4 * acc, 0.8 * acc]
        .iter()
        .map(|&v| {
            let mut s = spec.clone();
            let frees = AXES
                .iter()
                .zip(r.axes_excited)
                .filter(|(_, e)| *e)
                .map(|(b, _)| {
                    let value = if inactive.contains(b) {
                        v
                    } else {
                        spec.value(EffectKind::AccelerationSaturation, *b, "limit")
                            .unwrap_or(v)
                            .clamp(min, max)
                    };
                    add_effect(&mut s, EffectKind::AccelerationSaturation, &[*b], &[value]);
                    Free::new(
                        EffectKind::AccelerationSaturation,
                        vec![*b],
                        "limit",
                        value,
                        min,
                        max,
                    )
                })
                .collect();
            (s, frees)
        })
        .collect()
}
