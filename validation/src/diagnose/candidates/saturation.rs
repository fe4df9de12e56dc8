//! The acceleration-saturation candidate: the servo's force limit per axis, started below
//! what the campaign demands, an identified limit that never acts restarted from there.

use super::{add_effect, per_axis, servo_params, DataRange, Free, Start, AXES};
use zmp_models::{Binding, ModelSpec};

pub(super) fn acceleration_saturation(spec: &ModelSpec, r: &DataRange) -> Vec<Start> {
    // The largest acceleration the campaign demands of the linear servo.
    let (wn, zeta) = servo_params(spec);
    let peak = |w: f64| {
        let h = wn * wn / ((wn * wn - w * w).powi(2) + (2.0 * zeta * wn * w).powi(2)).sqrt();
        w * w * h * r.amplitude_max
    };
    let acc = peak(r.omega_max).max(1e-6);
    let (min, max) = (0.02 * acc, 2.0 * acc);
    if !spec.has("acceleration_saturation") {
        return per_axis(
            spec,
            r,
            "acceleration_saturation",
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
    let inactive: Vec<Binding> = AXES
        .iter()
        .zip(r.axes_excited)
        .filter(|(b, e)| {
            *e && spec
                .value("acceleration_saturation", **b, "limit")
                .is_some_and(|l| l >= acc)
        })
        .map(|(b, _)| *b)
        .collect();
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
                        spec.value("acceleration_saturation", *b, "limit")
                            .unwrap_or(v)
                            .clamp(min, max)
                    };
                    add_effect(&mut s, "acceleration_saturation", &[*b], &[value]);
                    Free::new(
                        "acceleration_saturation",
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
