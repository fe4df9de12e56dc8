//! A play, per axis: on the CoM command (cheap, in closed form) or inside the servo's loop
//! between the drive and the trunk (`in_servo = 1`: where the force limit clamps, the limited
//! force moves the drive alone through the play, then the trunk).

use super::{add_effect, axis, instance_frees, DataRange, Profile, Start};
use crate::fit::Free;
use crate::structure::{Candidate, Law};
use crate::words::{amplitude_evidence, Evidence};
use zmp_models::{EffectKind, ModelSpec};

pub struct Backlash;

const K: EffectKind = EffectKind::Backlash;

/// Widths up to nearly twice the smallest amplitude (beyond, the smallest sines would not move
/// the trunk at all), 10 cm at most.
fn width_range(r: &DataRange) -> (f64, f64) {
    (0.0, (1.9 * r.amplitude_min).min(0.1))
}

/// The drive's share of the axis's inertia inside the servo (the registry's range).
const DRIVE_RANGE: (f64, f64) = (0.01, 0.9);

impl Profile for Backlash {
    fn kind(&self) -> EffectKind {
        K
    }

    fn model_kinds(&self) -> &'static [EffectKind] {
        &[K]
    }

    fn laws(&self) -> &'static [Law] {
        &[Law::OnCommand, Law::InServo]
    }

    /// Not where the model has a play; inside the servo not where a flexible link is (a servo
    /// drives one link).
    fn addable(&self, spec: &ModelSpec, c: &Candidate, r: &DataRange) -> bool {
        !spec.has(K)
            && (c.law == Law::OnCommand
                || !r.excited().into_iter().any(|a| {
                    spec.value(EffectKind::FlexibleTrunk, axis(a), "in_servo") == Some(1.0)
                }))
    }

    /// A tenth of the smallest amplitude (typical) and half of it; inside the servo each also
    /// with a third and half of the inertia in the drive, and with the force limit as it is
    /// and doubled (inside the servo the limited force accelerates the drive alone while the
    /// play is open, so a limit fitted for a rigid trunk is low for it).
    fn starts(&self, spec: &ModelSpec, c: &Candidate, r: &DataRange) -> Vec<Start> {
        let axes = r.excited();
        let (lo, hi) = width_range(r);
        let inside = c.law == Law::InServo;
        let (drives, factors): (&[f64], &[f64]) = if inside {
            (&[0.3, 0.5], &[1.0, 2.0])
        } else {
            (&[0.3], &[1.0])
        };
        let sat = EffectKind::AccelerationSaturation;
        let mut out = Vec::new();
        for width in [0.1, 0.5].map(|f| f * r.amplitude_min) {
            for &drive in drives {
                for &factor in factors {
                    let mut s = spec.clone();
                    let mut own = Vec::new();
                    for a in &axes {
                        let b = axis(*a);
                        let law = if inside { 1.0 } else { 0.0 };
                        add_effect(&mut s, K, &[b], &[width, law, 150.0, 0.2, drive, 20.0]);
                        own.push(Free::new(K, vec![b], "width", width, lo, hi));
                        if !inside {
                            continue;
                        }
                        let (dlo, dhi) = DRIVE_RANGE;
                        own.push(Free::new(K, vec![b], "drive", drive, dlo, dhi));
                        if let Some(l) = spec.value(sat, b, "limit") {
                            s.set_value(sat, b, "limit", factor * l);
                            own.push(Free::new(sat, vec![b], "limit", factor * l, 1e-3, 1e3));
                        }
                    }
                    if factor == 1.0 || own.iter().any(|f| f.kind == sat) {
                        out.push((s, own));
                    }
                }
            }
        }
        out
    }

    /// The width of every play; inside the servo the drive's share too (the transmission's
    /// shape, its mode, damping and drag, is the ringing of the impacts that a ZMP's first and
    /// third harmonics barely resolve: the model file's).
    fn frees(&self, spec: &ModelSpec, r: &DataRange) -> Vec<Free> {
        let mut out = instance_frees(spec, K, "width", width_range(r));
        out.extend(
            instance_frees(spec, K, "drive", DRIVE_RANGE)
                .into_iter()
                .filter(|f| spec.value(K, f.bindings[0], "in_servo") == Some(1.0)),
        );
        out
    }

    /// The widths alone: a play's absence is a width of zero, and inside the servo the drive's
    /// share of the inertia acts through the transmission even without a play (its compliance
    /// and drag), so a determined share is no evidence of a play.
    fn strength(&self, fit: &crate::fit::Fit, _c: &Candidate) -> Vec<(f64, f64)> {
        fit.frees
            .iter()
            .zip(&fit.std_err)
            .filter(|(f, _)| f.kind == K && f.param == "width")
            .map(|(f, e)| (f.bounds.value, *e))
            .collect()
    }

    fn costly(&self, c: &Candidate) -> bool {
        c.law == Law::InServo
    }

    fn signature(&self, c: &Candidate) -> &'static str {
        match c.law {
            Law::InServo => {
                "small sines responding less and later than large ones, odd harmonics, and \
                 where the force limit clamps the drive moving ahead of the trunk"
            }
            _ => "small sines responding less and later than large ones, with odd harmonics",
        }
    }

    fn evidence(&self, _c: &Candidate, e: &Evidence) -> String {
        amplitude_evidence(
            "a play the drive must cross before the CoM moves (backlash)",
            e,
        )
    }
}
