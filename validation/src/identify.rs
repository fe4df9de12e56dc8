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
//!    the harmonic distortion and the noise;
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

// Index loops read as the matrix algebra they implement.
#![allow(clippy::needless_range_loop)]

mod fit;
mod noise;
pub mod report;
mod sine;
mod steady;

use crate::campaign::{Campaign, Record};
use crate::par::parallel_map;
use fit::{Point, NP};
use num_complex::Complex64;
use serde::Serialize;
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use zmp_models::effect::BuildContext;
use zmp_models::effects::servo::{servo_first_harmonic_from, PeriodStart};
use zmp_models::{Axis, Binding, Channel, EffectInstance, ModelSpec, Plant};

/// The SILO2 values of the first seed (section 6), for comparison in reports.
pub const SEED_PENDULUM: [(&str, f64); 8] = [
    ("a11", 0.8293),
    ("a12", 0.07455),
    ("a21", 0.1895),
    ("a22", 1.245),
    ("b11", 0.2767),
    ("b12", 0.005428),
    ("b21", 0.09979),
    ("b22", 0.1012),
];
/// The seed's tracking low-pass `(omega_n, zeta)` (section 6.3).
pub const SEED_BANDWIDTH: (f64, f64) = (30.0, 1.0);

/// Reduced chi-square above which the pendulum fit counts as poor (said in words, and the
/// low-pass is compared with a low-pass and a delay).
pub const POOR_FIT: f64 = 4.0;

/// Chi-square drop that one added parameter must bring to be kept (likelihood-ratio test at
/// p = 0.001).
const LIKELIHOOD_RATIO_1DOF: f64 = 10.83;

/// The pendulum and low-pass fitted again with a pure delay in front: what a low-pass that
/// absorbed a delay would have been.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DelayAlternative {
    pub delay_s: f64,
    pub omega_n: f64,
    pub zeta: f64,
    pub reduced_chi2: f64,
}

/// The pendulum fit with a pure delay `tau` as a fixed factor `e^{-j w tau}` of every point,
/// `tau` chosen by Brent's method on the chi-square within `[0, min(0.5 s, 3 / omega_n)]`.
fn delay_alternative_fit(
    pts: &[Point],
    (wn0, z0): (f64, f64),
    wn_fit: f64,
) -> Option<DelayAlternative> {
    let with_delay = |tau: f64| -> Vec<Point> {
        pts.iter()
            .map(|p| Point {
                factor: p.factor * Complex64::from_polar(1.0, -p.omega * tau),
                ..*p
            })
            .collect()
    };
    let fit_at = |tau: f64| pendulum_fit(&with_delay(tau), (wn0.max(wn_fit), z0), false).ok();
    let chi = |tau: f64| fit_at(tau).map_or(f64::INFINITY, |(l, _, _)| l.chi2);
    let hi = (3.0 / wn_fit.max(1.0)).min(0.5);
    let (tau, _) = brent_minimise(0.0, hi, 1e-5, 40, chi);
    let (l, _, _) = fit_at(tau)?;
    (l.dof > 0).then(|| DelayAlternative {
        delay_s: tau,
        omega_n: l.params[8],
        zeta: l.params[9],
        reduced_chi2: l.chi2 / l.dof as f64,
    })
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
    pub excited: Axis,
    /// Excitation frequency from the manifest, rad/s.
    pub omega: f64,
    /// Frequency refined by the sine fit, rad/s.
    pub omega_fit: f64,
    /// Amplitude of the excited reference from the manifest, m.
    pub amplitude: f64,
    /// Amplitude of the excited reference fitted in the data, m.
    pub input_amplitude: f64,
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

/// The steady-state components of a record from its harmonic fit (with a trend column), and
/// the noise they carry: what the diagnosis compares with a model.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadyComponents {
    /// Steady-state window: first and last sample time, s (the record's own clock).
    pub t0: f64,
    pub t1: f64,
    pub samples: usize,
    /// Frequency the components were fitted at (refined), rad/s.
    pub omega: f64,
    /// First-harmonic phasor of the excited input (sin-referenced, phase from the window's
    /// start), m.
    pub u1: Complex64,
    /// First- and third-harmonic phasors of `[zmp_x, zmp_y]`, same reference, m.
    pub y1: [Complex64; 2],
    pub y3: [Complex64; 2],
    /// Linear trend of each output over the window, m/s.
    pub trend: [f64; 2],
    /// Residual variance of the harmonic fit of each output (white-noise estimate), m².
    pub residual_var: [f64; 2],
    /// Residual variance of the harmonic fit of the excited input, m².
    pub input_residual_var: f64,
    /// Residual power beside the excitation and near zero frequency over the residual
    /// variance, per output: this record's own colour estimate.
    pub colour_raw: [(f64, f64); 2],
    /// Middle frequency of the near-zero bins, rad/s.
    pub zero_band_omega: f64,
    /// Every bin of the colour estimate, per output: `(frequency rad/s, power over the
    /// residual variance)`, pooled over the campaign by frequency.
    pub colour_bins: [Vec<(f64, f64)>; 2],
    /// The campaign's pooled colour factors at this record's frequency and near zero
    /// (1 for white noise).
    pub colour: [(f64, f64); 2],
    /// The same at three times the record's frequency (the third harmonic's noise).
    pub colour3: [f64; 2],
    /// Variance factors of the fit: inverse normal matrix at the fundamental's sin and cos
    /// columns, and at the trend column (1/s²).
    pub inv_diag_h1: [f64; 2],
    pub inv_diag_trend: f64,
}

impl SteadyComponents {
    /// Variance of the real (and of the imaginary) part of `y1[i]`, m².
    pub fn y1_var(&self, i: usize) -> f64 {
        self.residual_var[i] * self.colour[i].0 * 0.5 * (self.inv_diag_h1[0] + self.inv_diag_h1[1])
    }

    /// Variance of `trend[i]`, (m/s)².
    pub fn trend_var(&self, i: usize) -> f64 {
        self.residual_var[i] * self.colour[i].1 * self.inv_diag_trend
    }

    /// Variance of the real (and of the imaginary) part of `y3[i]`, m²: `2/n` of the noise
    /// at three times the frequency (the harmonic columns are orthogonal over whole periods).
    pub fn y3_var(&self, i: usize) -> f64 {
        self.residual_var[i] * self.colour3[i] * 2.0 / self.samples.max(1) as f64
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
    pub const TOO_SHORT: &str = "shorter than two periods";
    pub const NO_STEADY: &str = "fewer than two whole periods of steady state";
    pub const ZERO_AMPLITUDE: &str = "zero amplitude: the excited reference carries no sine";
    pub const CONSTANT_OUTPUT: &str = "constant output (ZMP sensor dead or disconnected?)";
    pub const WRONG_FREQUENCY: &str = "the excitation is not at the frequency campaign.toml gives";
    pub const BAD_DATA: &str = "the harmonic fit failed (non-finite or degenerate data)";
    pub const SATURATED: &str =
        "acceleration saturation (first-harmonic gain off the linear model, odd harmonics)";
}

/// A fitted parameter.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Parameter {
    /// Dotted name as in the model file (`pendulum.a11`).
    pub name: String,
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
    pub omega_n: f64,
    pub zeta: f64,
    pub omega_n_stderr: f64,
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
    pub limit_stderr: Option<f64>,
    /// Per flagged record: the demanded CoM acceleration amplitude `A w^2 |H|`, m/s².
    pub demanded_acceleration: Vec<(usize, f64)>,
}

/// One point of the uncertainty database.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UncertaintyPoint {
    pub omega: f64,
    /// Largest `|G_meas - G_model|` over the records at this frequency.
    pub additive: f64,
    /// `additive / |G_model|`.
    pub multiplicative: f64,
    pub records: usize,
}

/// The uncertainty of one channel.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelUncertainty {
    /// `G11`..`G22`.
    pub channel: String,
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
    pub campaign_name: Option<String>,
    pub records: Vec<RecordFit>,
    /// `a[i][j]`, `b[i][j]` with their standard errors.
    pub a: [[Parameter; 2]; 2],
    pub b: [[Parameter; 2]; 2],
    pub bandwidth: Bandwidth,
    pub saturation: Saturation,
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
    #[error("the campaign has no records")]
    Empty,
    #[error("no usable record: {0}")]
    NoUsableRecords(String),
    #[error("{0}")]
    FrequencySpan(String),
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

fn excluded(rec: &Record, index: usize, why: &str) -> RecordFit {
    RecordFit {
        index,
        excited: rec.meta.excited,
        omega: rec.meta.omega,
        omega_fit: rec.meta.omega,
        amplitude: rec.meta.amplitude,
        input_amplitude: 0.0,
        operating_point: rec.meta.operating_point,
        g: [Complex64::new(f64::NAN, f64::NAN); 2],
        sigma: [f64::NAN; 2],
        distortion: [f64::NAN; 2],
        input_distortion: f64::NAN,
        third_harmonic_snr: [f64::NAN; 2],
        noise_std: [f64::NAN; 2],
        steady_start_s: 0.0,
        periods: 0,
        excluded: Some(why.to_string()),
        components: None,
    }
}

fn is_constant(v: &[f64]) -> bool {
    match v.first() {
        None => true,
        Some(&f) => v.iter().all(|&x| x == f),
    }
}

/// Steps 1-3 for one record (`index` is its place in the campaign).
pub fn analyse_record(rec: &Record, index: usize, opts: &IdentifyOptions) -> RecordFit {
    let omega = rec.meta.omega;
    let dt = rec.dt();
    let n = rec.len();
    if !(dt.is_finite() && dt > 0.0 && omega.is_finite() && omega > 0.0) {
        return excluded(rec, index, reason::TOO_SHORT);
    }
    let per = 2.0 * PI / (omega * dt);
    if (n as f64) < 2.0 * per || per < 4.0 {
        return excluded(rec, index, reason::TOO_SHORT);
    }
    let input = rec.excitation();
    if rec.meta.amplitude <= 0.0 || is_constant(input) {
        return excluded(rec, index, reason::ZERO_AMPLITUDE);
    }
    if is_constant(&rec.zmp_x) || is_constant(&rec.zmp_y) {
        return excluded(rec, index, reason::CONSTANT_OUTPUT);
    }
    // Centre every signal (conditioning of the fits).
    let centre = |v: &[f64]| -> Vec<f64> {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        v.iter().map(|x| x - m).collect()
    };
    let (u, yx, yy) = (centre(input), centre(&rec.zmp_x), centre(&rec.zmp_y));
    if ![&u, &yx, &yy]
        .iter()
        .all(|s| s.iter().all(|v| v.is_finite()))
    {
        return excluded(rec, index, reason::BAD_DATA);
    }
    // 1. Steady state.
    let Some(st) = steady::detect_steady([&u[..], &yx[..], &yy[..]], omega, dt) else {
        return excluded(rec, index, reason::TOO_SHORT);
    };
    let steady_start_s = st.start as f64 * dt;
    if st.periods < 2 {
        let mut r = excluded(rec, index, reason::NO_STEADY);
        r.steady_start_s = steady_start_s;
        r.periods = st.periods;
        return r;
    }
    let range = st.start..st.start + st.len;
    let sig = [&u[range.clone()], &yx[range.clone()], &yy[range]];
    // 2. First estimate: windowed FFT of the input; the excitation must be where the manifest
    // says (within two FFT bins).
    let (fft_phasors, w_fft) = sine::fft_estimate([sig[0]], omega, dt);
    let bin = 2.0 * PI / (st.len as f64 * dt);
    if (w_fft - omega).abs() > 2.0 * bin || fft_phasors[0].norm() == 0.0 {
        let mut r = excluded(rec, index, reason::WRONG_FREQUENCY);
        r.steady_start_s = steady_start_s;
        r.periods = st.periods;
        return r;
    }
    // 3. Harmonic regression with a trend column (a drifting sensor's ramp stays out of the
    // harmonics), the frequency refined on the detrended signals, then the final fit at the
    // refined frequency.
    let k_max = opts.harmonics.clamp(1, 8);
    let Some(first) = sine::harmonic_fit_trend(sig, omega, dt, k_max) else {
        return excluded(rec, index, reason::BAD_DATA);
    };
    let c = (st.len as f64 - 1.0) / 2.0;
    let detrended: [Vec<f64>; 3] = std::array::from_fn(|j| {
        let r = first.trend[j] * dt;
        sig[j]
            .iter()
            .enumerate()
            .map(|(k, y)| y - r * (k as f64 - c))
            .collect()
    });
    let Some((w, _)) = sine::refine_frequency(
        [&detrended[0][..], &detrended[1][..], &detrended[2][..]],
        omega,
        dt,
        k_max,
    ) else {
        return excluded(rec, index, reason::BAD_DATA);
    };
    let Some(hf) = sine::harmonic_fit_trend(sig, w, dt, k_max) else {
        return excluded(rec, index, reason::BAD_DATA);
    };
    // The outputs' residual colour (the input's is not used: its noise enters through
    // `noise_var[0]` alone).
    let local = noise::local_noise([sig[1], sig[2]], &hf.pick([1, 2]), w, dt);
    let p_in = hf.harmonics[0][0];
    let nn = st.len as f64;
    let amp_in = p_in.norm();
    if amp_in.is_nan() || amp_in <= 1e-3 * rec.meta.amplitude.abs() || !amp_in.is_finite() {
        return excluded(rec, index, reason::ZERO_AMPLITUDE);
    }
    let var_u = hf.noise_var[0];
    let mut g = [Complex64::new(0.0, 0.0); 2];
    let mut sigma = [0.0; 2];
    let mut distortion = [0.0; 2];
    let mut snr3 = [0.0; 2];
    let mut noise = [0.0; 2];
    for o in 0..2 {
        let p = hf.harmonics[1 + o][0];
        g[o] = p / p_in;
        let var_y = hf.noise_var[1 + o];
        // Each phasor component has variance 2 var / n over whole periods.
        let noise_var = (2.0 / nn) * (var_y + g[o].norm_sqr() * var_u) / (amp_in * amp_in);
        sigma[o] = (noise_var + (opts.relative_floor * g[o].norm()).powi(2)).sqrt();
        let harm: f64 = hf.harmonics[1 + o][1..].iter().map(|h| h.norm_sqr()).sum();
        distortion[o] = harm.sqrt() / p.norm().max(1e-300);
        snr3[o] = if k_max >= 3 {
            hf.harmonics[1 + o][2].norm() / ((2.0 / nn) * var_y).sqrt().max(1e-300)
        } else {
            0.0
        };
        noise[o] = var_y.sqrt();
    }
    let harm_in: f64 = hf.harmonics[0][1..].iter().map(|h| h.norm_sqr()).sum();
    let t0 = rec.t[st.start];
    let third = |j: usize| {
        hf.harmonics[j]
            .get(2)
            .copied()
            .unwrap_or(Complex64::new(0.0, 0.0))
    };
    let ratio = |j: usize, v: f64| v / hf.noise_var[j].max(1e-300);
    let components = SteadyComponents {
        t0,
        t1: rec.t[st.start + st.len - 1],
        samples: st.len,
        omega: w,
        u1: p_in,
        y1: [hf.harmonics[1][0], hf.harmonics[2][0]],
        y3: [third(1), third(2)],
        trend: [hf.trend[1], hf.trend[2]],
        residual_var: [hf.noise_var[1], hf.noise_var[2]],
        input_residual_var: hf.noise_var[0],
        zero_band_omega: {
            let (_, zero) = noise::bin_frequencies(st.len, dt, w, k_max);
            zero.iter().sum::<f64>() / zero.len().max(1) as f64
        },
        colour_raw: [
            (ratio(1, local[0].near_omega), ratio(1, local[0].near_zero)),
            (ratio(2, local[1].near_omega), ratio(2, local[1].near_zero)),
        ],
        colour_bins: [1, 2].map(|j| {
            local[j - 1]
                .near_bins
                .iter()
                .chain(local[j - 1].zero_bins.iter())
                .map(|&(f, p)| (f, ratio(j, p)))
                .collect()
        }),
        colour: [(1.0, 1.0); 2],
        colour3: [1.0; 2],
        inv_diag_h1: hf.inv_diag_h1,
        inv_diag_trend: hf.inv_diag_trend,
    };
    RecordFit {
        index,
        excited: rec.meta.excited,
        omega,
        omega_fit: w,
        amplitude: rec.meta.amplitude,
        input_amplitude: amp_in,
        operating_point: rec.meta.operating_point,
        g,
        sigma,
        distortion,
        input_distortion: harm_in.sqrt() / amp_in,
        third_harmonic_snr: snr3,
        noise_std: noise,
        steady_start_s,
        periods: st.periods,
        excluded: None,
        components: Some(components),
    }
}

/// Analyses every record on `threads` scoped threads, results in record order; the noise's
/// colour is then pooled over the campaign ([`pool_colour`]).
pub fn analyse_records(
    campaign: &Campaign,
    opts: &IdentifyOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Vec<RecordFit> {
    let done = AtomicUsize::new(0);
    let mut fits = parallel_map(campaign.records.len(), worker_count(opts), |k| {
        let fit = analyse_record(&campaign.records[k], k, opts);
        progress(done.fetch_add(1, Ordering::Relaxed) + 1);
        fit
    });
    pool_colour(&mut fits, opts.relative_floor);
    fits
}

/// [`analyse_records`] straight from the campaign folder `dir` (whose manifest is
/// `manifest`): each record is analysed on the thread that read it and its columns are dropped
/// there, so the campaign's data is never all in memory (what `cargo xtask identify` does).
/// The analyses equal those of [`read_campaign`](crate::campaign::read_campaign) followed by
/// [`analyse_records`].
pub fn analyse_folder(
    dir: &std::path::Path,
    manifest: &crate::campaign::Manifest,
    opts: &IdentifyOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<RecordFit>, crate::campaign::CampaignError> {
    let done = AtomicUsize::new(0);
    let mut fits = crate::campaign::map_records(dir, manifest, worker_count(opts), |k, record| {
        let fit = analyse_record(&record, k, opts);
        progress(done.fetch_add(1, Ordering::Relaxed) + 1);
        fit
    })?;
    pool_colour(&mut fits, opts.relative_floor);
    Ok(fits)
}

/// Pools the records' colour estimates over the campaign, per output and by frequency (see
/// `noise`), and updates each record's colour factors and the standard errors of its `g`:
/// with white noise the factors are about 1 and nothing changes; with coloured noise the
/// variances follow the noise where each record sees it.
pub fn pool_colour(records: &mut [RecordFit], relative_floor: f64) {
    use noise::{pool_ratios, ColourSample};
    for i in 0..2 {
        // Every bin of every record, at its own frequency; a bin both beside the excitation
        // and near zero counts once.
        let mut samples: Vec<ColourSample> = Vec::new();
        for c in records.iter().filter_map(|r| r.components.as_ref()) {
            let res = 2.0 * std::f64::consts::PI / (c.t1 - c.t0).max(1e-9);
            let mut seen: Vec<f64> = Vec::new();
            for &(w, ratio) in &c.colour_bins[i] {
                if seen.iter().any(|s| (s - w).abs() < 0.25 * res) {
                    continue;
                }
                seen.push(w);
                samples.push(ColourSample {
                    omega: w,
                    ratio,
                    bins: 1,
                });
            }
        }
        let q_near: Vec<f64> = records
            .iter()
            .map(|r| r.components.as_ref().map_or(f64::NAN, |c| c.omega))
            .collect();
        let q_zero: Vec<f64> = records
            .iter()
            .map(|r| {
                r.components
                    .as_ref()
                    .map_or(f64::NAN, |c| c.zero_band_omega)
            })
            .collect();
        let q_third: Vec<f64> = q_near.iter().map(|w| 3.0 * w).collect();
        let f_near = pool_ratios(&samples, &q_near);
        let f_zero = pool_ratios(&samples, &q_zero);
        let f_third = pool_ratios(&samples, &q_third);
        for (k, r) in records.iter_mut().enumerate() {
            let Some(c) = r.components.as_mut() else {
                continue;
            };
            c.colour[i] = (f_near[k], f_zero[k]);
            c.colour3[i] = f_third[k];
            if r.excluded.is_none() || r.excluded.as_deref() == Some(reason::SATURATED) {
                let amp2 = c.u1.norm_sqr().max(1e-300);
                let u_var = c.input_residual_var * 0.5 * (c.inv_diag_h1[0] + c.inv_diag_h1[1]);
                let var = (c.y1_var(i) + r.g[i].norm_sqr() * u_var) / amp2;
                r.sigma[i] = (var + (relative_floor * r.g[i].norm()).powi(2)).sqrt();
            }
        }
    }
}

/// Worker threads for `opts`: `opts.threads`, else the thread budget ([`crate::par::budget`]:
/// the available cores unless a caller set it).
fn worker_count(opts: &IdentifyOptions) -> usize {
    opts.threads.unwrap_or_else(crate::par::budget).max(1)
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

/// The identification from the records' analyses ([`analyse_records`] or [`analyse_folder`]),
/// in record order, of the campaign named `campaign_name` (`name` in its manifest).
pub fn identify_analysed(
    mut records: Vec<RecordFit>,
    campaign_name: Option<String>,
    opts: &IdentifyOptions,
) -> Result<Identification, IdentifyError> {
    if records.is_empty() {
        return Err(IdentifyError::Empty);
    }
    let mut warnings = Vec::new();
    // Exclusions, grouped by reason.
    let mut by_reason: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for r in &records {
        if let Some(why) = &r.excluded {
            by_reason.entry(why.clone()).or_default().push(r.index);
        }
    }
    for (why, ix) in &by_reason {
        warnings.push(format!("{}: excluded: {why}", name_records(ix)));
    }
    if records.iter().all(|r| r.excluded.is_some()) {
        return Err(IdentifyError::NoUsableRecords(warnings.join("; ")));
    }
    check_frequency_span(&records)?;

    let (wn0, z0) = opts
        .given_bandwidth
        .or_else(|| {
            opts.start_model.as_ref().and_then(|m| {
                Some((
                    m.value("tracking_lowpass", Binding::Axis(Axis::X), "omega_n")?,
                    m.value("tracking_lowpass", Binding::Axis(Axis::X), "zeta")?,
                ))
            })
        })
        .unwrap_or(SEED_BANDWIDTH);
    let factors = start_factors(opts.start_model.as_ref(), &records);

    // Saturation candidates: a significant third harmonic in the directly excited output.
    let candidates: Vec<usize> = if opts.detect_saturation && opts.harmonics >= 3 {
        records
            .iter()
            .filter(|r| r.excluded.is_none())
            .filter(|r| r.third_harmonic_snr[r.excited.index()] > 6.0)
            .filter(|r| {
                // Saturation acts on the largest acceleration demands of an axis: odd
                // harmonics at small demands come from something else (friction, backlash).
                let demand = |q: &RecordFit| {
                    q.amplitude * q.omega * q.omega * fit::lowpass(q.omega, wn0, z0).norm()
                };
                let mut d: Vec<f64> = records
                    .iter()
                    .filter(|q| q.excluded.is_none() && q.excited == r.excited)
                    .map(demand)
                    .collect();
                d.sort_by(f64::total_cmp);
                demand(r) >= d[d.len() / 2]
            })
            .map(|r| r.index)
            .collect()
    } else {
        Vec::new()
    };
    let fit_without = |skip: &[usize]| -> Result<(fit::LmResult, bool, String), IdentifyError> {
        let pts = points(&records, &factors, skip);
        pendulum_fit(&pts, (wn0, z0), opts.fix_bandwidth)
    };
    let (mut lm, mut bw_est, mut bw_note) = fit_without(&candidates)?;
    let mut saturated = Vec::new();
    let mut harmonic_only = Vec::new();
    for &c in &candidates {
        let r = &records[c];
        let j = r.excited.index();
        let gm = fit::model(
            &lm.params,
            &Point {
                i: j,
                j,
                omega: r.omega_fit,
                g: r.g[j],
                sigma: r.sigma[j],
                factor: factors[c][j],
            },
        );
        // Saturation changes the first harmonic: compressed when the clipping is mild relative
        // to the phase lag it adds, expanded towards 4/pi of the limit when the clipped
        // acceleration turns square; either way the gain leaves the linear model's.
        let dev = (r.g[j] - gm).norm() / gm.norm();
        let rel_sigma = r.sigma[j] / gm.norm();
        if dev > (4.0 * rel_sigma).max(0.005) {
            saturated.push(c);
        } else {
            harmonic_only.push(c);
        }
    }
    // Saturation is monotone in the acceleration demand: a record that deviates from the
    // linear model while a record of its axis with a larger demand does not is not saturated
    // (a misfit of the seed's structure, e.g. a delay swallowed by the low-pass, deviates
    // anywhere). Such records (below 70 % of the largest linear demand: a mild clip hides in
    // the noise) stay in the fit.
    let demand_of = |q: &RecordFit| {
        q.amplitude * q.omega * q.omega * fit::lowpass(q.omega, lm.params[8], lm.params[9]).norm()
    };
    let linear_top = |axis: Axis| -> f64 {
        records
            .iter()
            .filter(|q| q.excluded.is_none() && q.excited == axis && !saturated.contains(&q.index))
            .map(demand_of)
            .fold(0.0, f64::max)
    };
    let linear_tops = [linear_top(Axis::X), linear_top(Axis::Y)];
    let (kept, not_monotone): (Vec<usize>, Vec<usize>) = saturated
        .iter()
        .partition(|&&c| demand_of(&records[c]) > 0.7 * linear_tops[records[c].excited.index()]);
    if !not_monotone.is_empty() {
        warnings.push(format!(
            "{}: off the linear model but with smaller acceleration demands than linear records \
             of their axis: not saturation; kept in the fit",
            name_records(&not_monotone)
        ));
        harmonic_only.extend(not_monotone);
        saturated = kept;
    }
    if !harmonic_only.is_empty() {
        let (l2, e2, n2) = fit_without(&saturated)?;
        lm = l2;
        bw_est = e2;
        bw_note = n2;
        warnings.push(format!(
            "{}: significant odd harmonics without gain compression; kept in the fit",
            name_records(&harmonic_only)
        ));
    }
    for &c in &saturated {
        records[c].excluded = Some(reason::SATURATED.to_string());
    }
    let mut p = lm.params;
    let mut saturation = Saturation {
        records: saturated.clone(),
        harmonic_only,
        limit: None,
        limit_stderr: None,
        demanded_acceleration: Vec::new(),
    };
    if !saturated.is_empty() {
        for &c in &saturated {
            let r = &records[c];
            let h = fit::lowpass(r.omega, p[8], p[9]).norm();
            saturation
                .demanded_acceleration
                .push((c, r.amplitude * r.omega * r.omega * h));
        }
        let floor = saturated
            .iter()
            .map(|&c| linear_tops[records[c].excited.index()])
            .fold(f64::INFINITY, f64::min);
        let (limit, se, at_floor) = estimate_limit(
            &records,
            &saturated,
            &p,
            &factors,
            floor,
            worker_count(opts),
        );
        if at_floor {
            // The limit's describing function does not reproduce these records' change: it
            // would need a limit below the demands of records that stay linear. Not
            // saturation as the seed's structure has it; the records go back into the fit.
            warnings.push(format!(
                "{}: odd harmonics and a gain change that an acceleration limit does not \
                 reproduce (it would need a limit below the demands of linear records); kept \
                 in the fit, no limit estimated",
                name_records(&saturated)
            ));
            for &c in &saturated {
                records[c].excluded = None;
            }
            saturation.harmonic_only.extend(saturated.iter().copied());
            saturation.records.clear();
            saturation.demanded_acceleration.clear();
            let pts = points(&records, &factors, &[]);
            let (l2, e2, n2) = pendulum_fit(&pts, (wn0, z0), opts.fix_bandwidth)?;
            lm = l2;
            bw_est = e2;
            bw_note = n2;
            p = lm.params;
            saturated.clear();
        } else {
            saturation.limit = limit;
            saturation.limit_stderr = se;
            warnings.push(format!(
                "{}: acceleration saturation detected{}; left out of the linear fit",
                name_records(&saturated),
                match limit {
                    Some(l) => format!(" (limit about {l:.3} m/s2)"),
                    None => String::new(),
                }
            ));
        }
    }
    let mut delay_alternative = None;
    if lm.dof > 0 && lm.chi2 / lm.dof as f64 > POOR_FIT {
        warnings.push(format!(
            "the pendulum model misfits the data: reduced chi-square {:.1} (about 1 when the \
             model is right). A physical effect the seed's model lacks is likely acting: `cargo \
             xtask diagnose CAMPAIGN --model MODEL` names it with evidence, `cargo xtask loop \
             CAMPAIGN` adds it; until then the standard errors are inflated by the misfit and \
             the uncertainty weights carry it",
            lm.chi2 / lm.dof as f64
        ));
        if bw_est {
            let pts = points(&records, &factors, &saturated);
            if let Some(alt) = delay_alternative_fit(&pts, (wn0, z0), lm.params[8]) {
                if alt.reduced_chi2 < 0.5 * lm.chi2 / lm.dof as f64 {
                    warnings.push(format!(
                        "the tracking low-pass may be absorbing a delay: alone it fits omega_n = \
                         {:.2} rad/s, zeta = {:.3} (reduced chi-square {:.1}); with a pure delay of \
                         {:.1} ms it fits omega_n = {:.2} rad/s, zeta = {:.3} (reduced chi-square \
                         {:.1}). The model file keeps the seed's structure (low-pass only); the \
                         diagnosis tests the delay on held-out records",
                        lm.params[8],
                        lm.params[9],
                        lm.chi2 / lm.dof as f64,
                        alt.delay_s * 1e3,
                        alt.omega_n,
                        alt.zeta,
                        alt.reduced_chi2
                    ));
                }
                delay_alternative = Some(alt);
            }
        }
    }
    if !bw_est {
        warnings.push(bw_note.clone());
    }

    let param = |name: String, k: usize| Parameter {
        name,
        value: p[k],
        stderr: lm.stderr[k],
        estimated: true,
    };
    let names = ["11", "12", "21", "22"];
    let a = [
        [
            param(format!("pendulum.a{}", names[0]), 0),
            param(format!("pendulum.a{}", names[1]), 1),
        ],
        [
            param(format!("pendulum.a{}", names[2]), 2),
            param(format!("pendulum.a{}", names[3]), 3),
        ],
    ];
    let b = [
        [
            param(format!("pendulum.b{}", names[0]), 4),
            param(format!("pendulum.b{}", names[1]), 5),
        ],
        [
            param(format!("pendulum.b{}", names[2]), 6),
            param(format!("pendulum.b{}", names[3]), 7),
        ],
    ];
    let bandwidth = Bandwidth {
        omega_n: p[8],
        zeta: p[9],
        omega_n_stderr: if bw_est { lm.stderr[8] } else { 0.0 },
        zeta_stderr: if bw_est { lm.stderr[9] } else { 0.0 },
        estimated: bw_est,
        note: bw_note,
    };
    let uncertainty = uncertainty_database(&records, &p, &factors);
    let mut ident = Identification {
        campaign_name,
        records,
        a,
        b,
        bandwidth,
        saturation,
        uncertainty,
        reduced_chi2: if lm.dof > 0 {
            lm.chi2 / lm.dof as f64
        } else {
            f64::NAN
        },
        warnings,
        delay_alternative,
        model: ModelSpec {
            name: None,
            description: None,
            effects: Vec::new(),
            provenance: toml::Table::new(),
            stderr: toml::Table::new(),
        },
    };
    ident.model = build_model(&ident, opts)?;
    Ok(ident)
}

fn check_frequency_span(records: &[RecordFit]) -> Result<(), IdentifyError> {
    let mut problems = Vec::new();
    for axis in Axis::BOTH {
        let recs: Vec<&RecordFit> = records
            .iter()
            .filter(|r| r.excluded.is_none() && r.excited == axis)
            .collect();
        if recs.is_empty() {
            problems.push(format!(
                "no usable record excites {axis}_cr, so G1{0} and G2{0} cannot be identified",
                axis.index() + 1
            ));
            continue;
        }
        let mut w: Vec<f64> = recs.iter().map(|r| r.omega).collect();
        w.sort_by(|a, b| a.total_cmp(b));
        w.dedup_by(|a, b| (*a / *b - 1.0).abs() < 1e-6);
        let span = w[w.len() - 1] / w[0];
        if w.len() < 3 || span < 2.0 {
            let ix: Vec<usize> = recs.iter().map(|r| r.index).collect();
            problems.push(format!(
                "the usable records exciting {axis}_cr ({}) span {} distinct frequencies over a \
                 factor {span:.2} ({:.3}..{:.3} rad/s): a and b of G1{n} and G2{n} cannot be \
                 separated; at least 3 frequencies spanning a factor 2 are needed, ideally up to \
                 where b w^2 dominates a",
                name_records(&ix),
                w.len(),
                w[0],
                w[w.len() - 1],
                n = axis.index() + 1
            ));
        }
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(IdentifyError::FrequencySpan(problems.join("; ")))
    }
}

/// The fixed complex factor of the start model's extra linear effects, per record and output.
fn start_factors(start: Option<&ModelSpec>, records: &[RecordFit]) -> Vec<[Complex64; 2]> {
    let one = [Complex64::new(1.0, 0.0); 2];
    let Some(spec) = start else {
        return vec![one; records.len()];
    };
    let Ok(mut plant) = Plant::new(spec, zmp_models::DEFAULT_STEP) else {
        return vec![one; records.len()];
    };
    let lp = |a: Axis| *plant.tracking_lowpass(a);
    let pend = *plant.pendulum();
    let lps = [lp(Axis::X), lp(Axis::Y)];
    records
        .iter()
        .map(|r| {
            if r.excluded.is_some() {
                return one;
            }
            plant.set_operating_point([0.0, 0.0]);
            let j = r.excited.index();
            plant.set_operating_point(r.operating_point);
            let full = plant.frequency_response(r.omega);
            let mut f = one;
            for i in 0..2 {
                let ch = Channel {
                    output: Axis::from_index(i).expect("0 or 1"),
                    input: r.excited,
                };
                let core = pend.response(ch, r.omega) * lps[j].freq(r.omega);
                if core.norm() > 0.0 {
                    f[i] = full[i][j] / core;
                }
            }
            f
        })
        .collect()
}

fn points(records: &[RecordFit], factors: &[[Complex64; 2]], skip: &[usize]) -> Vec<Point> {
    let mut pts = Vec::new();
    for r in records {
        if r.excluded.is_some() || skip.contains(&r.index) {
            continue;
        }
        for i in 0..2 {
            if r.sigma[i] > 0.0 && r.g[i].re.is_finite() && r.g[i].im.is_finite() {
                pts.push(Point {
                    i,
                    j: r.excited.index(),
                    omega: r.omega_fit,
                    g: r.g[i],
                    sigma: r.sigma[i],
                    factor: factors[r.index][i],
                });
            }
        }
    }
    pts
}

/// Steps 4-5: returns the fit, whether the bandwidth was estimated, and a note.
fn pendulum_fit(
    pts: &[Point],
    (wn0, z0): (f64, f64),
    fix: bool,
) -> Result<(fit::LmResult, bool, String), IdentifyError> {
    if pts.is_empty() {
        return Err(IdentifyError::FitFailed("no data points".into()));
    }
    let all: Vec<usize> = (0..NP).collect();
    let core: Vec<usize> = (0..8).collect();
    let start = fit::linear_start(pts, wn0, z0);
    let fixed = fit::levenberg_marquardt(start, pts, &core);
    if fix {
        return Ok((
            fixed,
            false,
            format!("tracking low-pass given (omega_n = {wn0} rad/s, zeta = {z0}), not estimated"),
        ));
    }
    // Parameter `k` of a fit is determined: finite, in its plausible range, relative standard
    // error below 25 %.
    let determined = |lm: &fit::LmResult, k: usize, (lo, hi): (f64, f64)| {
        lm.params.iter().all(|v| v.is_finite())
            && lm.params[k] > lo
            && lm.params[k] < hi
            && lm.stderr[k] / lm.params[k] < 0.25
    };
    const WN_RANGE: (f64, f64) = (0.5, 1e4);
    let free = fit::levenberg_marquardt(fixed.params, pts, &all);
    let p = free.params;
    if determined(&free, 8, WN_RANGE) && determined(&free, 9, (0.01, 100.0)) {
        let note = format!(
            "tracking low-pass estimated from the data: omega_n = {:.2} +- {:.2} rad/s, zeta = \
             {:.3} +- {:.3}",
            p[8], free.stderr[8], p[9], free.stderr[9]
        );
        return Ok((free, true, note));
    }
    // A band that ends well below omega_n determines the low-pass's phase lag, about
    // 2 zeta w / omega_n, but not omega_n and zeta apart: fit omega_n with zeta held, and keep it
    // when it is determined and the likelihood-ratio test prefers it to the given low-pass
    // (chi-square drop above 10.83, p = 0.001 for one parameter, in units of the reduced
    // chi-square when the fit is worse than its noise).
    let mut with_wn = core.clone();
    with_wn.push(8);
    let one = fit::levenberg_marquardt(fixed.params, pts, &with_wn);
    let scale = if one.dof > 0 {
        (one.chi2 / one.dof as f64).max(1.0)
    } else {
        f64::INFINITY
    };
    let wn = one.params[8];
    if determined(&one, 8, WN_RANGE) && (fixed.chi2 - one.chi2) / scale > LIKELIHOOD_RATIO_1DOF {
        let note = format!(
            "tracking low-pass: omega_n = {:.2} +- {:.2} rad/s estimated from the data with \
             zeta held at {z0} (the data determine the phase lag, not omega_n and zeta apart: \
             both free gave omega_n = {:.3e} +- {:.1e}, zeta = {:.3e} +- {:.1e}); the errors of \
             a, b do not include zeta's uncertainty",
            wn, one.stderr[8], p[8], free.stderr[8], p[9], free.stderr[9]
        );
        Ok((one, true, note))
    } else {
        Ok((
            fixed,
            false,
            format!(
                "the data do not determine the tracking low-pass (estimate omega_n = {:.3e} +- \
                 {:.1e} rad/s, zeta = {:.3e} +- {:.1e}); the given omega_n = {wn0} rad/s, zeta = \
                 {z0} are used (set them with --bandwidth WN,ZETA), and the errors of a, b do \
                 not include their uncertainty",
                p[8], free.stderr[8], p[9], free.stderr[9]
            ),
        ))
    }
}

/// Step 6: the acceleration limit that makes the servo's describing function match the
/// saturated records; golden-section search on `log(limit)`.
fn estimate_limit(
    records: &[RecordFit],
    sat: &[usize],
    p: &[f64; NP],
    factors: &[[Complex64; 2]],
    linear_demand: f64,
    threads: usize,
) -> (Option<f64>, Option<f64>, bool) {
    let info = zmp_models::lookup("acceleration_saturation").expect("registered effect");
    let h = zmp_models::DEFAULT_STEP;
    let ctx = BuildContext {
        h,
        binding: Binding::Axis(Axis::X),
        servo: Some((p[8], p[9])),
        link: None,
    };
    let demand: Vec<f64> = sat
        .iter()
        .map(|&c| {
            let r = &records[c];
            r.amplitude * r.omega * r.omega * fit::lowpass(r.omega, p[8], p[9]).norm()
        })
        .collect();
    let top = demand.iter().cloned().fold(0.0, f64::max);
    if top.is_nan() || top <= 0.0 {
        return (None, None, false);
    }
    // Distinct (omega, amplitude) pairs share a describing function.
    let mut keys: Vec<(f64, f64)> = Vec::new();
    for &c in sat {
        let k = (records[c].omega, records[c].amplitude);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    // The describing function of the limit at each key is the servo's first harmonic with the
    // limit over the linear servo's (what `frequency_response` of the effect computes); the
    // linear runs do not depend on the limit, so they are done once, and the runs of one
    // evaluation are shared out over the worker threads (each one is a long simulation).
    // A saturated servo settles slowly from rest, so each run of the search starts from the
    // periodic orbit of the search's previous limit (the linear orbit for the first).
    let starts: Mutex<Vec<Option<PeriodStart>>> = Mutex::new(vec![None; keys.len()]);
    let first_harmonics = |limit: Option<f64>, keep_orbit: bool| -> Vec<Complex64> {
        let from = starts.lock().unwrap_or_else(|p| p.into_inner()).clone();
        let run = |k: usize| {
            let (w, a) = keys[k];
            let mut limits: Vec<Box<dyn zmp_models::Effect>> =
                limit.iter().map(|&l| (info.build)(&ctx, &[l])).collect();
            servo_first_harmonic_from(p[8], p[9], h, &mut limits, w, a, from[k])
        };
        let out = parallel_map(keys.len(), threads, run);
        if keep_orbit {
            *starts.lock().unwrap_or_else(|p| p.into_inner()) =
                out.iter().map(|o| Some(o.1)).collect();
        }
        out.into_iter().map(|o| o.0).collect()
    };
    let linear = first_harmonics(None, true);
    // `keep_orbit`: the search's own evaluations pass their orbit on; the two curvature points,
    // evaluated at once, start from the search's last and leave it alone (deterministic).
    let chi2 = |limit: f64, keep_orbit: bool| -> f64 {
        let nf: Vec<Complex64> = first_harmonics(Some(limit), keep_orbit)
            .iter()
            .zip(&linear)
            .map(|(with, without)| with / without)
            .collect();
        let mut s = 0.0;
        for &c in sat {
            let r = &records[c];
            let k = keys
                .iter()
                .position(|&k| k == (r.omega, r.amplitude))
                .expect("key");
            for i in 0..2 {
                let gm = fit::model(
                    p,
                    &Point {
                        i,
                        j: r.excited.index(),
                        omega: r.omega_fit,
                        g: r.g[i],
                        sigma: r.sigma[i],
                        factor: factors[c][i],
                    },
                ) * nf[k];
                s += (r.g[i] - gm).norm_sqr() / r.sigma[i].powi(2);
            }
        }
        s
    };
    // Brent's minimisation over log(limit), to within 1e-4 (relative) of the limit: each
    // evaluation is a long saturated simulation, and parabolic steps need fewer of them than
    // golden sections alone.
    // The limit lies near or above the demands of the axis's records that stay linear (a
    // mild clip deviates less than the noise).
    let lo = (0.05 * top).max(0.7 * linear_demand.min(top));
    let (x, c0) = brent_minimise(lo.ln(), (1.2 * top).ln(), 5e-5, 60, |x| chi2(x.exp(), true));
    let l = x.exp();
    // Standard error from the curvature of chi-square, scaled by the reduced chi-square (the
    // two side evaluations at once).
    let d = 0.01 * l;
    let side = parallel_map(2, threads, |i| {
        chi2(if i == 0 { l - d } else { l + d }, false)
    });
    let (cm, cp) = (side[0], side[1]);
    let curv = (cm - 2.0 * c0 + cp) / (d * d);
    let dof = (2 * sat.len()).saturating_sub(1).max(1) as f64;
    let se = if curv > 0.0 {
        Some((2.0 / curv * (c0 / dof).max(1.0)).sqrt())
    } else {
        None
    };
    // A minimum on the search's lower end: the data ask for a limit below the linear demands.
    let at_floor = linear_demand.is_finite() && linear_demand > 0.0 && l <= 1.01 * lo;
    (Some(l), se, at_floor)
}

/// Brent's method: a minimum of `f` on `[a, b]` to within about `2 tol` (absolute), and `f`
/// there, by
/// parabolic interpolation through the best three points where that step is safe and golden
/// sections otherwise (Brent 1973, "Algorithms for Minimization without Derivatives", ch. 5).
fn brent_minimise(
    mut a: f64,
    mut b: f64,
    tol: f64,
    max_evals: usize,
    f: impl Fn(f64) -> f64,
) -> (f64, f64) {
    const CGOLD: f64 = 0.381_966_011_250_105_1; // (3 - sqrt 5) / 2
    let mut x = a + CGOLD * (b - a);
    let (mut w, mut v) = (x, x);
    let mut fx = f(x);
    let (mut fw, mut fv) = (fx, fx);
    // The last step and the one before it.
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 1..max_evals {
        let xm = 0.5 * (a + b);
        if (x - xm).abs() <= 2.0 * tol - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol {
            // Parabola through (x, fx), (w, fw), (v, fv): its minimum at x + p / q.
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            // Accept it if it lies inside [a, b] and moves less than half the step before last.
            if p.abs() < (0.5 * q * e).abs() && p > q * (a - x) && p < q * (b - x) {
                e = d;
                d = p / q;
                let u = x + d;
                if u - a < 2.0 * tol || b - u < 2.0 * tol {
                    d = tol.copysign(xm - x);
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= xm { a - x } else { b - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol {
            x + d
        } else {
            x + tol.copysign(d)
        };
        let fu = f(u);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, fv) = (w, fw);
            (w, fw) = (x, fx);
            (x, fx) = (u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv) = (w, fw);
                (w, fw) = (u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (x, fx)
}

/// Step 7: the uncertainty database and the weights.
fn uncertainty_database(
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

/// `YYYY-MM-DDTHH:MM:SSZ` from the system clock.
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

fn fl(v: f64) -> toml::Value {
    toml::Value::Float(v)
}

/// Step 8: the model file.
fn build_model(ident: &Identification, opts: &IdentifyOptions) -> Result<ModelSpec, IdentifyError> {
    let mut spec = match &opts.start_model {
        Some(m) => m.clone(),
        None => ModelSpec::parse(
            include_str!("../../models/params/silo2-paper.toml"),
            "silo2-paper.toml",
        )
        .map_err(|e| IdentifyError::FitFailed(e.to_string()))?,
    };
    let name = ident.campaign_name.as_deref().unwrap_or("campaign");
    spec.name = Some(format!("identified from {name}"));
    spec.description = Some(format!(
        "Identified by zmp-validation {} (first seed, section 5) from {} of {} records; \
         uncertainty delta = 0 (nominal).",
        env!("CARGO_PKG_VERSION"),
        ident.used().count(),
        ident.records.len()
    ));
    let fail = |what: &str| IdentifyError::FitFailed(format!("cannot set {what} in the model"));
    let mut se_pend = toml::Table::new();
    for (m, letter) in [(&ident.a, 'a'), (&ident.b, 'b')] {
        for (i, row) in m.iter().enumerate() {
            for (j, prm) in row.iter().enumerate() {
                let key = format!("{letter}{}{}", i + 1, j + 1);
                // A structure without a coupling channel (both terms zero in the model given)
                // keeps it out.
                let absent = i != j
                    && opts.start_model.as_ref().is_some_and(|m| {
                        ["a", "b"].iter().all(|l| {
                            m.value(
                                "pendulum",
                                Binding::Global,
                                &format!("{l}{}{}", i + 1, j + 1),
                            ) == Some(0.0)
                        })
                    });
                if absent {
                    continue;
                }
                if !spec.set_value("pendulum", Binding::Global, &key, prm.value) {
                    return Err(fail(&key));
                }
                se_pend.insert(key, fl(prm.stderr));
            }
        }
    }
    let lp = zmp_models::lookup("tracking_lowpass").expect("registered");
    for axis in Axis::BOTH {
        spec.insert(EffectInstance {
            info: lp,
            binding: Binding::Axis(axis),
            values: vec![ident.bandwidth.omega_n, ident.bandwidth.zeta],
        });
    }
    let unc = zmp_models::lookup("uncertainty").expect("registered");
    let mut se_unc = toml::Table::new();
    for (ch, cu) in Channel::ALL.iter().zip(&ident.uncertainty) {
        let (k, z, p) = cu.weight;
        spec.insert(EffectInstance {
            info: unc,
            binding: Binding::Channel(*ch),
            values: vec![k, z, p, 0.0, 0.0],
        });
        let _ = &mut se_unc;
    }
    let mut stderr = toml::Table::new();
    stderr.insert("pendulum".into(), toml::Value::Table(se_pend));
    if ident.bandwidth.estimated {
        let mut t = toml::Table::new();
        t.insert("omega_n".into(), fl(ident.bandwidth.omega_n_stderr));
        t.insert("zeta".into(), fl(ident.bandwidth.zeta_stderr));
        stderr.insert("tracking_lowpass".into(), toml::Value::Table(t));
    }
    let wants_limit = opts.include_saturation
        || opts
            .start_model
            .as_ref()
            .is_some_and(|m| m.has("acceleration_saturation"));
    if let (Some(l), true) = (ident.saturation.limit, wants_limit) {
        let sat = zmp_models::lookup("acceleration_saturation").expect("registered");
        for axis in Axis::BOTH {
            // The limit is identified; a start model's other saturation parameters (its
            // passive damping) are kept, as its other effects are.
            let mut values = vec![l.clamp(1e-3, 1e3)];
            if let Some(start) = opts.start_model.as_ref().and_then(|m| {
                m.effects.iter().find(|e| {
                    e.info.kind == "acceleration_saturation" && e.binding == Binding::Axis(axis)
                })
            }) {
                values.extend(start.values.iter().skip(1));
            }
            spec.insert(EffectInstance {
                info: sat,
                binding: Binding::Axis(axis),
                values,
            });
        }
        if let Some(se) = ident.saturation.limit_stderr {
            let mut t = toml::Table::new();
            t.insert("limit".into(), fl(se));
            stderr.insert("acceleration_saturation".into(), toml::Value::Table(t));
        }
    }
    spec.stderr = stderr;
    let mut prov = toml::Table::new();
    prov.insert("campaign".into(), toml::Value::String(name.to_owned()));
    if let Some(p) = &opts.campaign_path {
        prov.insert(
            "campaign_path".into(),
            toml::Value::String(p.display().to_string()),
        );
    }
    let used = ident.used().count();
    prov.insert(
        "records".into(),
        toml::Value::Integer(ident.records.len() as i64),
    );
    prov.insert("records_used".into(), toml::Value::Integer(used as i64));
    prov.insert(
        "records_excluded".into(),
        toml::Value::Integer((ident.records.len() - used) as i64),
    );
    prov.insert("date".into(), toml::Value::String(utc_now()));
    prov.insert(
        "tool".into(),
        toml::Value::String(format!(
            "zmp-validation {} identify",
            env!("CARGO_PKG_VERSION")
        )),
    );
    prov.insert(
        "harmonics".into(),
        toml::Value::Integer(opts.harmonics as i64),
    );
    prov.insert("reduced_chi2".into(), fl(ident.reduced_chi2));
    prov.insert(
        "bandwidth".into(),
        toml::Value::String(if ident.bandwidth.estimated {
            "estimated".into()
        } else {
            "given".into()
        }),
    );
    spec.provenance = prov;
    spec.validate("identified model")
        .map_err(|e| IdentifyError::FitFailed(format!("the identified model is invalid: {e}")))?;
    Ok(spec)
}

/// Writes the model file atomically; an existing file needs `force`.
pub fn write_model(
    ident: &Identification,
    path: &std::path::Path,
    force: bool,
) -> anyhow::Result<()> {
    crate::io::atomic_write(path, ident.model.to_toml().as_bytes(), force)
}

/// A JSON summary: parameters with standard errors, excluded records, warnings.
pub fn summary_json(ident: &Identification) -> serde_json::Value {
    let excluded: Vec<serde_json::Value> = ident
        .records
        .iter()
        .filter_map(|r| {
            r.excluded
                .as_ref()
                .map(|w| serde_json::json!({"record": r.index, "reason": w}))
        })
        .collect();
    serde_json::json!({
        "campaign": ident.campaign_name,
        "records": ident.records.len(),
        "records_used": ident.used().count(),
        "parameters": ident.parameters(),
        "bandwidth": ident.bandwidth,
        "saturation": ident.saturation,
        "uncertainty": ident.uncertainty,
        "reduced_chi2": ident.reduced_chi2,
        "poor_fit": ident.reduced_chi2 > POOR_FIT,
        "delay_alternative": ident.delay_alternative,
        "excluded": excluded,
        "warnings": ident.warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use zmp_models::effects::servo::servo_first_harmonic;

    /// `estimate_limit` splits the effect's describing function into a run with the limit and
    /// a linear run it does once: the ratio must be the effect's own `frequency_response`.
    #[test]
    fn limit_runs_match_the_effects_describing_function() {
        let info = zmp_models::lookup("acceleration_saturation").expect("registered effect");
        let h = zmp_models::DEFAULT_STEP;
        let (wn, zeta) = (28.0, 0.9);
        let ctx = BuildContext {
            h,
            binding: Binding::Axis(Axis::X),
            servo: Some((wn, zeta)),
            link: None,
        };
        for (limit, w, a) in [(1.2, 6.0, 0.05), (0.8, 12.0, 0.02), (3.0, 2.0, 0.01)] {
            let e = (info.build)(&ctx, &[limit]);
            let mut limits = vec![(info.build)(&ctx, &[limit])];
            let with = servo_first_harmonic(wn, zeta, h, &mut limits, w, a);
            let without = servo_first_harmonic(wn, zeta, h, &mut [], w, a);
            // Equal up to rounding: the effect computes its linear run at unit amplitude.
            let (df, own) = (with / without, e.frequency_response(w, a));
            assert!((df - own).norm() <= 1e-12 * own.norm(), "{df} vs {own}");
        }
    }

    #[test]
    fn brent_finds_minima() {
        let calls = std::cell::Cell::new(0);
        let f = |x: f64| {
            calls.set(calls.get() + 1);
            (x - 0.3).powi(2) * (1.0 + 0.5 * x.sin()) + 2.0
        };
        let (x, _) = brent_minimise(-3.0, 3.0, 5e-5, 60, f);
        assert!((x - 0.3).abs() < 2e-4, "{x}");
        assert!(calls.get() < 20, "{} evaluations", calls.get());
        // A minimum at the end of the interval and a flat function.
        let (x, _) = brent_minimise(0.0, 1.0, 5e-5, 60, |x| -x);
        assert!(x > 1.0 - 2e-4, "{x}");
        let (x, _) = brent_minimise(0.0, 1.0, 5e-5, 60, |_| 1.0);
        assert!((0.0..=1.0).contains(&x));
    }
}
