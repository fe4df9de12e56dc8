//! The search: a lattice of structures, the identified model's own (the root) plus up to
//! [`MAX_EFFECTS`] candidates, each scored by the one criterion (`criterion`).
//!
//! **Where it goes.** Every single candidate (each kind under each law, a mode per plane) and
//! every pair, exhaustively; then a beam of width [`BEAM`]: the best admissible structures of
//! each level, each with every candidate it admits added, to four effects.
//!
//! **How each structure is fitted** on each fold (and on all records for those reported):
//! from its parents' fits on the same records (the structure without one of its effects) with
//! the missing effect at each of its profile's starts, and from the identified model's core
//! after `fit::undo` with every effect at its typical values; the one multi-start policy of
//! `fit::fit_starts`. A fold's fit never starts from anything fitted on its test records.
//!
//! **What it concludes.** A structure is *admissible* when each of its effects is significant:
//! it is significantly better (`criterion::compare`) than itself without that effect. The
//! *best* is the admissible structure with the lowest held-out chi-square. The *set* is the
//! best and the admissible structures that are not significantly worse than it nor than any
//! structure already in the set (at most [`MAX_SET`], one per set of kinds, best first): more
//! than one, and the data cannot decide between them. A structure the records part from a
//! member of the set by many standard deviations yet fit about as well is no such
//! alternative: Cox's test centred on each rejects both (`criterion`), and it is reported
//! as parted from that member (neither is the whole truth). A structure that does not predict
//! significantly better than a smaller admissible structure inside it (the identified model's
//! own, say) is no alternative to it.

use crate::criterion::{compare, split, threshold, Comparison, HeldOut};
use crate::fit::{core_frees, fit_starts, undo, Fit};
use crate::observe::Observation;
use crate::profiles::{candidates, effect_frees, profile, DataRange, Start};
use crate::structure::{Candidate, Structure};
use std::collections::BTreeMap;
use zmp_models::ModelSpec;

pub mod nested;

/// Effects a structure adds at most.
pub const MAX_EFFECTS: usize = 4;
/// Structures of a level the beam goes on from.
pub const BEAM: usize = 3;
/// Structures an ambiguous verdict names at most.
pub const MAX_SET: usize = 3;

/// A scored structure.
#[derive(Debug, Clone)]
pub struct Node {
    /// The structure scored.
    pub structure: Structure,
    /// Fitted on each fold's records (`criterion::split`).
    pub folds: [Fit; 2],
    /// Its records scored by the fold fits not fitted on them.
    pub held: HeldOut,
}

/// The search's result.
#[derive(Debug, Clone)]
pub struct Search {
    /// Every structure scored, by structure.
    pub nodes: BTreeMap<Structure, Node>,
    /// The threshold of its comparisons (`criterion::threshold` over the structures it
    /// planned to compare).
    pub z_crit: f64,
    /// How many structures it planned to compare.
    pub compared: usize,
    /// The mismatch factor of its comparisons: the best-predicting structure's held-out
    /// chi-square per component, at least 1.
    pub mismatch: f64,
    /// The admissible structures.
    pub admissible: Vec<Structure>,
    /// The best admissible structure.
    pub best: Structure,
    /// What the data cannot decide between (the best first; one member when they can).
    pub set: Vec<Structure>,
    /// Structures the records part from a member of the set (the member first) yet fit about
    /// as well: Cox's test rejects both ([`Comparison::neither`]), so they are no alternative
    /// the records cannot decide between, and neither is the whole truth.
    pub parted: Vec<(Structure, Structure)>,
    /// Whether the time limit passed before every planned structure was scored.
    pub cut_short: bool,
}

impl Search {
    /// The scored node of `s` (panics when `s` was not scored).
    pub fn node(&self, s: &Structure) -> &Node {
        &self.nodes[s]
    }

    /// `a` against `b` by the criterion.
    pub fn compare(&self, a: &Structure, b: &Structure) -> Comparison {
        compare(&self.nodes[a].held, &self.nodes[b].held, self.mismatch)
    }

    /// The structures from the root to `s`, one effect added at each step: at each step back
    /// the scored parent with the lowest held-out chi-square.
    pub fn chain(&self, s: &Structure) -> Vec<Structure> {
        let mut out = vec![s.clone()];
        let mut at = s.clone();
        while !at.is_empty() {
            let Some(p) = at
                .effects()
                .iter()
                .map(|c| at.without(c))
                .filter(|p| self.nodes.contains_key(p))
                .min_by(|a, b| self.nodes[a].held.chi2.total_cmp(&self.nodes[b].held.chi2))
            else {
                break;
            };
            out.push(p.clone());
            at = p;
        }
        out.reverse();
        out
    }
}

/// The records a fit of fold `f` uses (`None`: all of them).
fn records<'a>(obs: &[&'a Observation], f: Option<usize>) -> Vec<&'a Observation> {
    match f {
        Some(f) => split(obs, f).0,
        None => obs.to_vec(),
    }
}

/// The starts of structure `s` on one set of records: `parents` are its scored parents'
/// fits there (each `s` without one effect), `root` the root's fit there.
fn starts_of(
    s: &Structure,
    parents: &[(&Structure, &Fit)],
    root: &Fit,
    r: &DataRange,
) -> Vec<Start> {
    let mut out: Vec<Start> = Vec::new();
    for (p, fit) in parents {
        let Some(c) = s.effects().iter().find(|c| !p.contains(c)) else {
            continue;
        };
        out.extend(profile(c.kind).starts(&fit.spec, c, r));
    }
    // From typical values: the root's core undone, every effect at its typical start.
    for (spec, own) in undo(&root.spec, r) {
        let mut start = (spec, own);
        for c in s.effects() {
            let Some((spec, own)) = profile(c.kind).starts(&start.0, c, r).into_iter().next()
            else {
                return out;
            };
            start.0 = spec;
            start.1.extend(own);
        }
        out.push(start);
    }
    out
}

/// The root's fit on some records: the model's core from it as it is and from each undo start.
pub fn fit_root(model: &ModelSpec, obs: &[&Observation], r: &DataRange) -> Option<Fit> {
    let starts: Vec<Start> = undo(model, r)
        .into_iter()
        .map(|(s, mut own)| {
            let core = core_frees(&s);
            own.retain(|f| !core.iter().any(|c| c.name() == f.name()));
            own.extend(core);
            (s, own)
        })
        .collect();
    fit_starts(&starts, obs, r)
}

/// Searches from `model` on `obs` with `threads` threads; `progress` names each structure
/// scored. `None` when the root itself cannot be fitted.
pub fn search(
    model: &ModelSpec,
    obs: &[&Observation],
    threads: usize,
    progress: &(dyn Fn(&str) + Sync),
) -> Option<Search> {
    let r = DataRange::of(obs);
    let root = Structure::root();
    let fits = zmp_campaign::par::parallel_map(2, threads, |f| {
        fit_root(model, &records(obs, Some(f)), &r)
    });
    let [Some(a), Some(b)] = <[Option<Fit>; 2]>::try_from(fits).ok()? else {
        return None;
    };
    let held = HeldOut::of([&a.spec, &b.spec], obs)?;
    let mut nodes = BTreeMap::new();
    nodes.insert(
        root.clone(),
        Node {
            structure: root.clone(),
            folds: [a, b],
            held,
        },
    );
    let (singles, pairs) = lattice(model, &r);
    let compared = planned(&singles, &pairs);
    let z_crit = threshold(compared);
    let mut level: Vec<Structure> = singles.iter().map(|c| root.with(*c)).collect();
    let mut cut_short = false;
    for depth in 1..=MAX_EFFECTS {
        if depth == 2 {
            level = pairs.clone();
        }
        score_all(&mut nodes, &level, obs, &r, threads, progress);
        nested::refresh_parents(&mut nodes, &level, obs, &r, threads, z_crit);
        if zmp_campaign::par::past_deadline() {
            cut_short = true;
            break;
        }
        if (2..MAX_EFFECTS).contains(&depth) {
            // The beam: the best admissible structures of this level that no admissible
            // structure found so far is significantly better than (a structure the data reject
            // for another is no explanation to build on), each with every candidate it admits.
            let c = mismatch(&nodes);
            let mut all: Vec<&Structure> = nodes
                .keys()
                .filter(|s| admissible(&nodes, s, z_crit, c))
                .collect();
            all.sort_by(|a, b| nodes[*a].held.chi2.total_cmp(&nodes[*b].held.chi2));
            let best = all.first().map(|b| &nodes[*b].held);
            let mut good: Vec<&Structure> = level
                .iter()
                .filter(|s| nodes.contains_key(*s) && admissible(&nodes, s, z_crit, c))
                .filter(|s| best.is_none_or(|b| !compare(b, &nodes[*s].held, c).better(z_crit)))
                .collect();
            good.sort_by(|a, b| nodes[*a].held.chi2.total_cmp(&nodes[*b].held.chi2));
            let mut next: Vec<Structure> = Vec::new();
            for s in good.into_iter().take(BEAM) {
                for c in &singles {
                    let child = s.with(*c);
                    if s.admits(c) && valid(&child) && !next.contains(&child) {
                        next.push(child);
                    }
                }
            }
            // Each child's other parents, so that every effect of it can be judged.
            let mut parents: Vec<Structure> = next
                .iter()
                .flat_map(|s| s.effects().iter().map(|c| s.without(c)).collect::<Vec<_>>())
                .filter(|p| !nodes.contains_key(p))
                .collect();
            parents.sort();
            parents.dedup();
            score_all(&mut nodes, &parents, obs, &r, threads, progress);
            level = next;
        }
        if depth >= 2 && level.is_empty() {
            break;
        }
    }
    let c = mismatch(&nodes);
    let mut admissible: Vec<Structure> = nodes
        .keys()
        .filter(|s| admissible(&nodes, s, z_crit, c))
        .cloned()
        .collect();
    admissible.sort_by(|a, b| nodes[a].held.chi2.total_cmp(&nodes[b].held.chi2));
    let (set, parted) = ambiguity_set(&nodes, &admissible, z_crit, c);
    Some(Search {
        best: set.first().cloned().unwrap_or_default(),
        nodes,
        z_crit,
        compared,
        mismatch: c,
        admissible,
        set,
        parted,
        cut_short,
    })
}

/// The lattice's exhaustive levels from `model`: every single candidate and every valid pair.
fn lattice(model: &ModelSpec, r: &DataRange) -> (Vec<Candidate>, Vec<Structure>) {
    let root = Structure::root();
    let singles: Vec<Candidate> = candidates(model, r);
    let pairs: Vec<Structure> = (0..singles.len())
        .flat_map(|i| (i + 1..singles.len()).map(move |j| (i, j)))
        .map(|(i, j)| root.with(singles[i]).with(singles[j]))
        .filter(valid)
        .collect();
    (singles, pairs)
}

/// How many structures a search plans to compare: the exhaustive levels and the beam's two
/// further levels of at most [`BEAM`] parents with every candidate each (the count its
/// threshold is shared over).
fn planned(singles: &[Candidate], pairs: &[Structure]) -> usize {
    singles.len() + pairs.len() + 2 * BEAM * singles.len()
}

/// The threshold a search from `model` on records spanning `r` compares at
/// (`criterion::threshold` over the structures it plans to compare).
pub fn z_threshold(model: &ModelSpec, r: &DataRange) -> f64 {
    let (singles, pairs) = lattice(model, r);
    threshold(planned(&singles, &pairs))
}

/// Whether a structure can be built at all: one law per kind, one mode per plane.
fn valid(s: &Structure) -> bool {
    s.effects().iter().all(|c| s.without(c).admits(c))
}

/// The mismatch factor of the structures scored: the best-predicting one's held-out
/// chi-square per component, at least 1 (`criterion`).
pub(super) fn mismatch(nodes: &BTreeMap<Structure, Node>) -> f64 {
    nodes
        .values()
        .map(|n| n.held.mismatch())
        .fold(f64::INFINITY, f64::min)
        .max(1.0)
}

/// Whether every effect of `s` is significant: `s` significantly better than itself without
/// it (a structure whose parent was not scored is not admissible), and the effect determined
/// by the records ([`determined`] on a fold's fit: what part of the records determines, all
/// of them determine at least as well, the information of independent records adding up; an
/// effect only part of the band shows, a force limit reached at the top frequency alone, is
/// determined by one fold only). Intersection-union: both tests at the same level. The root
/// is admissible.
pub fn admissible(nodes: &BTreeMap<Structure, Node>, s: &Structure, z_crit: f64, c: f64) -> bool {
    let Some(n) = nodes.get(s) else { return false };
    s.effects().iter().all(|e| {
        nodes
            .get(&s.without(e))
            .is_some_and(|p| compare(&n.held, &p.held, c).better(z_crit))
            && n.folds.iter().any(|f| determined(f, e, z_crit))
    })
}

/// Whether the records `fit` was fitted on determine effect `c`: one of the parameters that
/// carry it ([`Profile::strength`](crate::profiles::Profile::strength)) lies more than
/// `z_crit` of its standard errors from zero (a Wald test). A held-out gain whose effect the
/// fitted records leave undetermined (a cutoff of 1040 +- 2e5 rad/s) is a basin of the other
/// parameters, not evidence of the effect.
pub fn determined(fit: &Fit, c: &Candidate, z_crit: f64) -> bool {
    profile(c.kind)
        .strength(fit, c)
        .iter()
        .any(|(v, se)| v.abs() > z_crit * se)
}

/// The best admissible structure and those the data cannot separate from it (see the module
/// documentation), leaving out every structure that is not significantly better than a
/// smaller admissible one inside it; and the structures left out because the records part
/// them from a member yet fit neither (`Comparison::neither`), each with that member.
fn ambiguity_set(
    nodes: &BTreeMap<Structure, Node>,
    admissible: &[Structure],
    z_crit: f64,
    c: f64,
) -> (Vec<Structure>, Vec<(Structure, Structure)>) {
    // Parsimony: a structure that does not predict significantly better than a smaller
    // admissible structure inside it (`Structure::holds`: fewer effects, or a law that holds
    // another as a special case) is no alternative to it (the test is not transitive: two
    // effects can each pass against the structure without them and together not against the
    // identified model's own).
    let pool: Vec<&Structure> = admissible
        .iter()
        .filter(|s| {
            !admissible
                .iter()
                .any(|t| s.holds(t) && !compare(&nodes[*s].held, &nodes[t].held, c).better(z_crit))
        })
        .collect();
    let mut set: Vec<Structure> = Vec::new();
    let mut parted = Vec::new();
    for s in pool {
        if set.len() >= MAX_SET {
            break;
        }
        let against = |m: &Structure| compare(&nodes[m].held, &nodes[s].held, c);
        let worse = set.iter().any(|m| against(m).better(z_crit));
        let same_kinds = set.iter().any(|m| m.kinds() == s.kinds());
        if worse || same_kinds {
            continue;
        }
        match set.iter().find(|m| against(m).neither(z_crit)) {
            Some(m) => parted.push((m.clone(), s.clone())),
            None => set.push(s.clone()),
        }
    }
    (set, parted)
}

/// Scores every structure of `todo` not scored yet (both folds in parallel), each from its
/// scored parents; structures that cannot be fitted are left out.
fn score_all(
    nodes: &mut BTreeMap<Structure, Node>,
    todo: &[Structure],
    obs: &[&Observation],
    r: &DataRange,
    threads: usize,
    progress: &(dyn Fn(&str) + Sync),
) {
    let todo: Vec<&Structure> = todo.iter().filter(|s| !nodes.contains_key(*s)).collect();
    // The costly structures first, so that the threads finish together.
    let mut work: Vec<(usize, usize)> = (0..todo.len()).flat_map(|k| [(k, 0), (k, 1)]).collect();
    let costly = |s: &Structure| s.effects().iter().any(|c| profile(c.kind).costly(c));
    work.sort_by_key(|&(k, _)| !costly(todo[k]));
    let root = &nodes[&Structure::root()];
    let fits = zmp_campaign::par::parallel_map(work.len(), threads, |i| {
        let (k, f) = work[i];
        let s = todo[k];
        let parents: Vec<(&Structure, &Fit)> = s
            .effects()
            .iter()
            .filter_map(|c| nodes.get_key_value(&s.without(c)))
            .map(|(p, n)| (p, &n.folds[f]))
            .collect();
        let starts = starts_of(s, &parents, &root.folds[f], r);
        fit_starts(&starts, &records(obs, Some(f)), r)
    });
    let mut by: BTreeMap<usize, [Option<Fit>; 2]> = BTreeMap::new();
    for ((k, f), fit) in work.into_iter().zip(fits) {
        by.entry(k).or_default()[f] = fit;
    }
    for (k, [a, b]) in by {
        let (Some(a), Some(b)) = (a, b) else { continue };
        let Some(held) = HeldOut::of([&a.spec, &b.spec], obs) else {
            continue;
        };
        progress(&format!("scored {}", todo[k]));
        let s = todo[k].clone();
        nodes.insert(
            s.clone(),
            Node {
                structure: s,
                folds: [a, b],
                held,
            },
        );
    }
}

/// The fit of `s` on every record, from its chain's fits on every record (computed along
/// the way into `all`) by the same policy; past the time limit, a structure's first-fold fit.
pub fn fit_all(
    search: &Search,
    s: &Structure,
    model: &ModelSpec,
    obs: &[&Observation],
    all: &mut BTreeMap<Structure, Fit>,
) -> Option<Fit> {
    let r = DataRange::of(obs);
    for step in search.chain(s) {
        if all.contains_key(&step) {
            continue;
        }
        let fitted = if step.is_empty() {
            fit_root(model, obs, &r)
        } else {
            let root = all.get(&Structure::root())?;
            let parents: Vec<(&Structure, &Fit)> = step
                .effects()
                .iter()
                .filter_map(|c| all.get_key_value(&step.without(c)))
                .collect();
            // Where no start from the chain can be fitted on every record, the structure's
            // own fits on each fold's records are its starts.
            fit_starts(&starts_of(&step, &parents, root, &r), obs, &r).or_else(|| {
                let folds = &search.nodes.get(&step)?.folds;
                let own: Vec<Start> = folds
                    .iter()
                    .map(|f| (f.spec.clone(), effect_frees(&f.spec, &r)))
                    .collect();
                fit_starts(&own, obs, &r)
            })
        };
        // Past the time limit no fit runs: the structure keeps what the search reached, its
        // fit on the first fold's records.
        let fit = match fitted {
            Some(f) => f,
            None if zmp_campaign::par::past_deadline() => search.nodes.get(&step)?.folds[0].clone(),
            None => return None,
        };
        all.insert(step, fit);
    }
    all.get(s).cloned()
}

#[cfg(test)]
mod tests;
