//! A first-order low-pass on the ZMP measurement, per output axis (two force sensors).

use super::{instance_frees, per_axis, DataRange, Profile, Start};
use crate::structure::Candidate;
use crate::words::Evidence;
use zmp_models::{EffectKind, ModelSpec};

pub struct SensorLowpass;

/// From a fifth of the lowest frequency to a hundred times the highest (a tenth of a degree
/// of lag there: no filter).
fn range(r: &DataRange) -> (f64, f64) {
    (0.2 * r.omega_min, 100.0 * r.omega_max)
}

impl Profile for SensorLowpass {
    fn kind(&self) -> EffectKind {
        EffectKind::SensorLowpass
    }

    fn model_kinds(&self) -> &'static [EffectKind] {
        &[EffectKind::SensorLowpass]
    }

    /// The cutoff at the top frequency (typical), at half of it and at four times it.
    fn starts(&self, spec: &ModelSpec, _c: &Candidate, r: &DataRange) -> Vec<Start> {
        let scan = [1.0, 0.5, 4.0].map(|f| f * r.omega_max);
        let k = EffectKind::SensorLowpass;
        per_axis(spec, r, k, &[r.omega_max], "cutoff", &scan, range(r))
    }

    fn frees(&self, spec: &ModelSpec, r: &DataRange) -> Vec<crate::fit::Free> {
        instance_frees(spec, EffectKind::SensorLowpass, "cutoff", range(r))
    }

    fn signature(&self, _c: &Candidate) -> &'static str {
        "gain falling and phase lagging towards 90 degrees above its cutoff, on the ZMP reading"
    }

    fn evidence(&self, _c: &Candidate, e: &Evidence) -> String {
        let (w, ph, mag) = e.ratio_parts();
        let hi = w.iter().copied().fold(0.0, f64::max);
        let top: Vec<usize> = (0..w.len()).filter(|&k| w[k] >= 0.99 * hi).collect();
        let n = top.len().max(1) as f64;
        let m = top.iter().map(|&k| mag[k]).sum::<f64>() / n;
        let p = top.iter().map(|&k| ph[k]).sum::<f64>() / n;
        format!(
            "magnitude of measured/model falls to {:+.1} dB and the phase lags {:.1} deg at \
             {hi:.1} rad/s, both growing with omega like a first-order filter on the ZMP \
             measurement ({})",
            20.0 * m.max(1e-12).log10(),
            -p.to_degrees(),
            e.params_text()
        )
    }
}
