//! What tells two explanations apart: each one's effects the other lacks, in their profiles'
//! words, and where their predictions part, computed on a grid wider than the campaign (its
//! axes and amplitudes, frequencies up to three times its top), in units of one record's noise.

use crate::measure::predict;
use crate::observe::Observation;
use crate::profiles::profile;
use crate::structure::Structure;
use num_complex::Complex64;
use serde::Serialize;
use zmp_models::{Axis, ModelSpec};

/// Where two fitted structures' predictions part most.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Separation {
    /// Over the campaign's own records: the root of the summed squared difference of the
    /// first harmonics in units of each record's noise.
    pub campaign_sigma: f64,
    /// The largest difference of one record on the grid, in its noise.
    pub max_sigma: f64,
    /// Frequency of that record, rad/s.
    pub omega: f64,
    /// Its reference amplitude, m.
    pub amplitude_m: f64,
    /// The axis it excites.
    pub axis: Axis,
    /// The lowest grid frequency from which on one record differs by 3 noise standard
    /// deviations or more (on the axis and amplitude of the largest), if any.
    pub from_omega: Option<f64>,
    /// The separation in one sentence, for the report.
    pub words: String,
}

/// A record's noise standard deviation on the difference counted as separating it (three: a
/// single record's chance of passing it on noise alone is 0.3 %).
const RECORD_SIGMA: f64 = 3.0;

/// What separates `a` (fitted as `a_spec`) from `b` (as `b_spec`) on the campaign `obs`.
pub fn distinguish(
    a: &Structure,
    a_spec: &ModelSpec,
    b: &Structure,
    b_spec: &ModelSpec,
    obs: &[&Observation],
) -> Option<Separation> {
    let campaign_sigma = {
        let (pa, pb) = (predict(a_spec, obs).ok()?, predict(b_spec, obs).ok()?);
        obs.iter()
            .zip(pa.iter().zip(&pb))
            .map(|(o, (x, y))| {
                (0..2)
                    .map(|i| ((x.g[i] - y.g[i]) * o.u1).norm_sqr() / (2.0 * o.y1_var[i]))
                    .sum::<f64>()
            })
            .sum::<f64>()
            .sqrt()
    };
    let grid = grid(obs);
    let refs: Vec<&Observation> = grid.iter().collect();
    let (pa, pb) = (predict(a_spec, &refs).ok()?, predict(b_spec, &refs).ok()?);
    let sigma: Vec<f64> = grid
        .iter()
        .zip(pa.iter().zip(&pb))
        .map(|(o, (x, y))| {
            let j = o.excited.index();
            ((x.g[j] - y.g[j]) * o.u1).norm() / o.y1_var[j].sqrt()
        })
        .collect();
    let k = (0..grid.len()).max_by(|&i, &j| sigma[i].total_cmp(&sigma[j]))?;
    let at = &grid[k];
    let from_omega = grid
        .iter()
        .zip(&sigma)
        .filter(|(o, _)| o.excited == at.excited && o.nominal_amplitude == at.nominal_amplitude)
        .filter(|(_, s)| **s >= RECORD_SIGMA)
        .map(|(o, _)| o.omega)
        .fold(None, |m: Option<f64>, w| Some(m.map_or(w, |m| m.min(w))));
    let top = obs.iter().map(|o| o.omega).fold(0.0, f64::max);
    let words = sentence(a, b, at, sigma[k], from_omega, top, campaign_sigma);
    Some(Separation {
        campaign_sigma,
        max_sigma: sigma[k],
        omega: at.omega,
        amplitude_m: at.nominal_amplitude,
        axis: at.excited,
        from_omega,
        words,
    })
}

/// The effects of `a` that `b` lacks, in their profiles' words.
fn own_words(a: &Structure, b: &Structure) -> String {
    let only: Vec<String> = a
        .effects()
        .iter()
        .filter(|c| !b.contains(c))
        .map(|c| format!("{} adds {}", c.label(), profile(c.kind).signature(c)))
        .collect();
    if only.is_empty() {
        "nothing the other lacks".into()
    } else {
        only.join("; ")
    }
}

fn sentence(
    a: &Structure,
    b: &Structure,
    at: &Observation,
    max: f64,
    from: Option<f64>,
    top: f64,
    campaign: f64,
) -> String {
    let place = match from {
        Some(w) if w > top * (1.0 + 1e-9) => {
            format!("above {w:.1} rad/s, beyond the campaign's top of {top:.1} rad/s")
        }
        Some(w) => format!("from {w:.1} rad/s"),
        None => format!("nowhere by {RECORD_SIGMA} standard deviations of one record"),
    };
    format!(
        "{} ({}) against {} ({}): they part {place} on {} with {:.1} mm sines, by up to {:.1} \
         noise standard deviations of one record at {:.1} rad/s; on the campaign's own records \
         by {:.1} in all",
        a.label(),
        own_words(a, b),
        b.label(),
        own_words(b, a),
        at.excited.name(),
        at.nominal_amplitude * 1e3,
        max,
        at.omega,
        campaign
    )
}

/// The grid: each excited axis at the campaign's first operating point, its smallest and
/// largest amplitude, 24 frequencies log-spaced from its lowest to three times its highest;
/// each point with the median first-harmonic noise of the campaign's records of that axis and
/// amplitude (a sensor's noise does not follow the excitation's frequency).
fn grid(obs: &[&Observation]) -> Vec<Observation> {
    let lo = obs.iter().map(|o| o.omega).fold(f64::INFINITY, f64::min);
    let hi = 3.0 * obs.iter().map(|o| o.omega).fold(0.0, f64::max);
    let amps = [
        obs.iter()
            .map(|o| o.nominal_amplitude)
            .fold(f64::INFINITY, f64::min),
        obs.iter().map(|o| o.nominal_amplitude).fold(0.0, f64::max),
    ];
    let op = obs.first().map_or([0.0; 2], |o| o.operating_point);
    let mut out = Vec::new();
    for axis in Axis::BOTH {
        for &amp in &amps {
            let mut var: Vec<f64> = obs
                .iter()
                .filter(|o| o.excited == axis && (o.nominal_amplitude - amp).abs() < 1e-12)
                .map(|o| o.y1_var[axis.index()])
                .collect();
            if var.is_empty() {
                continue;
            }
            var.sort_by(f64::total_cmp);
            let v = var[var.len() / 2];
            for w in zmp_models::logspace(lo, hi, 24) {
                out.push(Observation {
                    index: out.len(),
                    excited: axis,
                    omega: w,
                    operating_point: op,
                    nominal_amplitude: amp,
                    t0: 0.0,
                    t1: 1.0,
                    u1: Complex64::new(amp, 0.0),
                    y1: [Complex64::new(0.0, 0.0); 2],
                    y1_var: [v; 2],
                    y3: [Complex64::new(0.0, 0.0); 2],
                    y3_var: [v; 2],
                    third_band: false,
                    slope: [0.0; 2],
                    slope_var: [1.0; 2],
                    noise_std: [v.sqrt(); 2],
                    samples: 0,
                });
            }
        }
    }
    out
}
