//! After the forward search: one swap pass (an early choice that stood in for an effect
//! shown only once the others were in is replaced) and backward elimination (an effect the
//! later ones made redundant is dropped). See [`super`] for the test both use.

use super::{complexity, gain, plausible, Step, CHI2_MIN};
use crate::candidates::CATALOGUE;
use crate::engine::{score_candidate, score_candidates, Scored};
use crate::observe::Observation;

/// The swap pass of the search: with two or more effects added one at a time, an early choice
/// may have stood in for an effect that shows only once the others are in (a flexible mode
/// mimicking a sensor low-pass next to a play). Each added effect but the last (chosen given
/// all the others) is taken out, the others are refitted from the root in their order, and
/// every other candidate is tried in its place; one that scores better held-out by at least
/// [`CHI2_MIN`] (a more complex one by more than the tie slack of [`super::choose`]), or a simpler
/// one within that slack, takes its place. At most one swap. Returns the new steps and
/// effects. (Held-out draw 1030039, a 76 ms delay beside play and drift: a mode took the
/// delay's place at a held-out chi-square 3 % lower, 2489 against 2574, and the delay was
/// lost.)
pub(super) fn swap(
    root: &Scored,
    added: &[String],
    steps: &[Step],
    obs: &[&Observation],
    threads: usize,
    progress: &(dyn Fn(&str) + Sync),
) -> Option<(Vec<Step>, Vec<String>)> {
    let current = &steps.last()?.scored;
    for removed in &added[..added.len() - 1] {
        let others: Vec<&String> = added.iter().filter(|e| *e != removed).collect();
        let mut chain = refit_chain(root, &others, obs)?;
        let base = chain.last().unwrap_or(root);
        let children = plausible(
            score_candidates(&base.fitted.spec, obs, added, threads, progress),
            base,
            obs,
        );
        if let Some(b) = children.iter().min_by(|a, b| a.chi2.total_cmp(&b.chi2)) {
            progress(&format!(
                "in place of {removed}: {} (held-out chi-square {:.0} against {:.0})",
                b.effect, b.chi2, current.chi2
            ));
        }
        let Some(best) = children
            .iter()
            .filter(|c| replaces(c, removed, current.chi2))
            .min_by(|a, b| a.chi2.total_cmp(&b.chi2))
        else {
            continue;
        };
        progress(&format!("{} replaces {removed}", best.effect));
        chain.push(best.clone());
        return Some(steps_of(root, &chain));
    }
    None
}

/// Whether `c`, fitted in place of the effect `removed`, is better than the structure that had
/// it (held-out chi-square `current`): the tie rule of [`super::choose`] both ways, a simpler
/// effect wins within the slack (at least [`CHI2_MIN`], a twentieth of `current`), a more
/// complex one must win by more than it, one alike by [`CHI2_MIN`].
pub fn replaces(c: &Scored, removed: &str, current: f64) -> bool {
    let slack = CHI2_MIN.max(0.05 * current);
    let margin = if complexity(&c.effect) > complexity(removed) {
        slack
    } else {
        CHI2_MIN
    };
    c.chi2 < current - margin
        || (complexity(&c.effect) < complexity(removed) && c.chi2 <= current + slack)
}

/// The entries of `added` but the `k`-th, in order.
fn without(added: &[String], k: usize) -> Vec<&String> {
    added
        .iter()
        .enumerate()
        .filter(|&(j, _)| j != k)
        .map(|(_, e)| e)
        .collect()
}

/// `effects` added to `root` one after the other, each fitted (everything refitted) on top of
/// the one before; `None` when one cannot be added or fitted.
fn refit_chain(root: &Scored, effects: &[&String], obs: &[&Observation]) -> Option<Vec<Scored>> {
    let mut chain: Vec<Scored> = Vec::new();
    for e in effects {
        let base = chain.last().unwrap_or(root);
        let c = CATALOGUE.iter().find(|c| c.effect == e.as_str())?;
        chain.push(score_candidate(c, &base.fitted.spec, obs)?);
    }
    Some(chain)
}

/// The search's steps and effects along `chain` (one effect per step) from `root`.
fn steps_of(root: &Scored, chain: &[Scored]) -> (Vec<Step>, Vec<String>) {
    let mut steps = Vec::new();
    let mut prev = root;
    for s in chain {
        steps.push(Step {
            added: vec![s.effect.clone()],
            scored: s.clone(),
            gain: gain(prev, s),
        });
        prev = s;
    }
    (steps, chain.iter().map(|s| s.effect.clone()).collect())
}

/// Backward elimination after the forward search and the swap: an effect added early can be
/// made redundant by the ones added after it (a flexible mode standing in for a play that a
/// later step adds itself), and then stays in the model as a false finding. Each effect is
/// taken out in turn and the others refitted from `root` in their order; an effect whose
/// removal the test that adds effects ([`super::Gain::significant`], the removed structure as the
/// parent) does not reject is dropped, the cheapest to drop first (the smallest held-out
/// chi-square rise), and the pass repeats on what is left. A model that explains the data
/// (`stop`) is only reduced to one that does too. Returns the new steps and effects when an
/// effect was dropped.
pub(super) fn prune(
    root: &Scored,
    added: &[String],
    steps: &[Step],
    obs: &[&Observation],
    threads: usize,
    progress: &(dyn Fn(&str) + Sync),
    stop: &dyn Fn(&Scored) -> bool,
) -> Option<(Vec<Step>, Vec<String>)> {
    let mut added: Vec<String> = added.to_vec();
    let mut current: Scored = steps.last()?.scored.clone();
    let mut chain: Option<Vec<Scored>> = None;
    while added.len() >= 2 {
        let explained = stop(&current);
        let reduced = zmp_campaign::par::parallel_map(added.len(), threads, |k| {
            refit_chain(root, &without(&added, k), obs)
        });
        let best = reduced
            .into_iter()
            .enumerate()
            .filter_map(|(k, c)| Some((k, c?)))
            .filter(|(_, c)| {
                let last = c.last().unwrap_or(root);
                !gain(last, &current).significant() && (!explained || stop(last))
            })
            .min_by(|a, b| {
                let chi2 = |c: &[Scored]| c.last().unwrap_or(root).chi2;
                chi2(&a.1).total_cmp(&chi2(&b.1))
            });
        let Some((k, c)) = best else { break };
        progress(&format!(
            "{} dropped: the others explain as much without it (held-out chi-square {:.0} \
             against {:.0})",
            added[k],
            c.last().unwrap_or(root).chi2,
            current.chi2
        ));
        added.remove(k);
        current = c.last().unwrap_or(root).clone();
        chain = Some(c);
    }
    chain.map(|c| steps_of(root, &c))
}
