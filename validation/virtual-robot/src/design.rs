//! The experiment design: which stepped-sine records a campaign holds and how they are timed,
//! sampled and disturbed; read from a design file with errors that name the file and field.

use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use zmp_campaign::RecordMeta;
use zmp_models::Axis;

/// What to run: every operating point × amplitude × frequency × excited channel (the grid
/// form), or the records listed one by one (the list form, `[[records]]`: what `cargo xtask
/// design-next` writes). A design has one form or the other.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentDesign {
    /// Campaign name written to `campaign.toml`.
    #[serde(default = "default_name")]
    pub name: String,
    /// Constant CoM references `[x, y]` the sines oscillate around, m (grid form).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub operating_points: Vec<[f64; 2]>,
    /// Sine amplitudes of the excited reference, m (grid form).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub amplitudes: Vec<f64>,
    /// Excitation frequencies, rad/s (grid form).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub omegas: Vec<f64>,
    /// Excited reference channels (grid form).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub excited: Vec<Axis>,
    /// The records one by one, in campaign order (list form).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub records: Vec<ListedRecord>,
    /// Data sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Seconds recorded from the start of the excitation before the steady state is expected.
    pub transient_s: f64,
    /// Whole periods recorded after the transient.
    pub periods: u32,
    /// Least steady-state length, s (high frequencies get more periods).
    pub min_steady_s: f64,
    /// Standard deviation of the white ZMP sensor noise, m.
    pub zmp_noise_std: f64,
    /// ZMP sensor resolution, m (0: none).
    pub quantisation: f64,
    /// Noise seed.
    pub seed: u64,
    /// Internal step of the plant, s.
    #[serde(default = "default_step")]
    pub internal_step: f64,
    /// Also write the true CoM as extra columns `x_c`, `y_c`.
    #[serde(default)]
    pub record_com: bool,
}

/// One record of a design in the list form.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ListedRecord {
    /// The excited reference channel.
    pub excited: Axis,
    /// Excitation frequency, rad/s.
    pub omega: f64,
    /// Sine amplitude of the excited reference, m.
    pub amplitude: f64,
    /// Constant CoM references `[x, y]` the sine oscillates around, m.
    pub operating_point: [f64; 2],
}

fn default_name() -> String {
    "virtual".into()
}

fn default_step() -> f64 {
    zmp_models::DEFAULT_STEP
}

impl ExperimentDesign {
    /// The reference campaign: 3 operating points × 2 amplitudes (3 and 8 mm) × 14 frequencies
    /// from 0.5 to 15 rad/s × 2 excited channels at 200 Hz, 0.5 mm ZMP noise, 0.1 mm resolution.
    pub fn reference() -> ExperimentDesign {
        ExperimentDesign {
            name: "virtual-silo2".into(),
            operating_points: vec![[0.0, 0.0], [0.02, 0.0], [0.0, 0.02]],
            amplitudes: vec![0.003, 0.008],
            omegas: zmp_models::logspace(0.5, 15.0, 14),
            excited: vec![Axis::X, Axis::Y],
            records: Vec::new(),
            sample_rate_hz: 200.0,
            transient_s: 3.0,
            periods: 4,
            min_steady_s: 8.0,
            zmp_noise_std: 0.0005,
            quantisation: 0.0001,
            seed: 1,
            internal_step: zmp_models::DEFAULT_STEP,
            record_com: false,
        }
    }

    /// Record metadata in campaign order: the list form's order, or for the grid operating
    /// point, amplitude, excited channel, frequency.
    pub fn records(&self) -> Vec<RecordMeta> {
        if !self.records.is_empty() {
            return self
                .records
                .iter()
                .enumerate()
                .map(|(k, r)| RecordMeta {
                    file: PathBuf::from(format!("records/r{k:03}.csv")),
                    excited: r.excited,
                    omega: r.omega,
                    amplitude: r.amplitude,
                    operating_point: r.operating_point,
                })
                .collect();
        }
        let mut out = Vec::new();
        for op in &self.operating_points {
            for &amplitude in &self.amplitudes {
                for &excited in &self.excited {
                    for &omega in &self.omegas {
                        let k = out.len();
                        out.push(RecordMeta {
                            file: PathBuf::from(format!("records/r{k:03}.csv")),
                            excited,
                            omega,
                            amplitude,
                            operating_point: *op,
                        });
                    }
                }
            }
        }
        out
    }

    /// Reads a design file's text (TOML); every error names `file` and the field.
    pub fn from_toml(text: &str, file: &str) -> Result<ExperimentDesign, String> {
        let d: ExperimentDesign = toml::from_str(text).map_err(|e| {
            // The parser's message names the key (or quotes its line) and where it is.
            format!("{file}: {}", e.to_string().trim_end())
        })?;
        d.check().map_err(|e| format!("{file}: {e}"))?;
        Ok(d)
    }

    /// Rows of a record at `omega`: transient plus whole steady periods, sampled.
    fn rows_at(&self, omega: f64) -> f64 {
        let period = 2.0 * std::f64::consts::PI / omega;
        let steady = (self.periods as f64 * period).max(self.min_steady_s);
        let steady = (steady / period).ceil() * period;
        ((self.transient_s + steady) * self.sample_rate_hz).round() + 1.0
    }

    /// Checks the design makes sense: every number finite and in its range, every list
    /// non-empty and bounded, and the campaign no larger than [`MAX_RECORD_ROWS`] rows per
    /// record, [`MAX_CAMPAIGN_ROWS`] in all and [`MAX_INTERNAL_STEPS`] plant steps. The message
    /// starts with the field.
    pub fn check(&self) -> Result<(), String> {
        self.check_scalars()?;
        self.check_records()?;
        let steps_per_sample = self.check_sampling()?;
        self.check_sizes(steps_per_sample)
    }

    /// The name's length, the sampling, timing, noise and quantisation ranges, the periods.
    fn check_scalars(&self) -> Result<(), String> {
        if self.name.len() > 1000 {
            return Err(format!(
                "name is {} bytes long; at most 1000",
                self.name.len()
            ));
        }
        in_range(
            "sample_rate_hz",
            self.sample_rate_hz,
            0.0,
            MAX_SAMPLE_RATE_HZ,
            true,
        )?;
        in_range("internal_step", self.internal_step, 0.0, 0.1, true)?;
        in_range("transient_s", self.transient_s, 0.0, MAX_DURATION_S, false)?;
        in_range(
            "min_steady_s",
            self.min_steady_s,
            0.0,
            MAX_DURATION_S,
            false,
        )?;
        in_range("zmp_noise_std", self.zmp_noise_std, 0.0, 1.0, false)?;
        in_range("quantisation", self.quantisation, 0.0, 1.0, false)?;
        if self.periods == 0 || self.periods > MAX_PERIODS {
            return Err(format!(
                "periods = {}: must be a whole number from 1 to {MAX_PERIODS}",
                self.periods
            ));
        }
        Ok(())
    }

    /// The grid (operating points, amplitudes, frequencies below Nyquist, excited axes) or
    /// the listed records, not both; every entry in its range.
    fn check_records(&self) -> Result<(), String> {
        let grid = !(self.operating_points.is_empty()
            && self.amplitudes.is_empty()
            && self.omegas.is_empty()
            && self.excited.is_empty());
        if grid && !self.records.is_empty() {
            return Err(
                "records: a design lists its records ([[records]]) or gives the grid \
                 (operating_points, amplitudes, omegas, excited), not both"
                    .into(),
            );
        }
        let nyquist = std::f64::consts::PI * self.sample_rate_hz;
        if self.records.is_empty() {
            list_length("operating_points", self.operating_points.len())?;
            for (k, op) in self.operating_points.iter().enumerate() {
                check_operating_point(&format!("operating_points[{k}]"), op)?;
            }
            list_length("amplitudes", self.amplitudes.len())?;
            for (k, a) in self.amplitudes.iter().enumerate() {
                in_range(&format!("amplitudes[{k}]"), *a, 0.0, 1.0, true)?;
            }
            list_length("omegas", self.omegas.len())?;
            for (k, w) in self.omegas.iter().enumerate() {
                below_nyquist(&format!("omegas[{k}]"), *w, nyquist)?;
            }
            list_length("excited", self.excited.len())?;
            if self.excited.len() > 2
                || (self.excited.len() == 2 && self.excited[0] == self.excited[1])
            {
                return Err("excited must name each of \"x\", \"y\" at most once".into());
            }
        } else {
            if self.records.len() > MAX_RECORDS {
                return Err(format!(
                    "records has {} entries; at most {MAX_RECORDS}",
                    self.records.len()
                ));
            }
            for (k, r) in self.records.iter().enumerate() {
                check_operating_point(
                    &format!("records[{k}].operating_point"),
                    &r.operating_point,
                )?;
                in_range(
                    &format!("records[{k}].amplitude"),
                    r.amplitude,
                    0.0,
                    1.0,
                    true,
                )?;
                below_nyquist(&format!("records[{k}].omega"), r.omega, nyquist)?;
            }
        }
        Ok(())
    }

    /// The sample period must be a whole number of internal steps; that number.
    fn check_sampling(&self) -> Result<f64, String> {
        let dt = 1.0 / self.sample_rate_hz;
        let ratio = dt / self.internal_step;
        if (ratio - ratio.round()).abs() > 1e-9 * ratio.max(1.0) || ratio.round() < 1.0 {
            return Err(format!(
                "sample_rate_hz: the sample period {dt} s must be a whole number of internal \
                 steps (internal_step = {} s)",
                self.internal_step
            ));
        }
        Ok(ratio.round())
    }

    /// Sizes: a record's rows, the campaign's rows and the plant steps (`steps_per_sample`
    /// per row), before anything is allocated.
    fn check_sizes(&self, steps_per_sample: f64) -> Result<(), String> {
        // Per frequency, how many records are at it.
        let (sizes, fields): (Vec<(f64, f64)>, &str) = if self.records.is_empty() {
            let per_set =
                (self.operating_points.len() * self.amplitudes.len() * self.excited.len()) as f64;
            (
                self.omegas.iter().map(|w| (*w, per_set)).collect(),
                "operating_points, amplitudes, excited, omegas",
            )
        } else {
            (
                self.records.iter().map(|r| (r.omega, 1.0)).collect(),
                "records",
            )
        };
        let records: f64 = sizes.iter().map(|s| s.1).sum();
        if records > MAX_RECORDS as f64 {
            return Err(format!(
                "{fields}: {records} records; at most {MAX_RECORDS}"
            ));
        }
        let mut total_rows = 0.0;
        for (k, (w, count)) in sizes.iter().enumerate() {
            let rows = self.rows_at(*w);
            if rows > MAX_RECORD_ROWS as f64 {
                let at = if self.records.is_empty() {
                    format!("omegas[{k}]")
                } else {
                    format!("records[{k}].omega")
                };
                return Err(format!(
                    "transient_s, min_steady_s, periods: a record at {at} = {w} rad/s \
                     would have {rows:.3e} rows; at most {MAX_RECORD_ROWS:.0e}"
                ));
            }
            total_rows += rows * count;
        }
        if total_rows > MAX_CAMPAIGN_ROWS as f64 {
            return Err(format!(
                "{fields}: the campaign would have {total_rows:.3e} rows; at most \
                 {MAX_CAMPAIGN_ROWS:.0e}"
            ));
        }
        let steps = total_rows * steps_per_sample;
        if steps > MAX_INTERNAL_STEPS as f64 {
            return Err(format!(
                "internal_step = {} s: the campaign would take {steps:.3e} plant steps; at most \
                 {MAX_INTERNAL_STEPS:.0e}",
                self.internal_step
            ));
        }
        Ok(())
    }
}

/// `v` must be finite and in `(lo, hi]` (`lo_open`) or `[lo, hi]`; the message names `name`.
fn in_range(name: &str, v: f64, lo: f64, hi: f64, lo_open: bool) -> Result<(), String> {
    let above = if lo_open { v > lo } else { v >= lo };
    if v.is_finite() && above && v <= hi {
        Ok(())
    } else {
        let open = if lo_open { "(" } else { "[" };
        Err(format!(
            "{name} = {v}: must be a finite number in {open}{lo}, {hi}]"
        ))
    }
}

/// A list of `n` entries must hold 1 to [`MAX_LIST`].
fn list_length(name: &str, n: usize) -> Result<(), String> {
    if n == 0 {
        Err(format!("{name} is empty"))
    } else if n > MAX_LIST {
        Err(format!("{name} has {n} entries; at most {MAX_LIST}"))
    } else {
        Ok(())
    }
}

/// A frequency `w` (rad/s) must be positive and below the Nyquist frequency `nyquist` (rad/s).
fn below_nyquist(name: &str, w: f64, nyquist: f64) -> Result<(), String> {
    if w.is_finite() && w > 0.0 && w < nyquist {
        Ok(())
    } else {
        Err(format!(
            "{name} = {w}: must be a positive number below the Nyquist frequency \
             {nyquist} rad/s"
        ))
    }
}

/// An operating point's coordinates (m) must be finite and within 10 m.
fn check_operating_point(name: &str, op: &[f64; 2]) -> Result<(), String> {
    for (axis, v) in ["x", "y"].iter().zip(op) {
        if !(v.is_finite() && v.abs() <= 10.0) {
            return Err(format!(
                "{name}.{axis} = {v}: must be a finite number in [-10, 10] m"
            ));
        }
    }
    Ok(())
}

/// Longest list in a design (operating points, amplitudes, frequencies).
pub const MAX_LIST: usize = 1000;
/// Highest sample rate, Hz.
pub const MAX_SAMPLE_RATE_HZ: f64 = 1e6;
/// Longest transient or steady-state length, s.
pub const MAX_DURATION_S: f64 = 1e5;
/// Most steady-state periods.
pub const MAX_PERIODS: u32 = 1_000_000;
/// Most records in one campaign.
pub const MAX_RECORDS: usize = 100_000;
/// Most rows in one record.
pub const MAX_RECORD_ROWS: usize = 10_000_000;
/// Most rows in one campaign (about 2 GB in memory).
pub const MAX_CAMPAIGN_ROWS: usize = 50_000_000;
/// Most internal plant steps in one campaign.
pub const MAX_INTERNAL_STEPS: u64 = 10_000_000_000;
