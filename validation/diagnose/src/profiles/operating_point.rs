//! The pendulum's `a` and `b` changing linearly with the CoM position, under two laws: one
//! relative slope per direction for every channel (`only`), or each channel `G_ij` its own
//! slopes (`per_channel`, which holds the first as the case of equal slopes).
//!
//! **What the records determine per channel.** A record oscillates about an operating point
//! and measures the small-signal gains there: the derivative of the static map
//! `zmp_i(x) = sum_j a_ij (1 + da_ij . x) x_j` (and `b_ij (1 + db_ij . x)` at the
//! acceleration). How the gains change from one operating point to another is the map's second
//! derivative, `H_i,kl = a_ik da_ik,l + a_il da_il,k`, symmetric in `k, l`: of the two slopes
//! `da_ik,l` and `da_il,k` (`k != l`), the records carry only their sum. So where the operating
//! points span the plane, the per-channel law frees each channel's `a` slope along its own
//! input, the diagonal channels' along the other axis too (the sum, held by the larger
//! coefficient), and every `b` slope (`b` enters the gain alone); where they lie on a line,
//! only the slopes along the axis the line runs most along (the gains change along the line
//! alone: per ZMP axis two changes, two slopes). A channel whose coefficient is zero has no
//! slope to show.

use super::{add_effect, DataRange, Profile, Start};
use crate::fit::Free;
use crate::structure::{Candidate, Law};
use crate::words::{op_line, sig, Evidence};
use zmp_models::{Binding, Channel, EffectKind, ModelSpec};

pub struct OperatingPoint;

const K: EffectKind = EffectKind::OperatingPointDependence;

/// The slope parameters: `SLOPE[0]` of `a`, `SLOPE[1]` of `b`, each along x and y.
const SLOPE: [[&str; 2]; 2] = [["da_dx", "da_dy"], ["db_dx", "db_dy"]];

/// The bound of a slope along `k`: a relative change of 2 over the span (100 per metre at
/// most).
fn limit(r: &DataRange, k: usize) -> f64 {
    (2.0 / r.op_span[k]).min(100.0)
}

/// The slopes along the directions the operating points span, each up to a relative change
/// of 2 over the span (100 per metre at most).
fn frees_at(values: [f64; 4], r: &DataRange) -> Vec<Free> {
    let g = vec![Binding::Global];
    let mut out = Vec::new();
    for k in 0..2 {
        if r.op_span[k] > 1e-9 {
            let lim = limit(r, k);
            out.push(Free::new(K, g.clone(), SLOPE[0][k], values[k], -lim, lim));
            out.push(Free::new(
                K,
                g.clone(),
                SLOPE[1][k],
                values[k + 2],
                -lim,
                lim,
            ));
        }
    }
    out
}

/// The pendulum coefficient `a_ij` (`ab` 0) or `b_ij` (1) of channel `c`.
fn coefficient(spec: &ModelSpec, c: Channel, ab: usize) -> f64 {
    let name = format!("{}{}", ["a", "b"][ab], c.suffix());
    spec.value(EffectKind::Pendulum, Binding::Global, &name)
        .unwrap_or(0.0)
}

/// The channels a per-channel law binds: those with a coefficient that is not zero.
fn channels(spec: &ModelSpec) -> Vec<Channel> {
    Channel::ALL
        .into_iter()
        .filter(|c| (0..2).any(|ab| coefficient(spec, *c, ab) != 0.0))
        .collect()
}

/// The CoM axis a line of operating points with direction `u` runs most along.
fn dominant(u: [f64; 2]) -> usize {
    usize::from(u[1].abs() > u[0].abs())
}

/// The per-channel slopes the records determine (module documentation): `(ab, direction)`
/// for channel `c`.
fn channel_slopes(spec: &ModelSpec, c: Channel, r: &DataRange) -> Vec<(usize, usize)> {
    let spanned: Vec<usize> = match r.op_line {
        Some(u) => vec![dominant(u)],
        None => (0..2).filter(|k| r.op_span[*k] > 1e-9).collect(),
    };
    let mut out = Vec::new();
    for ab in 0..2 {
        if coefficient(spec, c, ab) == 0.0 {
            continue;
        }
        for &k in &spanned {
            let own = k == c.input.index() || c.output == c.input;
            if ab == 1 || r.op_line.is_some() || own {
                out.push((ab, k));
            }
        }
    }
    out
}

/// The free slopes of every channel `spec` binds the dependence to.
fn channel_frees(spec: &ModelSpec, r: &DataRange) -> Vec<Free> {
    let mut out = Vec::new();
    for c in Channel::ALL {
        let Some(e) = spec.get(K, Binding::Channel(c)) else {
            continue;
        };
        for (ab, k) in channel_slopes(spec, c, r) {
            let p = SLOPE[ab][k];
            let lim = limit(r, k);
            let v = e.value(p).unwrap_or(0.0);
            out.push(Free::new(K, vec![Binding::Channel(c)], p, v, -lim, lim));
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

    fn laws(&self) -> &'static [Law] {
        &[Law::Only, Law::PerChannel]
    }

    /// Only where the campaign has more than one operating point.
    fn addable(&self, spec: &ModelSpec, _c: &Candidate, r: &DataRange) -> bool {
        !spec.has(K) && r.op_span.iter().any(|s| *s > 1e-9)
    }

    /// No dependence: the slopes are nearly linear in the response, one start reaches them.
    fn starts(&self, spec: &ModelSpec, c: &Candidate, r: &DataRange) -> Vec<Start> {
        let mut s = spec.clone();
        if c.law == Law::PerChannel {
            let bound: Vec<Binding> = channels(spec).into_iter().map(Binding::Channel).collect();
            if bound.is_empty() {
                return Vec::new();
            }
            add_effect(&mut s, K, &bound, &[0.0; 4]);
            let frees = channel_frees(&s, r);
            return vec![(s, frees)];
        }
        add_effect(&mut s, K, &[Binding::Global], &[0.0; 4]);
        vec![(s, frees_at([0.0; 4], r))]
    }

    fn frees(&self, spec: &ModelSpec, r: &DataRange) -> Vec<Free> {
        let Some(e) = spec.get(K, Binding::Global) else {
            return channel_frees(spec, r);
        };
        let v = |p| e.value(p).unwrap_or(0.0);
        frees_at([v("da_dx"), v("da_dy"), v("db_dx"), v("db_dy")], r)
    }

    fn signature(&self, c: &Candidate) -> &'static str {
        if c.law == Law::PerChannel {
            "the same sine answering with a gain that changes with the operating point, \
             channel by channel"
        } else {
            "the same sine answering with a gain that changes with the operating point"
        }
    }

    fn evidence(&self, c: &Candidate, e: &Evidence) -> String {
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
        if c.law == Law::PerChannel {
            s.push_str(&determined_channels(e));
            if let Some(u) = op_line(e.obs) {
                s.push_str(&format!(
                    "; the operating points lie on one line (direction x {:.2}, y {:.2}), so \
                     each slope is the one along {} that moves the gains along the line as \
                     measured: the slopes across it are not determined",
                    u[0],
                    u[1],
                    ["x", "y"][dominant(u)]
                ));
            }
        } else if let Some(u) = op_line(e.obs) {
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

/// Which channels' slopes the records determine (a slope more than the criterion's z standard
/// errors from zero) and which they leave at no determined slope.
fn determined_channels(e: &Evidence) -> String {
    let mut moving: Vec<&str> = Vec::new();
    let mut still: Vec<&str> = Vec::new();
    for c in Channel::ALL {
        let tag = format!(".{}.", c.name());
        let slopes: Vec<&(String, f64, f64)> =
            e.params.iter().filter(|p| p.0.contains(&tag)).collect();
        if slopes.is_empty() {
            continue;
        }
        if slopes.iter().any(|p| p.1.abs() > e.z_crit * p.2) {
            moving.push(c.name());
        } else {
            still.push(c.name());
        }
    }
    let mut s = format!(
        "; the records determine slopes of {} (beyond {:.2} standard errors)",
        if moving.is_empty() {
            "no channel".to_string()
        } else {
            moving.join(", ")
        },
        e.z_crit
    );
    if !still.is_empty() {
        s.push_str(&format!(", none of {}", still.join(", ")));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profiles::{paper_with_limits, test_range};

    fn names(frees: &[Free]) -> Vec<String> {
        frees.iter().map(|f| f.name()).collect()
    }

    /// Where the operating points span the plane, the `a` slopes the records cannot tell apart
    /// (a channel's across its input and its row neighbour's along it) are one free slope, the
    /// diagonal channel's; on a line, every slope along the axis the line runs most along.
    #[test]
    fn per_channel_frees_are_the_slopes_the_records_determine() {
        let spec = paper_with_limits(1.0, 1.2);
        let c = Candidate::new(K, Law::PerChannel);
        let mut plane = test_range();
        plane.op_line = None;
        let (s, frees) = OperatingPoint.starts(&spec, &c, &plane).remove(0);
        let n = names(&frees);
        let p = |x: &str| format!("operating_point_dependence.{x}");
        for has in [
            "G11.da_dx",
            "G11.da_dy",
            "G12.da_dy",
            "G21.da_dx",
            "G22.da_dx",
        ] {
            assert!(n.contains(&p(has)), "{has}: {n:?}");
        }
        for lacks in ["G12.da_dx", "G21.da_dy"] {
            assert!(!n.contains(&p(lacks)), "{lacks}: {n:?}");
        }
        // Four channels: three a slopes per ZMP axis, every b slope.
        assert_eq!(n.len(), 6 + 8, "{n:?}");
        assert_eq!(names(&OperatingPoint.frees(&s, &plane)), n);
        // On the line (3, 2): x alone.
        let line = test_range();
        let (s, frees) = OperatingPoint.starts(&spec, &c, &line).remove(0);
        assert_eq!(frees.len(), 8);
        assert!(
            frees.iter().all(|f| f.param.ends_with("_dx")),
            "{:?}",
            names(&frees)
        );
        assert_eq!(names(&OperatingPoint.frees(&s, &line)), names(&frees));
        // The common law frees its four slopes wherever the points spread.
        let common = OperatingPoint.starts(&spec, &Candidate::new(K, Law::Only), &line);
        assert_eq!(common[0].1.len(), 4);
    }
}
