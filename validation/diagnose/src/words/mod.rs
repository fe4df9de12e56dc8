//! The diagnosis in words: the evidence for an effect (what the measurements show against the
//! model without it, each profile's sentence over the shared features here), what tells two
//! explanations apart ([`distinguish`]), and what an unexplained residual looks like
//! ([`describe_residual`]).

use crate::measure::Prediction;
use crate::observe::Observation;
use num_complex::Complex64;
use zmp_models::ModelSpec;

mod distinguish;
mod features;
mod residual;

pub use distinguish::{distinguish, Separation};
use features::{amplitude_contrast, axes_of, ratios};
pub use features::{
    amplitude_dependence, amplitude_dependence_shown, clamped, median, median_by_frequency,
    op_line, phase_words, sig, slope_through_origin, unwrapped_phase, AmplitudeDependence,
};
pub use residual::{describe_residual, ResidualFeature};

/// What an evidence sentence is computed from.
pub struct Evidence<'a> {
    /// The records the sentence describes.
    pub obs: &'a [&'a Observation],
    /// The fitted model without the effect (every other parameter as fitted with it).
    pub base_spec: &'a ModelSpec,
    /// Its predictions.
    pub base: &'a [Prediction],
    /// The effect's fitted parameters: dotted name, value, standard error.
    pub params: &'a [(String, f64, f64)],
    /// The criterion's z threshold: a parameter further than this many standard errors from
    /// zero is determined by the records (`search::determined`).
    pub z_crit: f64,
}

impl Evidence<'_> {
    /// Measured over modelled first harmonic of each record's excited output: `(record, ratio)`.
    pub fn ratios(&self) -> Vec<(usize, Complex64)> {
        ratios(self.obs, self.base)
    }

    /// The ratios as frequencies, phases and magnitudes.
    pub fn ratio_parts(&self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let r = self.ratios();
        (
            r.iter().map(|(k, _)| self.obs[*k].omega).collect(),
            r.iter().map(|(_, q)| q.arg()).collect(),
            r.iter().map(|(_, q)| q.norm()).collect(),
        )
    }

    /// `param = value ± s.e.` for each fitted parameter.
    pub fn params_text(&self) -> String {
        axes_of(self.params)
    }

    /// The fitted value of the parameter whose dotted name ends with `suffix` (0 without).
    pub fn value_of(&self, suffix: &str) -> f64 {
        self.params
            .iter()
            .find(|(n, _, _)| n.ends_with(suffix))
            .map_or(0.0, |p| p.1)
    }
}

/// The evidence of an amplitude law (a play, a friction): how the smallest amplitude's response
/// compares with the largest's at the same frequencies against the model without it, and
/// whether that is beyond the noise; `what` names the effect.
pub fn amplitude_evidence(what: &str, e: &Evidence) -> String {
    let r = e.ratios();
    let dep = amplitude_dependence(e.obs, e.base, e.base_spec);
    match (
        amplitude_contrast(e.obs, &r, e.base_spec),
        amplitude_dependence_shown(&dep),
    ) {
        (Some((g, p, low)), Some(shown)) => {
            let words = if shown {
                format!("the response depends on amplitude, as with {what}")
            } else {
                let per_axis: Vec<String> = dep
                    .iter()
                    .zip(["x", "y"])
                    .filter_map(|(d, ax)| {
                        d.map(|d| {
                            format!(
                                "{ax}: gain {:+.2} %, lag {:+.2} deg, +- {:.2} % / {:.2} deg",
                                100.0 * d.log_gain,
                                d.lag.to_degrees(),
                                100.0 * d.std_error,
                                d.std_error.to_degrees()
                            )
                        })
                    })
                    .collect();
                format!(
                    "within the noise the response does not depend on amplitude as with {what} \
                     (weighted by the records' noise, {})",
                    per_axis.join("; ")
                )
            };
            format!(
                "the smallest amplitude's gain is {:.1} % below the largest's at the same \
                 frequencies ({:.1} % at the lowest third), with {:.1} deg more phase lag: \
                 {words} ({})",
                100.0 * (1.0 - g),
                100.0 * (1.0 - low),
                -p,
                e.params_text()
            )
        }
        _ => {
            let (_, _, mag) = e.ratio_parts();
            format!(
                "gain below the model by {:.1} % (median): {what} ({})",
                100.0 * median(mag.iter().map(|m| 1.0 - m).collect()),
                e.params_text()
            )
        }
    }
}
