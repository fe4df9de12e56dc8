//! What the robust-stability check ([`zmp_models::robust`]) reports: the summary that
//! `identify`, `loop` and `robust` print (text and JSON) and the figure of `|T|` against
//! `1/|W|` per channel.

use crate::plot::{bode_svg, BodePanel, BodeSeries, PALETTE};
use anyhow::Result;
use num_complex::Complex64;
use serde::Serialize;
use std::path::Path;
use zmp_models::robust::{channel_index, RobustAnalysis};
use zmp_models::Channel;

/// One weighted channel: its weight and `||W T||_inf`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelSummary {
    /// `G11` .. `G22`.
    pub channel: String,
    /// The weight `W = k (s + z) / (s + p)`.
    pub k: f64,
    pub z: f64,
    pub p: f64,
    /// `max_w |W T|`, and where (rad/s).
    pub wt_peak: f64,
    pub omega: f64,
}

/// The check's result as printed (`--json`: this structure).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RobustSummary {
    pub controller: String,
    /// Closed-loop poles in the right half-plane without perturbation (`null`: one on the
    /// imaginary axis).
    pub unstable_poles: Option<usize>,
    pub nominally_stable: bool,
    /// Stable for every perturbation inside the weights, all channels at once.
    pub robustly_stable: bool,
    /// Peak over frequency of the structured (`mu`) upper bound, and where (rad/s).
    pub mu_peak: Option<f64>,
    pub mu_omega: Option<f64>,
    /// `1 / mu_peak`: how far the weights could grow before the loop can be destabilised.
    pub margin: Option<f64>,
    pub tightest_channel: Option<String>,
    pub channels: Vec<ChannelSummary>,
    /// The one-line verdict.
    pub line: String,
}

/// The summary of an analysis.
pub fn summary(a: &RobustAnalysis) -> RobustSummary {
    RobustSummary {
        controller: a.controller.clone(),
        unstable_poles: a.unstable_poles,
        nominally_stable: a.nominally_stable(),
        robustly_stable: a.robustly_stable(),
        mu_peak: a.structured.map(|s| s.peak),
        mu_omega: a.structured.map(|s| s.omega),
        margin: a.structured.map(|s| 1.0 / s.peak),
        tightest_channel: a.tightest_channel().map(|c| c.channel.to_string()),
        channels: a
            .channels
            .iter()
            .map(|c| ChannelSummary {
                channel: c.channel.to_string(),
                k: c.weight.k,
                z: c.weight.z,
                p: c.weight.p,
                wt_peak: c.peak,
                omega: c.omega,
            })
            .collect(),
        line: a.summary(),
    }
}

/// Frequencies shown, rad/s: the seed's loop crosses over near 0.1 rad/s, its servo rolls off
/// from 30 rad/s (above 100 rad/s only the 100 Hz hold's notch is left to see).
const SHOWN: (f64, f64) = (1e-3, 1e2);

/// `|T_k|` (line) against `1/|W_k|` (dashed) for each weighted channel, and the structured
/// bound against 1: the loop is robustly stable where every `|T|` stays under its `1/|W|` and
/// the bound under 1. Written with [`bode_svg`], magnitudes only (atomic, `overwrite` as `--force`).
pub fn write_plot(path: &Path, a: &RobustAnalysis, overwrite: bool) -> Result<()> {
    let shown: Vec<usize> = (0..a.curves.omega.len())
        .filter(|&k| (SHOWN.0..=SHOWN.1).contains(&a.curves.omega[k]))
        .collect();
    let omega: Vec<f64> = shown.iter().map(|&k| a.curves.omega[k]).collect();
    let real = |v: f64| Complex64::new(v, 0.0);
    let mut panels = Vec::new();
    for c in &a.channels {
        let i = channel_index(c.channel);
        let t: Vec<Complex64> = shown.iter().map(|&k| a.curves.t[k][i]).collect();
        let inv_w: Vec<Complex64> = omega
            .iter()
            .map(|&w| real(1.0 / c.weight.response(w).norm()))
            .collect();
        panels.push(BodePanel {
            title: format!(
                "{}: |T| against 1/|W| (||W T|| = {:.3} at {:.3} rad/s)",
                c.channel, c.peak, c.omega
            ),
            series: vec![
                BodeSeries::line("|T|", omega.clone(), t, PALETTE[0]),
                BodeSeries::line("1/|W|", omega.clone(), inv_w, PALETTE[1]).dashed(),
            ],
            bands: vec![],
            magnitude_only: true,
        });
    }
    if let Some(s) = a.structured {
        let mu: Vec<Complex64> = shown.iter().map(|&k| real(a.curves.mu[k])).collect();
        let ones = vec![real(1.0); omega.len()];
        panels.push(BodePanel {
            title: format!(
                "all channels: mu upper bound (peak {:.3} at {:.3} rad/s)",
                s.peak, s.omega
            ),
            series: vec![
                BodeSeries::line("mu bound", omega.clone(), mu, PALETTE[2]),
                BodeSeries::line("1", omega.clone(), ones, PALETTE[5]).dashed(),
            ],
            bands: vec![],
            magnitude_only: true,
        });
    }
    bode_svg(path, &panels, 2, overwrite)
}

/// Words for a channel's loop in reports: `zmp_y from y_cr`.
pub fn channel_words(ch: Channel) -> String {
    format!("zmp_{} from {}_cr", ch.output.name(), ch.input.name())
}
