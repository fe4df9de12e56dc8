//! Parents refitted from their children's fits.
//!
//! A structure's fit is the best over every start the search knows. A child `P + e` starts
//! from its parent `P`'s fit and from typical values, and its multi-start can find a basin of
//! the model's own parameters (the pendulum's, the servo's) that `P`'s starts never reached;
//! compared with `P`, the child is then credited with an improvement that is not `e`'s, and an
//! effect whose parameters end at no effect at all (a drift rate of zero, a low-pass cutoff
//! far above the band) is found "significant". So where a child claims to be significantly
//! better than a parent, the parent is fitted once more on each fold from the children's fits
//! with their effects taken out, and keeps that fit where it is better on the fold's own records (the
//! maximum of the likelihood over one more start; nothing is fitted on a test fold). The
//! comparisons are then made between structures each at its best known fit.

use super::{records, Node};
use crate::criterion::{compare, HeldOut};
use crate::fit::{all_frees, fit_starts, Fit};
use crate::observe::Observation;
use crate::profiles::{axis, profile, DataRange, Start};
use crate::structure::{Candidate, Structure};
use std::collections::BTreeMap;
use zmp_models::ModelSpec;

/// `spec` with candidate `c`'s effect taken out (its instances on `c`'s plane, or all of them).
pub fn strip(spec: &ModelSpec, c: &Candidate) -> ModelSpec {
    let kinds = profile(c.kind).model_kinds();
    let mut s = spec.clone();
    s.effects.retain(|e| {
        !(kinds.contains(&e.info.kind) && c.plane.is_none_or(|p| e.binding == axis(p)))
    });
    s
}

/// For every parent that a scored structure of `level` is significantly better than, one more
/// fit per fold from the claiming children's fits with their added effects taken out (the
/// multi-start policy of `fit::fit_starts` over them); kept where it is better on the fold's
/// records. Returns the parents whose fits changed.
pub(super) fn refresh_parents(
    nodes: &mut BTreeMap<Structure, Node>,
    level: &[Structure],
    obs: &[&Observation],
    r: &DataRange,
    threads: usize,
    z_crit: f64,
) -> Vec<Structure> {
    let c = super::mismatch(nodes);
    // Per parent: every child of the level that claims over it, with the effect it adds.
    let mut claims: BTreeMap<Structure, Vec<(Structure, Candidate)>> = BTreeMap::new();
    for s in level.iter().filter(|s| nodes.contains_key(*s)) {
        let held = &nodes[s].held;
        for e in s.effects() {
            let p = s.without(e);
            let Some(pn) = nodes.get(&p) else { continue };
            if compare(held, &pn.held, c).better(z_crit) {
                claims.entry(p).or_default().push((s.clone(), *e));
            }
        }
    }
    // Per parent and fold, the one multi-start policy over the claiming children's fits with
    // their effects taken out: every start evaluated, the nearest fitted.
    let mut jobs: Vec<(Structure, usize, Vec<Start>)> = Vec::new();
    for (p, children) in &claims {
        for f in 0..2 {
            let starts = children
                .iter()
                .map(|(child, e)| {
                    let spec = strip(&nodes[child].folds[f].spec, e);
                    let frees = all_frees(&spec, r);
                    (spec, frees)
                })
                .collect();
            jobs.push((p.clone(), f, starts));
        }
    }
    let fits = zmp_campaign::par::parallel_map(jobs.len(), threads, |i| {
        let (_, f, starts) = &jobs[i];
        fit_starts(starts, &records(obs, Some(*f)), r)
    });
    let mut changed: Vec<Structure> = Vec::new();
    for ((p, f, _), fit) in jobs.into_iter().zip(fits) {
        let Some(fit): Option<Fit> = fit else {
            continue;
        };
        let node = nodes.get_mut(&p).expect("a claimed parent is scored");
        if fit.cost < node.folds[f].cost {
            node.folds[f] = fit;
            if !changed.contains(&p) {
                changed.push(p);
            }
        }
    }
    for p in &changed {
        let node = nodes.get_mut(p).expect("scored");
        if let Some(held) = HeldOut::of([&node.folds[0].spec, &node.folds[1].spec], obs) {
            node.held = held;
        }
    }
    changed
}
