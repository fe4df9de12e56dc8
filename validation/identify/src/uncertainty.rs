//! Step 7: the uncertainty database (model error per channel and frequency) and its weights.

use super::fit::{self, Point, NP};
use super::{reason, ChannelUncertainty, RecordFit, UncertaintyPoint};
use num_complex::Complex64;
use zmp_models::Channel;

/// Step 7: the uncertainty database and the weights.
pub(super) fn uncertainty_database(
    records: &[RecordFit],
    p: &[f64; NP],
    factors: &[[Complex64; 2]],
) -> Vec<ChannelUncertainty> {
    let mut out = Vec::new();
    for ch in Channel::ALL {
        let (i, j) = (ch.output.index(), ch.input.index());
        // Records measured or saturated (nonlinear effects belong to the uncertainty).
        let recs: Vec<&RecordFit> = records
            .iter()
            .filter(|r| {
                r.excited == ch.input
                    && (r.excluded.is_none() || r.excluded.as_deref() == Some(reason::SATURATED))
            })
            .collect();
        let mut groups: Vec<(f64, f64, f64, usize)> = Vec::new();
        for r in recs {
            let gm = fit::model(
                p,
                &Point {
                    i,
                    j,
                    omega: r.omega_fit,
                    g: r.g[i],
                    sigma: r.sigma[i],
                    factor: factors[r.index][i],
                },
            );
            let e = (r.g[i] - gm).norm();
            let m = e / gm.norm().max(1e-300);
            match groups
                .iter_mut()
                .find(|g| (g.0 / r.omega - 1.0).abs() < 1e-6)
            {
                Some(g) => {
                    g.1 = g.1.max(e);
                    g.2 = g.2.max(m);
                    g.3 += 1;
                }
                None => groups.push((r.omega, e, m, 1)),
            }
        }
        groups.sort_by(|a, b| a.0.total_cmp(&b.0));
        let points: Vec<UncertaintyPoint> = groups
            .iter()
            .map(|g| UncertaintyPoint {
                omega: g.0,
                additive: g.1,
                multiplicative: g.2,
                records: g.3,
            })
            .collect();
        let w: Vec<f64> = points.iter().map(|q| q.omega).collect();
        let l: Vec<f64> = points.iter().map(|q| q.multiplicative).collect();
        let weight = fit::fit_weight(&w, &l).unwrap_or((1e-3, 1.0, 1.0));
        out.push(ChannelUncertainty {
            channel: ch.name().to_string(),
            points,
            weight,
        });
    }
    out
}
