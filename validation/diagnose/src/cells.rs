//! "Where it fails": the error split by channel, frequency band, amplitude and operating point,
//! and the cells whose error is significantly above their noise floor.

use super::measure::Prediction;
use super::observe::Observation;
use serde::Serialize;
use zmp_models::{Axis, Channel};

/// Per record and per output channel: squared error and squared floor, in the record's
/// normalisation (they sum over the two outputs to the record's score).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelScore {
    /// Squared prediction error of the channel (fundamental and slope terms).
    pub error2: f64,
    /// Squared noise floor of the channel: the error noise alone would produce.
    pub floor2: f64,
}

/// Scores of output `i` of every record.
pub fn channel_scores(o: &Observation, p: &Prediction) -> [ChannelScore; 2] {
    let t = o.duration();
    let den: f64 = (0..2)
        .map(|i| 0.5 * o.y1[i].norm_sqr())
        .sum::<f64>()
        .max(1e-300);
    let mut out = [ChannelScore {
        error2: 0.0,
        floor2: 0.0,
    }; 2];
    for (i, c) in out.iter_mut().enumerate() {
        let d = o.y1[i] - p.g[i] * o.u1;
        c.error2 = (0.5 * d.norm_sqr() + (o.slope[i] - p.slope[i]).powi(2) * t * t / 12.0) / den;
        c.floor2 = (o.y1_var[i] + o.slope_var[i] * t * t / 12.0) / den;
    }
    out
}

/// One cell of the campaign.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Cell {
    /// `G11` ... `G22` (output, excited input).
    pub channel: String,
    /// Frequency band, rad/s: `[low, high]` of the records in it.
    pub band_rad_s: [f64; 2],
    /// `low`, `mid` or `high` third of the campaign's frequencies (log scale).
    pub band: String,
    /// Reference amplitude, m.
    pub amplitude_m: f64,
    /// Operating point `[x, y]`, m.
    pub operating_point_m: [f64; 2],
    /// How many records fall in the cell.
    pub records: usize,
    /// RMS error and noise floor of the cell's records (the diagnosis measure, this channel).
    pub error: f64,
    /// RMS noise floor of the same records: the error noise alone would give.
    pub noise_floor: f64,
    /// `error / noise_floor`.
    pub ratio: f64,
    /// Above the floor beyond what noise explains for this many records.
    pub significant: bool,
}

impl Cell {
    /// One line: `G11  0.50-1.17  rad/s   3.0 mm  op (+0.000, +0.020) m   55.6x`.
    pub fn line(&self) -> String {
        format!(
            "{} {:>5.2}-{:<5.2} rad/s  {:>4.1} mm  op ({:+.3}, {:+.3}) m  {:>6.1}x",
            self.channel,
            self.band_rad_s[0],
            self.band_rad_s[1],
            self.amplitude_m * 1e3,
            self.operating_point_m[0],
            self.operating_point_m[1],
            self.ratio
        )
    }
}

/// Squared-error ratio above which a cell of `n` records counts as failing: at least 9
/// (error three times the floor: the floor is itself estimated, and a campaign has many
/// cells) and beyond six standard deviations of the chi-square spread of noise alone (three
/// degrees of freedom per record and channel).
pub fn threshold(n: usize) -> f64 {
    (1.0 + 6.0 * (2.0 / (3.0 * n.max(1) as f64)).sqrt()).max(9.0)
}

/// The frequency band (0, 1, 2) of `omega` within the campaign's range, log scale.
pub fn band_of(omega: f64, lo: f64, hi: f64) -> usize {
    if hi <= lo * (1.0 + 1e-9) {
        return 0;
    }
    let x = (omega / lo).ln() / (hi / lo).ln();
    ((x * 3.0).floor() as usize).min(2)
}

/// Names of the three frequency bands, indexed by [`band_of`].
pub const BAND_NAMES: [&str; 3] = ["low", "mid", "high"];

/// Cells of the campaign against predictions `preds`, most failing first.
pub fn cells(obs: &[&Observation], preds: &[Prediction]) -> Vec<Cell> {
    let lo = obs.iter().map(|o| o.omega).fold(f64::INFINITY, f64::min);
    let hi = obs.iter().map(|o| o.omega).fold(0.0, f64::max);
    #[derive(Default)]
    struct Acc {
        e: f64,
        f: f64,
        n: usize,
        wlo: f64,
        whi: f64,
    }
    let mut map: std::collections::BTreeMap<(usize, usize, usize, i64, i64, i64), Acc> =
        Default::default();
    for (o, p) in obs.iter().zip(preds) {
        let s = channel_scores(o, p);
        let band = band_of(o.omega, lo, hi);
        for (i, c) in s.iter().enumerate() {
            let key = (
                i,
                o.excited.index(),
                band,
                (o.nominal_amplitude * 1e7).round() as i64,
                (o.operating_point[0] * 1e7).round() as i64,
                (o.operating_point[1] * 1e7).round() as i64,
            );
            let a = map.entry(key).or_insert(Acc {
                wlo: f64::INFINITY,
                ..Default::default()
            });
            a.e += c.error2;
            a.f += c.floor2;
            a.n += 1;
            a.wlo = a.wlo.min(o.omega);
            a.whi = a.whi.max(o.omega);
        }
    }
    let mut out: Vec<Cell> = map
        .into_iter()
        .map(|((i, j, band, amp, opx, opy), a)| {
            let ch = Channel::new(
                Axis::from_index(i).expect("0 or 1"),
                Axis::from_index(j).expect("0 or 1"),
            );
            let ratio2 = a.e / a.f.max(1e-300);
            Cell {
                channel: ch.name().to_string(),
                band_rad_s: [a.wlo, a.whi],
                band: BAND_NAMES[band].to_string(),
                amplitude_m: amp as f64 * 1e-7,
                operating_point_m: [opx as f64 * 1e-7, opy as f64 * 1e-7],
                records: a.n,
                error: (a.e / a.n as f64).sqrt(),
                noise_floor: (a.f / a.n as f64).sqrt(),
                ratio: ratio2.sqrt(),
                significant: ratio2 > threshold(a.n),
            }
        })
        .collect();
    out.sort_by(|a, b| {
        b.significant
            .cmp(&a.significant)
            .then(b.ratio.total_cmp(&a.ratio))
    });
    out
}

/// Error of each channel over the whole campaign: `(channel, error, floor)` with the errors
/// as RMS over the channel's records.
pub fn channel_summary(obs: &[&Observation], preds: &[Prediction]) -> Vec<(String, f64, f64)> {
    let mut acc = [[(0.0, 0.0, 0usize); 2]; 2];
    for (o, p) in obs.iter().zip(preds) {
        for (i, c) in channel_scores(o, p).iter().enumerate() {
            let a = &mut acc[i][o.excited.index()];
            a.0 += c.error2;
            a.1 += c.floor2;
            a.2 += 1;
        }
    }
    let mut out = Vec::new();
    for ch in Channel::ALL {
        let a = acc[ch.output.index()][ch.input.index()];
        if a.2 > 0 {
            out.push((
                ch.name().to_string(),
                (a.0 / a.2 as f64).sqrt(),
                (a.1 / a.2 as f64).sqrt(),
            ));
        }
    }
    out
}
