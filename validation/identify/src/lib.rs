//! Identification (first seed, section 5): from a stepped-sine campaign to the seed's ZMP model
//! with standard errors and uncertainty weights.
//!
//! The pipeline, per record then over the campaign:
//! 1. steady state: where the transient ends, found from the data (sliding one-period windows
//!    whose phasors must stay within their noise of the final value); whole periods kept;
//! 2. first estimate: Hann window + FFT, amplitude and phase of the fundamental (and a check
//!    that the excitation is at the frequency the manifest says);
//! 3. nonlinear regression: DC + K harmonics of the input and both outputs by linear least
//!    squares at a given frequency, the frequency refined on the summed residual (variable
//!    projection); per record the column of `G` for the excited input, its standard error,
//!    the harmonic distortion and the noise (from the period-to-period variation of the
//!    steady state, pooled over the campaign by frequency: `noise`);
//! 4. pendulum fit: `G_ij = (a_ij + b_ij w^2) H(jw)` for the four channels jointly with a shared
//!    tracking low-pass `H = wn^2/(s^2 + 2 zeta wn s + wn^2)`, weighted Levenberg-Marquardt,
//!    standard errors from `(J^T W J)^-1` scaled by the reduced chi-square when above one;
//! 5. bandwidth: `wn, zeta` kept from the data when they are determined (relative standard
//!    errors below 25 %), otherwise fixed at the given value and said so;
//! 6. saturation: records with a significant 3rd harmonic and a compressed first-harmonic gain
//!    are flagged and left out of the linear fit; the acceleration limit is estimated by
//!    matching the servo's describing function;
//! 7. uncertainty: per channel and frequency, the largest `|G_meas - G_model|` (additive),
//!    divided by `|G_model|` (multiplicative), enveloped by `W = k (s + z)/(s + p)`;
//! 8. the model file, with `[stderr]` and `[provenance]`.
//!
//! Where the steps live: 1-3 in `record_analysis` (with `steady`, `sine`, `noise`), 4-5 in
//! `pendulum` (with `fit`), 6 in `saturation_limit`, 7 in `uncertainty`, 8 in `model_file`;
//! `campaign_fit` runs 4-8 over the campaign; the report is `zmp_report::identify`.

// Index loops read as the matrix algebra they implement.
#![allow(clippy::needless_range_loop)]
#![warn(missing_docs)]

mod campaign_fit;
mod fit;
mod model_file;
mod noise;
mod pendulum;
mod record_analysis;
mod saturation_limit;
pub(crate) mod sine;
mod steady;
mod uncertainty;

pub use campaign_fit::identify_analysed;
pub use model_file::{summary_json, write_model};
pub use noise::normal_quantile;
pub use record_analysis::{analyse_folder, analyse_record, analyse_records, pool_noise};

use num_complex::Complex64;
use serde::Serialize;
use std::path::PathBuf;
use zmp_campaign::Campaign;
use zmp_models::effects::pendulum::Pendulum;
use zmp_models::{Axis, ModelSpec};

/// The SILO2 values of the first seed (section 6), for comparison in reports.
pub const SEED_PENDULUM: Pendulum = Pendulum {
    a: [[0.8293, 0.07455], [0.1895, 1.245]],
    b: [[0.2767, 0.005428], [0.09979, 0.1012]],
};
/// The seed's tracking low-pass `(omega_n, zeta)` (section 6.3).
pub const SEED_BANDWIDTH: (f64, f64) = (30.0, 1.0);

/// Reduced chi-square above which the pendulum fit counts as poor (said in words, and the
/// low-pass is compared with a low-pass and a delay).
pub const POOR_FIT: f64 = 4.0;
/// The pendulum and low-pass fitted again with a pure delay in front: what a low-pass that
/// absorbed a delay would have been.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DelayAlternative {
    /// The pure delay in front of the low-pass, s.
    pub delay_s: f64,
    /// Natural frequency of the low-pass refitted with the delay, rad/s.
    pub omega_n: f64,
    /// Damping ratio of the low-pass refitted with the delay (dimensionless).
    pub zeta: f64,
    /// Reduced chi-square of the fit with the delay (compare with
    /// [`Identification::reduced_chi2`]).
    pub reduced_chi2: f64,
}

/// Options of [`identify`].
#[derive(Debug, Clone)]
pub struct IdentifyOptions {
    /// Harmonics fitted per record (1 = fundamental only); 3 by default.
    pub harmonics: usize,
    /// The tracking low-pass `(omega_n rad/s, zeta)` used when the data do not determine it
    /// (and as the start of its estimate). `None`: the start model's, else the seed's (30, 1).
    pub given_bandwidth: Option<(f64, f64)>,
    /// Use `given_bandwidth` as it is, without estimating it from the data.
    pub fix_bandwidth: bool,
    /// A model whose structure is refitted: its core effects (pendulum, tracking low-pass,
    /// uncertainty) are identified, its other linear effects enter the fit with their values
    /// fixed (as a complex factor per record), its nonlinear ones are kept as they are.
    pub start_model: Option<ModelSpec>,
    /// Where the campaign was read from, for the provenance.
    pub campaign_path: Option<PathBuf>,
    /// Detect acceleration saturation (on by default).
    pub detect_saturation: bool,
    /// Put a detected acceleration limit into the model file. Off by default: the identified
    /// model is the seed's linear one, and nonlinear effects are added through diagnose and
    /// augment, each with held-out evidence and a ledger entry. A start model that names
    /// `acceleration_saturation` has its limit refitted regardless.
    pub include_saturation: bool,
    /// Worker threads for the per-record analysis (`None`: the available cores).
    pub threads: Option<usize>,
    /// Relative accuracy floor of a measured gain (added in quadrature to its noise-based
    /// standard error): sensor calibration, sampling and interpolation effects that white
    /// noise does not describe. 3e-4 by default.
    pub relative_floor: f64,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        IdentifyOptions {
            harmonics: 3,
            given_bandwidth: None,
            fix_bandwidth: false,
            start_model: None,
            campaign_path: None,
            detect_saturation: true,
            include_saturation: false,
            threads: None,
            relative_floor: 3e-4,
        }
    }
}

/// The analysis of one record.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecordFit {
    /// Index of the record in the campaign.
    pub index: usize,
    /// The CoM axis whose reference carries the sine (from the manifest).
    pub excited: Axis,
    /// Excitation frequency from the manifest, rad/s.
    pub omega: f64,
    /// Frequency refined by the sine fit, rad/s.
    pub omega_fit: f64,
    /// Amplitude of the excited reference from the manifest, m.
    pub amplitude: f64,
    /// Amplitude of the excited reference fitted in the data, m.
    pub input_amplitude: f64,
    /// CoM operating point `[x, y]` the sine is centred on, from the manifest, m.
    pub operating_point: [f64; 2],
    /// Column of `G` for the excited input: `[G_xj, G_yj]` (output zmp_x, zmp_y).
    #[serde(serialize_with = "ser_complex2")]
    pub g: [Complex64; 2],
    /// Standard deviation of the real and of the imaginary part of each `g`.
    pub sigma: [f64; 2],
    /// RMS of harmonics 2..K over the fundamental, per output.
    pub distortion: [f64; 2],
    /// The same for the excited input.
    pub input_distortion: f64,
    /// Third-harmonic amplitude of each output over its standard error.
    pub third_harmonic_snr: [f64; 2],
    /// Residual standard deviation of each output after the harmonic fit, m.
    pub noise_std: [f64; 2],
    /// Where the steady state starts, s from the record's first sample.
    pub steady_start_s: f64,
    /// Whole periods of steady state used.
    pub periods: usize,
    /// `Some(reason)` if the record is not used in the linear fit.
    pub excluded: Option<String>,
    /// The steady-state components the diagnosis compares (`None` for a record that could
    /// not be analysed).
    #[serde(skip)]
    pub components: Option<SteadyComponents>,
}

/// A noise power per sample and its effective degrees of freedom: white noise of variance
/// `s^2` has power `s^2` at every frequency; a least-squares sine coefficient over `n`
/// samples of a noise of power `S` near its frequency has variance about `2 S / n`. The
/// estimate is a scaled chi-square with `dof` degrees of freedom (`power` `NaN` and `dof` 0
/// when nothing measured it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NoisePower {
    /// Noise power per sample, m² (`NaN` when unmeasured).
    pub power: f64,
    /// Effective degrees of freedom of the estimate (0 when unmeasured).
    pub dof: f64,
    /// Where the estimate comes from.
    pub source: NoiseSource,
}

/// Where a record's noise power comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseSource {
    /// Measured by this record alone (its periods, or its bins near zero frequency).
    Own,
    /// Pooled over the campaign's records by frequency (one sensor, one noise).
    Pooled,
    /// This record's own although pooling was asked: it varies from period to period beyond
    /// the campaign's noise (a response that does not quite repeat), and keeps the larger.
    Inconsistent,
    /// The residual variance of its harmonic fit: there was nothing to pool.
    Residual,
    /// Nothing measured it.
    Unmeasured,
}

/// The noise of one output of a record (see the `noise` module): this record's own
/// period-to-period estimates, its residual's bins near zero frequency, and the campaign's
/// pooled powers its variances use.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputNoise {
    /// From this record's periods alone, at its frequency.
    pub periods_first: NoisePower,
    /// From this record's periods alone, at three times its frequency.
    pub periods_third: NoisePower,
    /// Residual power per sample in bins near zero frequency, each clear of every harmonic:
    /// `(frequency rad/s, m²)`, two degrees of freedom each.
    pub zero_bins: Vec<(f64, f64)>,
    /// Pooled over the campaign's records by frequency, at this record's frequency: its
    /// first harmonic's noise.
    pub first: NoisePower,
    /// Pooled likewise at three times this record's frequency: its third harmonic's noise.
    pub third: NoisePower,
    /// Pooled likewise and averaged over [`SteadyComponents::trend_omegas`]: its trend's
    /// noise.
    pub trend: NoisePower,
}

/// The steady-state components of a record from its harmonic fit (with a trend column), and
/// the noise they carry: what the diagnosis compares with a model.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadyComponents {
    /// Time of the steady-state window's first sample, s (the record's own clock).
    pub t0: f64,
    /// Time of the steady-state window's last sample, s.
    pub t1: f64,
    /// Samples in the window.
    pub samples: usize,
    /// Whole periods in the window.
    pub periods: usize,
    /// Frequency the components were fitted at (refined), rad/s.
    pub omega: f64,
    /// First-harmonic phasor of the excited input (sin-referenced, phase from the window's
    /// start), m.
    pub u1: Complex64,
    /// First-harmonic phasors of `[zmp_x, zmp_y]`, same reference, m.
    pub y1: [Complex64; 2],
    /// Third-harmonic phasors of `[zmp_x, zmp_y]`, same reference, m.
    pub y3: [Complex64; 2],
    /// Linear trend of each output over the window, m/s.
    pub trend: [f64; 2],
    /// Residual variance of the harmonic fit of each output, m²: the noise plus every
    /// harmonic above the fitted ones (reported as the record's noise level; the variances
    /// below do not use it).
    pub residual_var: [f64; 2],
    /// Residual variance of the harmonic fit of the excited input, m².
    pub input_residual_var: f64,
    /// The frequencies at which the fitted trend sees the noise, rad/s: the
    /// `record_analysis::TREND_NODES` equal-weight quadrature nodes of the
    /// trend column's spectral window over this window's length (the trend's noise power is
    /// the pooled power averaged over them).
    pub trend_omegas: [f64; record_analysis::TREND_NODES.len()],
    /// The noise of each output.
    pub noise: [OutputNoise; 2],
    /// Variance factors of the fit: the inverse normal matrix's diagonal at the
    /// fundamental's sin and cos columns (dimensionless: a coefficient's variance is the
    /// noise variance times it).
    pub inv_diag_h1: [f64; 2],
    /// The inverse normal matrix's diagonal at the trend column, 1/s².
    pub inv_diag_trend: f64,
}

impl SteadyComponents {
    /// Variance of the real (and of the imaginary) part of `y1[i]`, m²: the pooled
    /// period-to-period noise power at the record's frequency times the fit's factor.
    pub fn y1_var(&self, i: usize) -> f64 {
        self.noise[i].first.power * 0.5 * (self.inv_diag_h1[0] + self.inv_diag_h1[1])
    }

    /// Variance of `trend[i]`, (m/s)²: the pooled power near zero frequency at the trend's
    /// nodes times the fit's factor.
    pub fn trend_var(&self, i: usize) -> f64 {
        self.noise[i].trend.power * self.inv_diag_trend
    }

    /// Variance of the real (and of the imaginary) part of `y3[i]`, m²: `2/n` of the pooled
    /// period-to-period noise power at three times the frequency (the harmonic columns are
    /// orthogonal over whole periods).
    pub fn y3_var(&self, i: usize) -> f64 {
        self.noise[i].third.power * 2.0 / self.samples.max(1) as f64
    }

    /// Effective degrees of freedom of [`y1_var`](Self::y1_var): its estimate is a scaled
    /// chi-square with this many (a whitened first-harmonic component then follows Student's
    /// t, a sum of `k` squared ones over `k` an F(k, dof), rather than a chi-square).
    pub fn y1_dof(&self, i: usize) -> f64 {
        self.noise[i].first.dof
    }

    /// Effective degrees of freedom of [`trend_var`](Self::trend_var).
    pub fn trend_dof(&self, i: usize) -> f64 {
        self.noise[i].trend.dof
    }

    /// Effective degrees of freedom of [`y3_var`](Self::y3_var).
    pub fn y3_dof(&self, i: usize) -> f64 {
        self.noise[i].third.dof
    }
}

fn ser_complex2<S: serde::Serializer>(g: &[Complex64; 2], s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeSeq;
    let mut seq = s.serialize_seq(Some(2))?;
    for v in g {
        seq.serialize_element(&[v.re, v.im])?;
    }
    seq.end()
}

/// Reasons a record is left out (the strings that [`RecordFit::excluded`] holds).
pub mod reason {
    /// The record holds fewer than two periods of its frequency (or fewer than four samples
    /// a period, or no valid sample period or frequency).
    pub const TOO_SHORT: &str = "shorter than two periods";
    /// The steady state, once the transient is over, holds fewer than two whole periods.
    pub const NO_STEADY: &str = "fewer than two whole periods of steady state";
    /// The manifest's amplitude is not positive, the excited reference is constant, or the
    /// fitted input amplitude is below a thousandth of the manifest's.
    pub const ZERO_AMPLITUDE: &str = "zero amplitude: the excited reference carries no sine";
    /// A ZMP output never changes.
    pub const CONSTANT_OUTPUT: &str = "constant output (ZMP sensor dead or disconnected?)";
    /// The input's FFT peak is more than two bins from the manifest's frequency.
    pub const WRONG_FREQUENCY: &str = "the excitation is not at the frequency campaign.toml gives";
    /// A sample is not finite, or the harmonic regression or its frequency refinement failed.
    pub const BAD_DATA: &str = "the harmonic fit failed (non-finite or degenerate data)";
    /// Past the time limit of the work identification serves (`par::with_deadline`, the
    /// loop's `--time-limit`), the records not yet analysed are left out.
    pub const TIME_LIMIT: &str = "not analysed: the time limit passed before its turn";
    /// Flagged as saturated: a compressed first-harmonic gain with significant odd
    /// harmonics; left out of the linear fit.
    pub const SATURATED: &str =
        "acceleration saturation (first-harmonic gain off the linear model, odd harmonics)";
}

/// A fitted parameter.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Parameter {
    /// Dotted name as in the model file (`pendulum.a11`).
    pub name: String,
    /// Fitted (or given) value, in the parameter's unit in the model file (`a`: m/m,
    /// `b`: s², `omega_n`: rad/s, `zeta`: 1, a limit: m/s²).
    pub value: f64,
    /// Standard error (0 for a parameter held fixed).
    pub stderr: f64,
    /// Whether it was estimated from the data (false: given and held fixed).
    pub estimated: bool,
}

impl Parameter {
    /// 95 % confidence interval (normal approximation).
    pub fn ci95(&self) -> (f64, f64) {
        (
            self.value - 1.96 * self.stderr,
            self.value + 1.96 * self.stderr,
        )
    }
}

/// The tracking low-pass found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Bandwidth {
    /// Natural frequency of `H = wn^2/(s^2 + 2 zeta wn s + wn^2)`, rad/s.
    pub omega_n: f64,
    /// Damping ratio of `H` (dimensionless).
    pub zeta: f64,
    /// Standard error of `omega_n`, rad/s (0 when it was given, not estimated).
    pub omega_n_stderr: f64,
    /// Standard error of `zeta` (0 when it was given, not estimated).
    pub zeta_stderr: f64,
    /// True if estimated from the data, false if the given value was used.
    pub estimated: bool,
    /// Why (for reports).
    pub note: String,
}

/// The acceleration saturation found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Saturation {
    /// Records flagged as saturated (left out of the linear fit).
    pub records: Vec<usize>,
    /// Records with significant odd harmonics but no gain compression (kept in the fit).
    pub harmonic_only: Vec<usize>,
    /// Estimated acceleration limit, m/s².
    pub limit: Option<f64>,
    /// Standard error of the limit, m/s².
    pub limit_stderr: Option<f64>,
    /// Per flagged record: the demanded CoM acceleration amplitude `A w^2 |H|`, m/s².
    pub demanded_acceleration: Vec<(usize, f64)>,
}

/// One point of the uncertainty database.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UncertaintyPoint {
    /// Frequency, rad/s.
    pub omega: f64,
    /// Largest `|G_meas - G_model|` over the records at this frequency.
    pub additive: f64,
    /// `additive / |G_model|`.
    pub multiplicative: f64,
    /// Records at this frequency.
    pub records: usize,
}

/// The uncertainty of one channel.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelUncertainty {
    /// `G11`..`G22`.
    pub channel: String,
    /// The measured uncertainty per frequency, ascending.
    pub points: Vec<UncertaintyPoint>,
    /// `W = k (s + z)/(s + p)`: `(k, z, p)`.
    pub weight: (f64, f64, f64),
}

/// Everything identification found.
#[derive(Debug, Clone)]
pub struct Identification {
    /// When the pendulum fit is poor: the same fit with a pure delay in front of the
    /// low-pass, for comparison (reported, not put in the model).
    pub delay_alternative: Option<DelayAlternative>,
    /// The campaign's `name` in its manifest.
    pub campaign_name: Option<String>,
    /// Every record's analysis, in campaign order (excluded ones with their reason).
    pub records: Vec<RecordFit>,
    /// The pendulum's static gains `a[i][j]` (m/m), with their standard errors.
    pub a: [[Parameter; 2]; 2],
    /// The pendulum's acceleration gains `b[i][j]` (s²), with their standard errors.
    pub b: [[Parameter; 2]; 2],
    /// The tracking low-pass shared by the four channels.
    pub bandwidth: Bandwidth,
    /// The records flagged as saturated and the acceleration limit found.
    pub saturation: Saturation,
    /// The multiplicative uncertainty per channel and its weight.
    pub uncertainty: Vec<ChannelUncertainty>,
    /// Reduced chi-square of the pendulum fit (about 1 when the model explains the data to
    /// within the noise).
    pub reduced_chi2: f64,
    /// Each names the records it is about.
    pub warnings: Vec<String>,
    /// The identified model, with `[stderr]` and `[provenance]`.
    pub model: ModelSpec,
}

impl Identification {
    /// Records used in the linear fit.
    pub fn used(&self) -> impl Iterator<Item = &RecordFit> {
        self.records.iter().filter(|r| r.excluded.is_none())
    }

    /// Every fitted parameter, pendulum first.
    pub fn parameters(&self) -> Vec<Parameter> {
        let mut v = Vec::new();
        for m in [&self.a, &self.b] {
            for row in m {
                v.extend(row.iter().cloned());
            }
        }
        v.push(Parameter {
            name: "tracking_lowpass.omega_n".into(),
            value: self.bandwidth.omega_n,
            stderr: self.bandwidth.omega_n_stderr,
            estimated: self.bandwidth.estimated,
        });
        v.push(Parameter {
            name: "tracking_lowpass.zeta".into(),
            value: self.bandwidth.zeta,
            stderr: self.bandwidth.zeta_stderr,
            estimated: self.bandwidth.estimated,
        });
        if let Some(l) = self.saturation.limit {
            v.push(Parameter {
                name: "acceleration_saturation.limit".into(),
                value: l,
                stderr: self.saturation.limit_stderr.unwrap_or(f64::NAN),
                estimated: true,
            });
        }
        v
    }

    /// The linear model's `G_ij(j omega)` (without uncertainty).
    pub fn model_response(&self, i: usize, j: usize, omega: f64) -> Complex64 {
        let h = fit::lowpass(omega, self.bandwidth.omega_n, self.bandwidth.zeta);
        (self.a[i][j].value + self.b[i][j].value * omega * omega) * h
    }
}

/// Identification errors; they name the records concerned.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// The campaign lists no record.
    #[error("the campaign has no records")]
    Empty,
    /// Every record was excluded; the reasons, naming the records.
    #[error("no usable record: {0}")]
    NoUsableRecords(String),
    /// An excited axis has no usable record, or fewer than three frequencies spanning a
    /// factor two (its `a` and `b` cannot be separated); what is missing.
    #[error("{0}")]
    FrequencySpan(String),
    /// The pendulum fit had no data points, or the model file could not be made from it
    /// (invalid, or a parameter it cannot hold); what went wrong.
    #[error("the pendulum fit failed: {0}")]
    FitFailed(String),
}

/// `records 3, 17` / `record 3`.
pub fn name_records(ix: &[usize]) -> String {
    let list: Vec<String> = ix.iter().map(|i| i.to_string()).collect();
    if ix.len() == 1 {
        format!("record {}", list[0])
    } else {
        format!("records {}", list.join(", "))
    }
}

/// Worker threads for `opts`: `opts.threads`, else the thread budget ([`zmp_campaign::par::budget`]:
/// the available cores unless a caller set it).
fn worker_count(opts: &IdentifyOptions) -> usize {
    opts.threads
        .unwrap_or_else(zmp_campaign::par::budget)
        .max(1)
}

/// Identifies the campaign (see the module docs).
pub fn identify(
    campaign: &Campaign,
    opts: &IdentifyOptions,
) -> Result<Identification, IdentifyError> {
    identify_with_progress(campaign, opts, &|_| {})
}

/// As [`identify`], calling `progress(records analysed)` during the per-record step.
pub fn identify_with_progress(
    campaign: &Campaign,
    opts: &IdentifyOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Identification, IdentifyError> {
    identify_analysed(
        analyse_records(campaign, opts, progress),
        campaign.name.clone(),
        opts,
    )
}
