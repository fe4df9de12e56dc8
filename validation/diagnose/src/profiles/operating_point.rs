//! The pendulum's `a` and `b` changing linearly with the CoM position (one law for every
//! channel: a common relative slope per direction).

use super::{add_effect, DataRange, Profile, Start};
use crate::fit::Free;
use crate::structure::Candidate;
use crate::words::{op_line, sig, Evidence};
use zmp_models::{Binding, EffectKind, ModelSpec};

pub struct OperatingPoint;

const K: EffectKind = EffectKind::OperatingPointDependence;

/// The slopes along the directions the operating points span, each up to a relative change
/// of 2 over the span (100 per metre at most).
fn frees_at(values: [f64; 4], r: &DataRange) -> Vec<Free> {
    let g = vec![Binding::Global];
    let mut out = Vec::new();
    for (k, (pa, pb)) in [("da_dx", "db_dx"), ("da_dy", "db_dy")]
        .into_iter()
        .enumerate()
    {
        if r.op_span[k] > 1e-9 {
            let lim = (2.0 / r.op_span[k]).min(100.0);
            out.push(Free::new(K, g.clone(), pa, values[k], -lim, lim));
            out.push(Free::new(K, g.clone(), pb, values[k + 2], -lim, lim));
        }
    }
    out
}

impl Profile for OperatingPoint {
    fn kind(&self) -> EffectKind {
        K
    }

    fn model_kinds(&self) -> &'static [EffectKind] {
        &[K]
    }

    /// Only where the campaign has more than one operating point.
    fn addable(&self, spec: &ModelSpec, _c: &Candidate, r: &DataRange) -> bool {
        !spec.has(K) && r.op_span.iter().any(|s| *s > 1e-9)
    }

    /// No dependence: the slopes are nearly linear in the response, one start reaches them.
    fn starts(&self, spec: &ModelSpec, _c: &Candidate, r: &DataRange) -> Vec<Start> {
        let mut s = spec.clone();
        add_effect(&mut s, K, &[Binding::Global], &[0.0; 4]);
        vec![(s, frees_at([0.0; 4], r))]
    }

    fn frees(&self, spec: &ModelSpec, r: &DataRange) -> Vec<Free> {
        let Some(e) = spec.get(K, Binding::Global) else {
            return Vec::new();
        };
        let v = |p| e.value(p).unwrap_or(0.0);
        frees_at([v("da_dx"), v("da_dy"), v("db_dx"), v("db_dy")], r)
    }

    fn signature(&self, _c: &Candidate) -> &'static str {
        "the same sine answering with a gain that changes with the operating point"
    }

    fn evidence(&self, _c: &Candidate, e: &Evidence) -> String {
        let r = e.ratios();
        let mut spread = 0.0f64;
        for &(k, q) in &r {
            for &(m, p) in &r {
                let (a, b) = (e.obs[k], e.obs[m]);
                if a.excited == b.excited
                    && (a.omega - b.omega).abs() <= 1e-9 * a.omega
                    && a.nominal_amplitude == b.nominal_amplitude
                    && a.operating_point != b.operating_point
                {
                    spread = spread.max((q.norm() / p.norm() - 1.0).abs());
                }
            }
        }
        let mut s = format!(
            "the same sine gives gains up to {:.1} % apart at different operating points: the \
             pendulum's a and b move with the CoM position ({})",
            100.0 * spread,
            e.params_text()
        );
        if let Some(u) = op_line(e.obs) {
            let get = |k: &str| e.value_of(k);
            s.push_str(&format!(
                "; the operating points lie on one line (direction x {:.2}, y {:.2}), so only \
                 the slopes along it are determined, not the x and y ones apart: da = {} and \
                 db = {} per m along the line",
                u[0],
                u[1],
                sig(u[0] * get("da_dx") + u[1] * get("da_dy")),
                sig(u[0] * get("db_dx") + u[1] * get("db_dy"))
            ));
        }
        s
    }
}
