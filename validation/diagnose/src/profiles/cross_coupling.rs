//! The pendulum's coupling terms a model leaves at zero (`a12`, `a21`, `b12`, `b21`): the
//! unexcited ZMP axis answering.

use super::{DataRange, Profile, Start};
use crate::fit::Free;
use crate::structure::{Candidate, Law};
use crate::words::Evidence;
use zmp_models::{Binding, EffectKind, ModelSpec};

pub struct CrossCoupling;

const TERMS: [&str; 4] = ["a12", "a21", "b12", "b21"];

fn zero_terms(spec: &ModelSpec) -> Vec<&'static str> {
    TERMS
        .into_iter()
        .filter(|p| spec.value(EffectKind::Pendulum, Binding::Global, p) == Some(0.0))
        .collect()
}

impl Profile for CrossCoupling {
    fn kind(&self) -> EffectKind {
        EffectKind::Pendulum
    }

    fn name(&self) -> &'static str {
        "cross_coupling"
    }

    fn model_kinds(&self) -> &'static [EffectKind] {
        &[EffectKind::Pendulum]
    }

    fn laws(&self) -> &'static [Law] {
        &[Law::Coupling]
    }

    /// The coupling terms alone (the pendulum's own terms are every structure's).
    fn strength(&self, fit: &crate::fit::Fit, _c: &Candidate) -> Vec<(f64, f64)> {
        fit.frees
            .iter()
            .zip(&fit.std_err)
            .filter(|(f, _)| f.kind == EffectKind::Pendulum && TERMS.contains(&f.param))
            .map(|(f, e)| (f.bounds.value, *e))
            .collect()
    }

    /// While the model leaves a coupling term at zero.
    fn addable(&self, spec: &ModelSpec, _c: &Candidate, _r: &DataRange) -> bool {
        !zero_terms(spec).is_empty()
    }

    /// The zero terms freed from zero (the response is linear in them).
    fn starts(&self, spec: &ModelSpec, _c: &Candidate, _r: &DataRange) -> Vec<Start> {
        let frees: Vec<Free> = zero_terms(spec)
            .into_iter()
            .map(|p| {
                Free::new(
                    EffectKind::Pendulum,
                    vec![Binding::Global],
                    p,
                    0.0,
                    -10.0,
                    10.0,
                )
            })
            .collect();
        if frees.is_empty() {
            return Vec::new();
        }
        vec![(spec.clone(), frees)]
    }

    /// None of its own: a coupling term that is not zero is the core's (`fit::core_frees`).
    fn frees(&self, _spec: &ModelSpec, _r: &DataRange) -> Vec<Free> {
        Vec::new()
    }

    /// The coupling terms back at zero.
    fn remove(&self, spec: &mut ModelSpec, _c: &Candidate) {
        for p in TERMS {
            spec.set_value(EffectKind::Pendulum, Binding::Global, p, 0.0);
        }
    }

    fn signature(&self, _c: &Candidate) -> &'static str {
        "the unexcited ZMP axis answering in proportion to the excited one"
    }

    fn evidence(&self, _c: &Candidate, e: &Evidence) -> String {
        let mut peak = [0.0f64; 2];
        for (o, p) in e.obs.iter().zip(e.base) {
            let j = o.excited.index();
            if p.g[1 - j].norm() == 0.0 {
                peak[j] = peak[j].max(o.g(1 - j).norm());
            }
        }
        format!(
            "the unexcited ZMP axis responds (|G21| up to {:.3}, |G12| up to {:.3}) where the \
             model has no coupling ({})",
            peak[0],
            peak[1],
            e.params_text()
        )
    }
}
