//! The campaign's noise, per output: every record's own estimates pooled by frequency, the
//! records that do not repeat left out (see the module above).

use super::{consistent, pool, weighted_power, Pooled, Sample};
use crate::record_analysis::TREND_NODES;
use crate::{NoisePower, NoiseSource, SteadyComponents};
use std::ops::Range;

/// For output `i` of every record of `comps`: its noise at its frequency, at three times it
/// and at its trend's nodes. One spectrum for the harmonics: every record's periods at its
/// frequency and at three times it, each its own sample; one for the trends: every record's
/// bins near zero frequency, a record's together. A record inconsistent with the pool
/// ([`consistent`]) keeps its own estimate; with nothing to pool at all, a record keeps its
/// residual variance (the white-noise estimate) with its residual's degrees of freedom.
pub(crate) fn pooled(
    comps: &[&SteadyComponents],
    i: usize,
) -> Vec<(NoisePower, NoisePower, NoisePower)> {
    let harmonics: Vec<Sample> = comps
        .iter()
        .flat_map(|c| {
            let nz = &c.noise[i];
            [
                (c.omega, nz.periods_first),
                (3.0 * c.omega, nz.periods_third),
            ]
            .map(|(omega, est)| Sample {
                omega,
                power: est.power,
                dof: est.dof,
            })
        })
        .collect();
    let mut near_zero: Vec<Sample> = Vec::new();
    let mut bin_groups = Vec::with_capacity(comps.len());
    for c in comps {
        let from = near_zero.len();
        near_zero.extend(c.noise[i].zero_bins.iter().map(|&(omega, power)| Sample {
            omega,
            power,
            dof: 2.0,
        }));
        bin_groups.push(from..near_zero.len());
    }
    let single: Vec<Range<usize>> = (0..harmonics.len()).map(|k| k..k + 1).collect();
    let keep_h = consistent(&harmonics, &single);
    let keep_z = consistent(&near_zero, &bin_groups);
    let pool_h = kept(&harmonics, &single, &keep_h);
    let pool_z = kept(&near_zero, &bin_groups, &keep_z);
    let first: Vec<f64> = comps.iter().map(|c| c.omega).collect();
    let third: Vec<f64> = first.iter().map(|w| 3.0 * w).collect();
    let nodes: Vec<f64> = comps.iter().flat_map(|c| c.trend_omegas).collect();
    let p_first = pool(&pool_h, &first, 1);
    let p_third = pool(&pool_h, &third, 1);
    let p_trend = pool(&pool_z, &nodes, TREND_NODES.len());
    comps
        .iter()
        .enumerate()
        .map(|(r, c)| {
            let white = NoisePower {
                power: c.residual_var[i],
                dof: (c.samples as f64 - 8.0).max(1.0),
                source: NoiseSource::Residual,
            };
            let own = |s: &[Sample]| weighted_power(s);
            (
                pick(
                    keep_h[2 * r],
                    own(&harmonics[2 * r..2 * r + 1]),
                    p_first[r],
                    white,
                ),
                pick(
                    keep_h[2 * r + 1],
                    own(&harmonics[2 * r + 1..2 * r + 2]),
                    p_third[r],
                    white,
                ),
                pick(
                    keep_z[r],
                    own(&near_zero[bin_groups[r].clone()]),
                    p_trend[r],
                    white,
                ),
            )
        })
        .collect()
}

/// The samples of the groups kept.
fn kept(samples: &[Sample], groups: &[Range<usize>], keep: &[bool]) -> Vec<Sample> {
    groups
        .iter()
        .zip(keep)
        .filter(|(_, k)| **k)
        .flat_map(|(g, _)| samples[g.clone()].iter().copied())
        .collect()
}

/// The pooled power of a record that shares the campaign's noise, its own `(power, dof)` if
/// not, `white` when neither is a power.
fn pick(keep: bool, own: (f64, f64), pooled: Pooled, white: NoisePower) -> NoisePower {
    let (power, dof, source) = if keep {
        (pooled.power, pooled.dof, NoiseSource::Pooled)
    } else {
        (own.0, own.1, NoiseSource::Inconsistent)
    };
    if power.is_finite() && power > 0.0 {
        NoisePower { power, dof, source }
    } else {
        white
    }
}
