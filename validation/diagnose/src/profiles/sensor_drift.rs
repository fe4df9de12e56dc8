//! A linear drift of the ZMP reading, per output axis.

use super::{instance_frees, per_axis, DataRange, Profile, Start};
use crate::structure::Candidate;
use crate::words::Evidence;
use zmp_models::{EffectKind, ModelSpec};

pub struct SensorDrift;

/// The registry's range: up to 0.1 m/s either way.
const RANGE: (f64, f64) = (-0.1, 0.1);

impl Profile for SensorDrift {
    fn kind(&self) -> EffectKind {
        EffectKind::SensorDrift
    }

    fn model_kinds(&self) -> &'static [EffectKind] {
        &[EffectKind::SensorDrift]
    }

    /// No drift: the rate is linear in the trend, one start reaches it.
    fn starts(&self, spec: &ModelSpec, _c: &Candidate, r: &DataRange) -> Vec<Start> {
        per_axis(
            spec,
            r,
            EffectKind::SensorDrift,
            &[0.0, 0.0],
            "rate",
            &[0.0],
            RANGE,
        )
    }

    fn frees(&self, spec: &ModelSpec, _r: &DataRange) -> Vec<crate::fit::Free> {
        instance_frees(spec, EffectKind::SensorDrift, "rate", RANGE)
    }

    fn signature(&self, _c: &Candidate) -> &'static str {
        "a linear trend of the ZMP reading through every record, the harmonics unchanged"
    }

    fn evidence(&self, _c: &Candidate, e: &Evidence) -> String {
        let n = e.obs.len().max(1) as f64;
        let mut sl = [0.0f64; 2];
        let mut t = [0.0f64; 2];
        for o in e.obs {
            for i in 0..2 {
                sl[i] += o.slope[i] / n;
                t[i] += o.slope[i] / o.slope_var[i].sqrt().max(1e-300) / n;
            }
        }
        format!(
            "the measured ZMP drifts linearly through every record (x {:+.3} mm/s, y {:+.3} \
             mm/s; mean {:.0} and {:.0} standard errors) where the model is periodic: a \
             drifting ZMP sensor offset ({})",
            sl[0] * 1e3,
            sl[1] * 1e3,
            t[0],
            t[1],
            e.params_text()
        )
    }
}
