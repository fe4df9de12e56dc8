//! The noise a record's components see, and the variances the diagnosis's chi-square uses.
//!
//! 1. **First and third harmonic: period-to-period variation** ([`periods`]). Over the `P`
//!    whole periods of a steady state the response repeats, the noise does not: the sample
//!    variance of each period's phasor is the noise's power at the phasor's own frequency
//!    (coloured noise included: no colour model), however distorted the response. The residual
//!    beyond the fitted harmonics, which the variances were scaled from before, keeps every
//!    harmonic above the third and on a play's records came out several times the noise.
//! 2. **Pooled by frequency** ([`pool`]): with `P = 2-4` periods at low frequency one record's
//!    variance has only `2(P - 1)` degrees of freedom (a chi-square of four degrees of freedom
//!    is below a third of its mean one time in ten). One sensor has one noise, so the
//!    records' estimates are pooled over the campaign by frequency, weighted by their degrees
//!    of freedom (the samples within a factor [`POOL_SPAN`] in frequency, at least
//!    [`POOL_MIN_DOF`] degrees of freedom, fitted linearly in log frequency and read at the
//!    record's); each pooled value states its effective degrees of freedom, so that a test
//!    can use the right reference distribution (a scaled chi-square, or an F).
//! 3. **Trend: bins near zero frequency** ([`spectrum`]). A fitted trend sees the noise below
//!    one Fourier bin of its window, where the periods hold no information (their variation
//!    is the noise around the excitation); its variance is the power per sample at the trend
//!    window's quadrature nodes (`record_analysis::TREND_NODES`), pooled by frequency from every record's residual
//!    bins near zero frequency, each clear of every harmonic (so noise alone, however
//!    distorted the response), in absolute units: the campaign's longer records supply the
//!    lowest frequencies.

pub(crate) mod campaign;
pub(crate) mod periods;
pub(crate) mod spectrum;

/// Frequency span (a factor either way) within which records' noise estimates are pooled.
pub(crate) const POOL_SPAN: f64 = 1.5;

/// Degrees of freedom behind a pooled noise power, at least: 192 give its variance to about
/// 10 % and a standard error to about 5 % (as 96 periodogram bins, two degrees of freedom
/// each).
pub(crate) const POOL_MIN_DOF: f64 = 192.0;

/// One estimate of the noise's power per sample at a frequency.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Sample {
    /// rad/s.
    pub omega: f64,
    /// m^2 (white noise of variance `s^2`: `s^2` at every frequency).
    pub power: f64,
    /// Degrees of freedom of `power` (a scaled chi-square).
    pub dof: f64,
}

/// A pooled noise power per sample (m^2) and its effective degrees of freedom (`NaN` power
/// when there was nothing to pool).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pooled {
    pub power: f64,
    pub dof: f64,
}

/// Pools `samples` by frequency at `nodes` (rad/s), `per_query` consecutive nodes per query
/// whose pooled powers are averaged (one node for a harmonic, the quadrature nodes for a
/// trend). At each node the samples within a factor [`POOL_SPAN`] (widened to the nearest
/// until they hold [`POOL_MIN_DOF`] degrees of freedom), their power fitted linearly in the
/// log of the frequency, weighted by their degrees of freedom, and read at the node (where the
/// samples lie on one side of it and the spectrum slopes there the line follows the slope up
/// to the nearest sample, and is held there beyond: a trend's lowest nodes lie below every
/// record's bins, and a line drawn a factor five or ten below its samples came out at the
/// clamp; kept within half and twice their weighted mean). Each result is a
/// linear combination `sum c_i P_i` of the samples' powers, whose effective degrees of freedom
/// are `1 / sum (c_i^2 / dof_i)` (exact for a mean of equal powers; `sum dof_i` for the
/// weighted mean). Samples that are not finite and positive are ignored.
pub(crate) fn pool(samples: &[Sample], nodes: &[f64], per_query: usize) -> Vec<Pooled> {
    let mut good: Vec<(f64, Sample)> = samples
        .iter()
        .filter(|s| s.power.is_finite() && s.power > 0.0 && s.omega > 0.0 && s.dof > 0.0)
        .map(|s| (s.omega.ln(), *s))
        .collect();
    good.sort_by(|a, b| a.0.total_cmp(&b.0));
    let per_query = per_query.max(1);
    let mut coef = vec![0.0; good.len()];
    let mut touched: Vec<usize> = Vec::new();
    nodes
        .chunks(per_query)
        .map(|query| {
            if good.is_empty() || query.iter().any(|w| w.is_nan() || *w <= 0.0) {
                return Pooled {
                    power: f64::NAN,
                    dof: 0.0,
                };
            }
            for &w in query {
                let (lo, hi) = window(&good, w.ln());
                node_coefficients(&good[lo..hi], w.ln(), |i, c| {
                    if coef[lo + i] == 0.0 {
                        touched.push(lo + i);
                    }
                    coef[lo + i] += c / query.len() as f64;
                });
            }
            let (mut power, mut inv_dof) = (0.0, 0.0);
            for &i in &touched {
                power += coef[i] * good[i].1.power;
                inv_dof += coef[i] * coef[i] / good[i].1.dof;
                coef[i] = 0.0;
            }
            touched.clear();
            Pooled {
                power,
                dof: if inv_dof > 0.0 { 1.0 / inv_dof } else { 0.0 },
            }
        })
        .collect()
}

/// The run `[lo, hi)` of `good` (sorted by log frequency) pooled at log frequency `lw`: the
/// samples within [`POOL_SPAN`], widened to the nearest until they hold [`POOL_MIN_DOF`];
/// samples as far as the last one taken are taken too (the result does not depend on their
/// order).
fn window(good: &[(f64, Sample)], lw: f64) -> (usize, usize) {
    let span = POOL_SPAN.ln();
    let dist = |k: usize| (good[k].0 - lw).abs();
    let mut lo = good.partition_point(|g| g.0 < lw - span);
    let mut hi = good.partition_point(|g| g.0 <= lw + span);
    let mut held: f64 = good[lo..hi].iter().map(|g| g.1.dof).sum();
    while held < POOL_MIN_DOF && (lo > 0 || hi < good.len()) {
        let d = match (lo > 0, hi < good.len()) {
            (true, true) => dist(lo - 1).min(dist(hi)),
            (true, false) => dist(lo - 1),
            _ => dist(hi),
        };
        while lo > 0 && dist(lo - 1) <= d {
            lo -= 1;
            held += good[lo].1.dof;
        }
        while hi < good.len() && dist(hi) <= d {
            held += good[hi].1.dof;
            hi += 1;
        }
    }
    (lo, hi)
}

/// The coefficients `c_i` (passed to `out(i, c_i)`) of the weighted least-squares line of the
/// samples `run` read at log frequency `lw` (at the nearest end of the run's frequencies when
/// `lw` lies beyond them: no extrapolation), or of their weighted mean (or of half or twice
/// it, where the line would leave that range).
fn node_coefficients(run: &[(f64, Sample)], lw: f64, mut out: impl FnMut(usize, f64)) {
    let (Some(first), Some(last)) = (run.first(), run.last()) else {
        return;
    };
    let lw = lw.clamp(first.0, last.0);
    let (mut sw, mut sx, mut sxx, mut sy, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (lg, s) in run {
        let (w, x) = (s.dof, lg - lw);
        sw += w;
        sx += w * x;
        sxx += w * x * x;
        sy += w * s.power;
        sxy += w * x * s.power;
    }
    if sw <= 0.0 {
        return;
    }
    let (xm, mean) = (sx / sw, sy / sw);
    let var_x = sxx / sw - xm * xm;
    let weighted_mean = |scale: f64, out: &mut dyn FnMut(usize, f64)| {
        for (i, (_, s)) in run.iter().enumerate() {
            out(i, scale * s.dof / sw);
        }
    };
    if var_x < 1e-4 {
        return weighted_mean(1.0, &mut out);
    }
    let slope = (sxy / sw - xm * mean) / var_x;
    let intercept = mean - slope * xm;
    if intercept < 0.5 * mean {
        return weighted_mean(0.5, &mut out);
    }
    if intercept > 2.0 * mean {
        return weighted_mean(2.0, &mut out);
    }
    // intercept = sum_i w_i y_i / sw - xm sum_i w_i (x_i - xm) y_i / (sw var_x).
    for (i, (lg, s)) in run.iter().enumerate() {
        let x = lg - lw;
        out(i, s.dof / sw * (1.0 - xm * (x - xm) / var_x));
    }
}

/// Significance level at which a campaign's records are found not to share one noise: 1 %
/// over the whole campaign (Bonferroni: each of `m` records is tested at `SIGNIFICANCE / m`,
/// so that a campaign of one noise loses a record to the test one time in a hundred).
pub(crate) const SIGNIFICANCE: f64 = 0.01;

/// Rounds of [`consistent`] at most (each takes out what the last pool showed; two or three
/// settle it).
const ROUNDS: usize = 8;

/// Paulson's normal approximation of the F distribution (through Wilson and Hilferty's cube
/// root of a chi-square): the standard normal deviate of the ratio `f` of two variance
/// estimates of `d1` and `d2` degrees of freedom (within a few hundredths of the exact
/// quantile from three degrees of freedom; conservative below).
pub(crate) fn f_deviate(f: f64, d1: f64, d2: f64) -> f64 {
    let (a1, a2) = (2.0 / (9.0 * d1), 2.0 / (9.0 * d2));
    let c = f.cbrt();
    ((1.0 - a2) * c - (1.0 - a1)) / (a2 * c * c + a1).sqrt()
}

/// The standard normal quantile (Acklam's rational approximation, relative error below
/// 1.2e-9 over `(0, 1)`).
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p <= 0.0 {
        f64::NEG_INFINITY
    } else if p >= 1.0 {
        f64::INFINITY
    } else if p < 0.024_25 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.024_25 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// Which groups of samples (one record's own estimates, `samples[groups[g]]`) share the
/// campaign's noise. One sensor has one noise: a record whose own power is above the power
/// pooled at its frequencies beyond the F distribution's upper point at [`SIGNIFICANCE`]
/// over the campaign (of their degrees of freedom) varies from period to period by more than
/// the sensor's noise: a response that does not quite repeat (a transient left in the steady
/// window, a clamped response's harmonics beyond Nyquist folded between the excitation's, an
/// irregular stick-slip, a play's impacts). Such a record is left out of the pool (it would
/// raise every other record's noise) and keeps its own, the larger. The search starts from
/// the records at or below the median of their neighbours in frequency (within
/// [`POOL_SPAN`]), and each round tests every record against the pool of the last: starting
/// from every record, a campaign where half the records at a frequency do not repeat (a
/// play's excited records at 3-15 rad/s, ten to a thousand times the sensor's noise) raised
/// its pool beyond what the test could see, and the records that did not repeat less stayed
/// in it. Repeated until no record changes side (at most [`ROUNDS`]); groups without a finite
/// estimate count as consistent.
pub(crate) fn consistent(samples: &[Sample], groups: &[std::ops::Range<usize>]) -> Vec<bool> {
    let own: Vec<(f64, f64)> = groups
        .iter()
        .map(|g| {
            let s = &samples[g.clone()];
            let lw = s.iter().map(|s| s.omega.ln()).sum::<f64>() / s.len().max(1) as f64;
            (lw, weighted_power(s).0)
        })
        .collect();
    let mut keep: Vec<bool> = own
        .iter()
        .map(|&(lw, p)| {
            if !p.is_finite() {
                return true;
            }
            let mut near: Vec<f64> = own
                .iter()
                .filter(|(l, q)| q.is_finite() && (l - lw).abs() <= POOL_SPAN.ln())
                .map(|(_, q)| *q)
                .collect();
            near.sort_by(f64::total_cmp);
            p <= near[(near.len() - 1) / 2]
        })
        .collect();
    let tested = groups
        .iter()
        .filter(|g| weighted_power(&samples[(*g).clone()]).1 > 0.0)
        .count()
        .max(1);
    let z_limit = normal_quantile(1.0 - SIGNIFICANCE / tested as f64);
    let nodes: Vec<f64> = samples.iter().map(|s| s.omega).collect();
    for _ in 0..ROUNDS {
        let kept: Vec<Sample> = groups
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .flat_map(|(g, _)| samples[g.clone()].iter().copied())
            .collect();
        let pooled = pool(&kept, &nodes, 1);
        let next: Vec<bool> = groups
            .iter()
            .map(|g| {
                let (own, own_dof) = weighted_power(&samples[g.clone()]);
                let (reference, _) = weighted_power(
                    &samples[g.clone()]
                        .iter()
                        .zip(&pooled[g.clone()])
                        .map(|(s, p)| Sample {
                            omega: s.omega,
                            power: p.power,
                            dof: s.dof,
                        })
                        .collect::<Vec<_>>(),
                );
                let ref_dof = pooled[g.clone()]
                    .iter()
                    .map(|p| p.dof)
                    .fold(f64::INFINITY, f64::min);
                !(own > 0.0 && reference > 0.0 && ref_dof > 0.0 && own_dof > 0.0)
                    || f_deviate(own / reference, own_dof, ref_dof) <= z_limit
            })
            .collect();
        if next == keep {
            break;
        }
        keep = next;
    }
    keep
}

/// The degrees-of-freedom-weighted mean power of `samples` (finite ones) and their summed
/// degrees of freedom; `(NaN, 0)` without any.
pub(crate) fn weighted_power(samples: &[Sample]) -> (f64, f64) {
    let (mut sp, mut sd) = (0.0, 0.0);
    for s in samples
        .iter()
        .filter(|s| s.power.is_finite() && s.dof > 0.0)
    {
        sp += s.power * s.dof;
        sd += s.dof;
    }
    if sd > 0.0 {
        (sp / sd, sd)
    } else {
        (f64::NAN, 0.0)
    }
}

#[cfg(test)]
mod tests;
