//! A linear drift of the ZMP reading, per output axis, under two laws: one rate through every
//! record (`only`), or a sensor re-zeroed at every record whose drift rate changes from record
//! to record (`per_record`, which holds the first as the case of equal rates).
//!
//! **Per record.** A record's trend is its own: no other record predicts it, so each record's
//! rate is a nuisance parameter fitted on that record alone ([`measure`](crate::measure)
//! predicts each record's own trend), and the criterion counts those rates as parameters the
//! held-out records did not test (`criterion::HeldOut::nuisance`): the structure must beat its
//! parent by a likelihood-ratio test with that many degrees of freedom. Against the one rate,
//! that is Cochran's test of heterogeneity, `Q = sum (s_k - mean)^2 / var(s_k)` on `n - 1`
//! degrees of freedom. The model keeps the mean rate and the records' spread beyond their
//! noise (`rate`, `rate_spread`: Paule and Mandel's estimate, `profiles::trend_spread`).

use super::{instance_frees, per_axis, DataRange, Profile, Start};
use crate::fit::{Fit, Free};
use crate::structure::{Candidate, Law};
use crate::words::Evidence;
use zmp_models::{EffectKind, ModelSpec};

pub struct SensorDrift;

const K: EffectKind = EffectKind::SensorDrift;

/// The registry's range: up to 0.1 m/s either way.
const RANGE: (f64, f64) = (-0.1, 0.1);

/// The smallest spread that marks a per-record law (m/s): below any sensor's resolution over a
/// record, so a model whose records' rates are all alike still keeps the law it was given.
const MARK: f64 = 1e-12;

/// Whether the drift of `spec` on output `i` is per record (a spread of rates).
pub fn per_record(spec: &ModelSpec, i: usize) -> bool {
    let b = zmp_models::Binding::Axis(zmp_models::Axis::from_index(i).expect("0 or 1"));
    spec.value(K, b, "rate_spread").is_some_and(|s| s > 0.0)
}

impl Profile for SensorDrift {
    fn kind(&self) -> EffectKind {
        K
    }

    fn model_kinds(&self) -> &'static [EffectKind] {
        &[K]
    }

    fn laws(&self) -> &'static [Law] {
        &[Law::Only, Law::PerRecord]
    }

    /// One rate: none, linear in the trend, one start reaches it. Per record: the records'
    /// mean rate and spread (nothing to fit: each record's trend is its own).
    fn starts(&self, spec: &ModelSpec, c: &Candidate, r: &DataRange) -> Vec<Start> {
        if c.law == Law::PerRecord {
            let mut s = spec.clone();
            for a in r.excited() {
                let [mean, spread] = r.trend[a.index()];
                super::add_effect(
                    &mut s,
                    K,
                    &[super::axis(a)],
                    &[0.0, mean, spread.max(MARK), 0.0],
                );
            }
            return vec![(s, Vec::new())];
        }
        per_axis(spec, r, K, &[0.0, 0.0], "rate", &[0.0], RANGE)
    }

    /// The one rate; a per-record drift has none to fit.
    fn frees(&self, spec: &ModelSpec, _r: &DataRange) -> Vec<Free> {
        instance_frees(spec, K, "rate", RANGE)
            .into_iter()
            .filter(|f| {
                !f.bindings.iter().any(|b| match b {
                    zmp_models::Binding::Axis(a) => per_record(spec, a.index()),
                    _ => false,
                })
            })
            .collect()
    }

    /// One rate: the fitted rates (a Wald test). Per record: the criterion's likelihood-ratio
    /// test on the records' own rates is the whole evidence (the records a fold was fitted on
    /// determine their own trends).
    fn strength(&self, fit: &Fit, c: &Candidate) -> Vec<(f64, f64)> {
        if c.law == Law::PerRecord {
            return vec![(1.0, 0.0)];
        }
        fit.frees
            .iter()
            .zip(&fit.std_err)
            .filter(|(f, _)| f.kind == K)
            .map(|(f, e)| (f.bounds.value, *e))
            .collect()
    }

    fn signature(&self, c: &Candidate) -> &'static str {
        if c.law == Law::PerRecord {
            "a linear trend of the ZMP reading with a rate of its own in each record, the \
             harmonics unchanged"
        } else {
            "a linear trend of the ZMP reading through every record, the harmonics unchanged"
        }
    }

    fn evidence(&self, c: &Candidate, e: &Evidence) -> String {
        if c.law == Law::PerRecord {
            return per_record_evidence(e);
        }
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

/// The records' trends per output: their mean and spread, and Cochran's `Q` against one rate,
/// saying on which outputs the rates differ beyond their noise (`Q` above its quantile at the
/// criterion's level on `n - 1` degrees of freedom).
fn per_record_evidence(e: &Evidence) -> String {
    let n = e.obs.len();
    let dof = n.saturating_sub(1).max(1) as f64;
    let mut beyond = Vec::new();
    let parts: Vec<String> = (0..2)
        .map(|i| {
            let [mean, spread] = super::trend_spread(e.obs, i);
            let (_, q) = super::trend_q(e.obs, i, 0.0);
            if q > crate::criterion::chi2_quantile(dof, crate::criterion::ALPHA) {
                beyond.push(["x", "y"][i]);
            }
            format!(
                "{} {:+.3} mm/s mean, {:.3} mm/s from record to record (Q {:.0} on {} degrees \
                 of freedom)",
                ["x", "y"][i],
                mean * 1e3,
                spread * 1e3,
                q,
                n.saturating_sub(1)
            )
        })
        .collect();
    let lead = if beyond.is_empty() {
        "each record's ZMP drifts linearly, at rates that differ from record to record by \
         little more than their noise on either output"
            .to_string()
    } else {
        format!(
            "each record's ZMP drifts linearly at a rate of its own, the rates differing from \
             record to record beyond their noise on {}",
            beyond.join(" and ")
        )
    };
    format!(
        "{lead} ({}): a ZMP sensor re-zeroed at every record whose drift differs each time",
        parts.join("; ")
    )
}
