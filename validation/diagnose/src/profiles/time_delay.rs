//! A pure delay of the CoM command, per axis (two servos, two latencies).

use super::{instance_frees, per_axis, servo_of, DataRange, Profile, Start, SEED_SERVO};
use crate::structure::Candidate;
use crate::words::{phase_words, slope_through_origin, unwrapped_phase, Evidence};
use zmp_models::{Axis, Binding, EffectKind, ModelSpec};

pub struct TimeDelay;

/// The delay's range on this campaign: up to 3 rad at the highest frequency (at most 450 ms).
fn range(r: &DataRange) -> (f64, f64) {
    (0.0, (3.0 / r.omega_max).min(0.45))
}

/// How much more the model's servo low-pass lags than the seed's below their bandwidths
/// (`2 zeta / omega_n` against `2 / 30` s, what a delay of that length lags too), when that is
/// more than the delay's shortest start (a tenth of a radian at the top frequency).
pub fn absorbed_lag(spec: &ModelSpec, r: &DataRange) -> Option<f64> {
    spec.has(EffectKind::TrackingLowpass).then_some(())?;
    let (wn, zeta) = servo_of(spec, Binding::Axis(Axis::X));
    let lag = 2.0 * zeta / wn - 2.0 * SEED_SERVO.1 / SEED_SERVO.0;
    (lag > 0.1 / r.omega_max).then_some(lag)
}

impl Profile for TimeDelay {
    fn kind(&self) -> EffectKind {
        EffectKind::TimeDelay
    }

    fn model_kinds(&self) -> &'static [EffectKind] {
        &[EffectKind::TimeDelay]
    }

    /// Half a radian of lag at the top frequency (typical), a tenth, one and a half; and where
    /// the model's servo lags more than the seed's, the seed's servo with the difference as the
    /// delay (an identified model gives a delay's lag to a slower, more damped low-pass).
    fn starts(&self, spec: &ModelSpec, _c: &Candidate, r: &DataRange) -> Vec<Start> {
        let w = r.omega_max;
        let k = EffectKind::TimeDelay;
        let scan = [0.5 / w, 0.1 / w, 1.5 / w];
        let mut out = per_axis(spec, r, k, &[0.0], "delay", &scan, range(r));
        if let Some(lag) = absorbed_lag(spec, r) {
            let mut seed = spec.clone();
            for a in Axis::BOTH {
                let b = Binding::Axis(a);
                seed.set_value(EffectKind::TrackingLowpass, b, "omega_n", SEED_SERVO.0);
                seed.set_value(EffectKind::TrackingLowpass, b, "zeta", SEED_SERVO.1);
            }
            let v = lag.min(range(r).1);
            out.extend(per_axis(&seed, r, k, &[0.0], "delay", &[v], range(r)));
        }
        out
    }

    fn frees(&self, spec: &ModelSpec, r: &DataRange) -> Vec<crate::fit::Free> {
        instance_frees(spec, EffectKind::TimeDelay, "delay", range(r))
    }

    fn signature(&self, _c: &Candidate) -> &'static str {
        "phase lag growing in proportion to frequency, the gain unchanged"
    }

    fn evidence(&self, _c: &Candidate, e: &Evidence) -> String {
        let (w, ph, mag) = e.ratio_parts();
        let (wu, phu) = unwrapped_phase(&w, &ph);
        let (slope, r2) = slope_through_origin(&wu, &phu);
        let dev = crate::words::median(mag.iter().map(|m| (m - 1.0).abs()).collect());
        let tail = if slope < 0.0 && r2 >= 0.9 && dev < 0.05 {
            format!(": a pure delay ({})", e.params_text())
        } else {
            format!(
                "; the fitted delay ({}) explains what the other parameters do not",
                e.params_text()
            )
        };
        format!(
            "phase of measured/model {} (slope {slope:.4} s, R^2 {r2:.3}) while the magnitude \
             stays within {:.1} %{tail}",
            phase_words(slope, r2),
            100.0 * dev
        )
    }
}
