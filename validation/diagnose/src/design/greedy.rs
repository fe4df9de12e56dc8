//! The greedy construction of a design (see the module documentation of `design`): each
//! step adds the candidate that maximises the smallest capped separation over the ordered
//! pairs, then refits every pair that records can separate.

use super::separation::{self, gains, record_set, refit, Pair, NESTED_CHI2};
use super::{contains, DesignError, DesignOptions, Rival};
use crate::observe::Observation;

/// What the greedy construction ends with.
pub(super) struct Greedy {
    /// Every ordered pair, refitted on the campaign and the chosen records.
    pub pairs: Vec<Pair>,
    /// The chosen candidates, in order.
    pub chosen: Vec<usize>,
    /// The smallest separation (noise standard deviations) before and after each record.
    pub path: Vec<f64>,
}

/// The error of rival `j`'s refit to rival `i`'s predictions.
fn fit_error(rivals: &[Rival], i: usize, j: usize) -> DesignError {
    DesignError::Fit {
        model: rivals[j].label.clone(),
        truth: rivals[i].label.clone(),
    }
}

/// The smallest separation, as a chi-square, over the pairs records can separate (not
/// nested); 0 when every direction is nested (the rivals are one another on every record).
fn smallest(pairs: &[Pair]) -> f64 {
    pairs
        .iter()
        .filter(|p| !p.nested)
        .map(|p| p.total)
        .reduce(f64::min)
        .unwrap_or(0.0)
}

/// Every ordered pair of rivals, the rival refitted to the truth's predictions on the
/// campaign alone, marked nested where its structure contains the truth's and it reproduces
/// the truth there.
fn start_pairs(
    rivals: &[Rival],
    campaign: &[Vec<Observation>],
    threads: usize,
) -> Result<Vec<Pair>, DesignError> {
    let n = rivals.len();
    let ordered: Vec<(usize, usize)> = (0..n)
        .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
        .collect();
    let mut pairs = zmp_campaign::par::parallel_map(ordered.len(), threads, |k| {
        let (i, j) = ordered[k];
        separation::start(i, j, &rivals[j].spec, &rivals[i].spec, &campaign[i])
    })
    .into_iter()
    .zip(&ordered)
    .map(|(p, &(i, j))| p.ok_or_else(|| fit_error(rivals, i, j)))
    .collect::<Result<Vec<Pair>, _>>()?;
    // A rival whose structure contains the truth's and whose refit reproduces the truth's
    // campaign within one noise standard deviation nests it: its extra effects vanish at the
    // truth (the refit's remainder is numerics, or the describing functions' simulation).
    for p in pairs.iter_mut() {
        p.nested = contains(&rivals[p.rival].spec, &rivals[p.truth].spec) && p.total < 1.0;
    }
    Ok(pairs)
}

/// Per pair, every candidate's directional gain against the current refit (zeros for a
/// nested pair); a candidate's third harmonic is compared when three times its frequency lies
/// within `top`, the highest frequency of the campaign and the records so far.
fn candidate_gains(
    rivals: &[Rival],
    pairs: &[Pair],
    truths: &[Vec<Observation>],
    top: f64,
) -> Result<Vec<Vec<f64>>, DesignError> {
    pairs
        .iter()
        .map(|p| {
            if p.nested {
                return Ok(vec![0.0; truths[p.truth].len()]);
            }
            let mine: Vec<Observation> = truths[p.truth]
                .iter()
                .map(|o| Observation {
                    third_band: 3.0 * o.omega <= top.max(o.omega) * (1.0 + 1e-9),
                    ..o.clone()
                })
                .collect();
            gains(p, &mine).ok_or_else(|| fit_error(rivals, p.truth, p.rival))
        })
        .collect()
}

/// Every pair that records can separate refitted on the campaign and the `chosen` records,
/// from where its refit stands, or also from the rival's own fitted values when `from_rivals`
/// (`separation::refit`); nested pairs stay as they are.
fn refit_pairs(
    rivals: &[Rival],
    pairs: &[Pair],
    chosen: &[usize],
    campaign: &[Vec<Observation>],
    truths: &[Vec<Observation>],
    from_rivals: bool,
    threads: usize,
) -> Result<Vec<Pair>, DesignError> {
    zmp_campaign::par::parallel_map(pairs.len(), threads, |k| {
        let p = &pairs[k];
        if p.nested {
            return Some(p.clone());
        }
        let added: Vec<Observation> = chosen.iter().map(|&c| truths[p.truth][c].clone()).collect();
        let set = record_set(&campaign[p.truth], &added);
        let own = from_rivals.then(|| &rivals[p.rival].spec);
        refit(p, &set, campaign[p.truth].len(), own)
    })
    .into_iter()
    .zip(pairs)
    .map(|(r, p)| r.ok_or_else(|| fit_error(rivals, p.truth, p.rival)))
    .collect()
}

/// The greedy construction (see the module documentation).
pub(super) fn greedy(
    rivals: &[Rival],
    campaign: &[Vec<Observation>],
    truths: &[Vec<Observation>],
    opts: &DesignOptions,
    target: f64,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Greedy, DesignError> {
    let threads = zmp_campaign::par::budget();
    progress("refitting each rival to the others' predictions");
    let mut pairs = start_pairs(rivals, campaign, threads)?;
    let cap = target * target;
    let campaign_top = campaign[0].iter().map(|o| o.omega).fold(0.0, f64::max);
    let mut chosen: Vec<usize> = Vec::new();
    let mut path = Vec::new();
    loop {
        let top = chosen
            .iter()
            .map(|&k| truths[0][k].omega)
            .fold(campaign_top, f64::max);
        let gain = candidate_gains(rivals, &pairs, truths, top)?;
        // A rival that reproduces its truth on the campaign, the records so far and every
        // candidate nests it (found once its refit has travelled there).
        for (p, g) in pairs.iter_mut().zip(&gain) {
            p.nested |= p.total < NESTED_CHI2 && g.iter().all(|v| *v < NESTED_CHI2);
        }
        if chosen.is_empty() {
            path.push(smallest(&pairs).max(0.0).sqrt());
        } else {
            let last = path.len() - 1;
            path[last] = smallest(&pairs).max(0.0).sqrt();
            progress(&format!(
                "record {}/{}: smallest separation {:.2} noise standard deviations",
                chosen.len(),
                opts.max_records,
                path[last]
            ));
        }
        if chosen.len() >= opts.max_records || smallest(&pairs) >= cap {
            break;
        }
        let active: Vec<Pair> = pairs.iter().filter(|p| !p.nested).cloned().collect();
        let active_gain: Vec<Vec<f64>> = pairs
            .iter()
            .zip(gain)
            .filter(|(p, _)| !p.nested)
            .map(|(_, g)| g)
            .collect();
        let Some(best) = pick(&active, &active_gain, cap) else {
            progress("no candidate separates the rivals further");
            break;
        };
        // The criterion judges each record by the fit of the fold that did not see it, the
        // records of one frequency alternating between the folds (`criterion::folds`): a
        // frequency recorded once is judged by extrapolation alone. A record at a frequency
        // the campaign and the design lack is therefore recorded twice, once in each fold
        // (budget allowing).
        let omega = truths[0][best].omega;
        let new = |w: f64| (w - omega).abs() > 1e-9 * omega;
        let fresh = campaign[0].iter().all(|o| new(o.omega))
            && chosen.iter().all(|&k| new(truths[0][k].omega));
        let copies = if fresh && chosen.len() + 2 <= opts.max_records {
            2
        } else {
            1
        };
        for _ in 0..copies {
            chosen.push(best);
        }
        pairs = refit_pairs(rivals, &pairs, &chosen, campaign, truths, false, threads)?;
        let now = smallest(&pairs).max(0.0).sqrt();
        path.extend(std::iter::repeat_n(now, copies));
    }
    // The finished design's separations, the rival also refitted from its own fitted values
    // (a refit stuck where the greedy path took it would overstate the separation).
    if !chosen.is_empty() {
        pairs = refit_pairs(rivals, &pairs, &chosen, campaign, truths, true, threads)?;
    }
    Ok(Greedy {
        pairs,
        chosen,
        path,
    })
}

/// The candidate that maximises the smallest capped separation after it (ties: the larger
/// capped sum); `None` when no candidate adds anything.
fn pick(pairs: &[Pair], gain: &[Vec<f64>], cap: f64) -> Option<usize> {
    let n = gain.first()?.len();
    let score = |k: usize| {
        let after: Vec<f64> = pairs
            .iter()
            .zip(gain)
            .map(|(p, g)| (p.total + g[k].max(0.0)).min(cap))
            .collect();
        (
            after.iter().copied().fold(f64::INFINITY, f64::min),
            after.iter().sum::<f64>(),
        )
    };
    let now: f64 = pairs.iter().map(|p| p.total.min(cap)).sum();
    let best = (0..n).max_by(|&a, &b| {
        let (sa, sb) = (score(a), score(b));
        sa.0.total_cmp(&sb.0).then(sa.1.total_cmp(&sb.1))
    })?;
    (score(best).1 > now * (1.0 + 1e-9) + 1e-12).then_some(best)
}
