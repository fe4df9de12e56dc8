//! The experiment design: which stepped-sine records a campaign holds and how they are sampled.
//!
//! Two forms: the grid (`operating_points`, `amplitudes`, `omegas`, `excited`: every
//! combination, ordered operating point, then excited axis, then amplitude, then frequency) or
//! the list (`[[records]]`, each with `excited`, `omega`, `amplitude`, `operating_point`, in
//! file order: what the project's `design-next` writes); the index `k` of `records()` is the
//! file `records/r{k:03}.csv`. Every record starts when its
//! excitation starts (`t = 0`, robot at rest at the operating point) and lasts `transient_s`
//! plus a whole number of periods: `max(ceil(periods), ceil(min_steady_s / T))`, at least one.

use crate::robot::{validate_noise, Noise};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::path::Path;

/// An input axis (and the output axis of the same name).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisName {
    /// Lateral plane (index 0).
    X,
    /// Sagittal plane (index 1).
    Y,
}

impl AxisName {
    /// 0 for x, 1 for y.
    pub fn index(self) -> usize {
        match self {
            AxisName::X => 0,
            AxisName::Y => 1,
        }
    }
    /// `"x"` or `"y"`.
    pub fn name(self) -> &'static str {
        ["x", "y"][self.index()]
    }
}

/// A stepped-sine campaign design.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Design {
    /// Campaign name written to `campaign.toml`.
    #[serde(default = "default_name")]
    pub name: String,
    /// Operating points `[x, y]` of the CoM references, m (grid form).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub operating_points: Vec<[f64; 2]>,
    /// Sine amplitudes of the excited reference, m (grid form).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub amplitudes: Vec<f64>,
    /// Excitation frequencies, rad/s (grid form).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub omegas: Vec<f64>,
    /// The excited reference axes (grid form).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub excited: Vec<AxisName>,
    /// The records one by one, in file order (list form).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub records: Vec<ListedRecord>,
    /// Sample rate of the written records, Hz.
    pub sample_rate_hz: f64,
    /// Recorded time before the steady state is expected, s.
    pub transient_s: f64,
    /// Minimum number of steady-state periods.
    pub periods: f64,
    /// Minimum steady-state duration, s.
    pub min_steady_s: f64,
    /// ZMP quantisation step, m (0: none).
    #[serde(default)]
    pub quantisation: f64,
    /// Seed of the measurement-noise realisation (record k uses ChaCha8 stream k of it).
    #[serde(default)]
    pub seed: u64,
    /// Noise law overriding the robot's own sensor noise (`None`: the robot's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<Noise>,
    /// Shorthand override for white noise only, m (the project's design files use it); used
    /// when `noise` is absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zmp_noise_std: Option<f64>,
    /// Lowest rate of this simulator's RK4 integrator, Hz. The step is the smaller of
    /// `1 / min_internal_rate_hz` and `STEP_RATE_PRODUCT / λ` (λ an estimate of the robot's
    /// fastest rate, see `Design::substeps_for`), shortened so that a sample period holds a
    /// whole number of steps.
    #[serde(default = "default_internal_rate")]
    pub min_internal_rate_hz: f64,
    /// Accepted for compatibility with the project's design files and ignored: this simulator
    /// chooses its own step (see `min_internal_rate_hz`).
    #[serde(default, skip_serializing)]
    pub internal_step: Option<f64>,
    /// Accepted for compatibility with the project's design files and ignored: this simulator
    /// never writes the true CoM into a campaign (use `simulate` for it).
    #[serde(default, skip_serializing)]
    pub record_com: Option<bool>,
}

fn default_name() -> String {
    "indep-sim".into()
}
fn default_internal_rate() -> f64 {
    1000.0
}

/// One record of a design in the list form.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ListedRecord {
    /// The reference that carries the sine.
    pub excited: AxisName,
    /// Excitation frequency, rad/s.
    pub omega: f64,
    /// Sine amplitude, m.
    pub amplitude: f64,
    /// Operating point `[x, y]`, m.
    pub operating_point: [f64; 2],
}

/// The product `λ h` of the robot's fastest rate estimate and the integrator step that the step
/// choice keeps to (RK4's local error is then below `0.15⁵/120 ≈ 6e-7` of the fastest motion).
pub const STEP_RATE_PRODUCT: f64 = 0.15;

/// One record of a design.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecordSpec {
    /// Position in `Design::records()` (and file `records/r{index:03}.csv`).
    pub index: usize,
    /// The reference that carries the sine.
    pub excited: AxisName,
    /// Excitation frequency, rad/s.
    pub omega: f64,
    /// Sine amplitude, m.
    pub amplitude: f64,
    /// Operating point `[x, y]`, m.
    pub operating_point: [f64; 2],
    /// Number of samples (at `t = k / sample_rate_hz`, `k = 0..n_samples`).
    pub n_samples: usize,
    /// Start of the steady window (= the design's `transient_s`), s.
    pub steady_start_s: f64,
    /// Whole periods in the steady window.
    pub steady_periods: usize,
}

impl RecordSpec {
    /// The file name relative to the campaign folder.
    pub fn file(&self) -> String {
        format!("records/r{:03}.csv", self.index)
    }
    /// End of the steady window, s.
    pub fn steady_end_s(&self) -> f64 {
        self.steady_start_s + self.steady_periods as f64 * 2.0 * PI / self.omega
    }
    /// Number of samples in the steady window `[steady_start_s, steady_end_s)`.
    pub fn steady_samples(&self, sample_rate_hz: f64) -> usize {
        let first = (self.steady_start_s * sample_rate_hz - 1e-9)
            .ceil()
            .max(0.0) as usize;
        let end = (self.steady_end_s() * sample_rate_hz - 1e-9).ceil() as usize;
        end.min(self.n_samples).saturating_sub(first)
    }
}

impl Default for Design {
    /// The blind-suite design: 3 operating points × 2 excited axes × 2 amplitudes (3, 8 mm)
    /// × 9 frequencies (0.5-15 rad/s, log-spaced) = 108 records at 200 Hz, 3 s transient,
    /// at least 3 periods and 12 s of steady state (records of 15-41 s), 0.1 mm quantisation.
    fn default() -> Self {
        let omegas = (0..9).map(|k| 0.5 * 30f64.powf(k as f64 / 8.0)).collect();
        Design {
            name: default_name(),
            operating_points: vec![[0.0, 0.0], [0.03, 0.02], [-0.03, -0.02]],
            amplitudes: vec![0.003, 0.008],
            omegas,
            excited: vec![AxisName::X, AxisName::Y],
            records: Vec::new(),
            sample_rate_hz: 200.0,
            transient_s: 3.0,
            periods: 3.0,
            min_steady_s: 12.0,
            quantisation: 1e-4,
            seed: 0,
            noise: None,
            zmp_noise_std: None,
            min_internal_rate_hz: default_internal_rate(),
            internal_step: None,
            record_com: None,
        }
    }
}

impl Design {
    /// Checks the design; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        let pos = |v: f64, w: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{w} must be positive and finite, got {v}"))
            }
        };
        let grid = !(self.operating_points.is_empty()
            && self.amplitudes.is_empty()
            && self.omegas.is_empty()
            && self.excited.is_empty());
        if grid && !self.records.is_empty() {
            return Err(
                "records: give either the grid (operating_points, amplitudes, omegas, \
                        excited) or the list ([[records]]), not both"
                    .into(),
            );
        }
        if self.records.is_empty() {
            if self.operating_points.is_empty() {
                return Err("operating_points must not be empty".into());
            }
            for (k, op) in self.operating_points.iter().enumerate() {
                if !(op[0].is_finite() && op[1].is_finite()) {
                    return Err(format!("operating_points[{k}] must be finite"));
                }
            }
            if self.amplitudes.is_empty() || self.omegas.is_empty() || self.excited.is_empty() {
                return Err("amplitudes, omegas and excited must not be empty".into());
            }
            for (k, a) in self.amplitudes.iter().enumerate() {
                pos(*a, &format!("amplitudes[{k}]"))?;
            }
            for (k, w) in self.omegas.iter().enumerate() {
                pos(*w, &format!("omegas[{k}]"))?;
            }
        }
        for (k, r) in self.records.iter().enumerate() {
            pos(r.omega, &format!("records[{k}].omega"))?;
            pos(r.amplitude, &format!("records[{k}].amplitude"))?;
            if !(r.operating_point[0].is_finite() && r.operating_point[1].is_finite()) {
                return Err(format!("records[{k}].operating_point must be finite"));
            }
        }
        pos(self.sample_rate_hz, "sample_rate_hz")?;
        pos(self.min_internal_rate_hz, "min_internal_rate_hz")?;
        if !(self.transient_s.is_finite() && self.transient_s >= 0.0) {
            return Err(format!(
                "transient_s must be >= 0, got {}",
                self.transient_s
            ));
        }
        if !(self.periods.is_finite() && self.periods >= 0.0) {
            return Err(format!("periods must be >= 0, got {}", self.periods));
        }
        if !(self.min_steady_s.is_finite() && self.min_steady_s >= 0.0) {
            return Err(format!(
                "min_steady_s must be >= 0, got {}",
                self.min_steady_s
            ));
        }
        if !(self.quantisation.is_finite() && self.quantisation >= 0.0) {
            return Err(format!(
                "quantisation must be >= 0, got {}",
                self.quantisation
            ));
        }
        if let Some(n) = &self.noise {
            validate_noise(n, "noise")?;
        }
        if let Some(s) = self.zmp_noise_std {
            if !(s.is_finite() && s >= 0.0) {
                return Err(format!("zmp_noise_std must be >= 0, got {s}"));
            }
        }
        for r in self.records() {
            if r.n_samples > 50_000_000 {
                return Err(format!(
                    "record {} would have {} samples: too long",
                    r.index, r.n_samples
                ));
            }
        }
        Ok(())
    }

    /// Reads a design from a TOML file; errors name the file (and, from the TOML parser, the
    /// line and key).
    pub fn from_toml_file(path: &Path) -> anyhow::Result<Self> {
        let text = zmp_files::read_limited_text(path, zmp_files::limits::MODEL_BYTES, "a design")?;
        let d: Design =
            toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        d.validate()
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        Ok(d)
    }

    /// The noise law in force: `noise`, else `zmp_noise_std` (white only), else the robot's.
    pub fn noise_for(&self, robot_noise: &Noise) -> Noise {
        if let Some(n) = &self.noise {
            n.clone()
        } else if let Some(s) = self.zmp_noise_std {
            Noise {
                white_std: s,
                coloured_std: 0.0,
                coloured_tau: 1.0,
            }
        } else {
            robot_noise.clone()
        }
    }

    /// Integrator steps per sample for a robot whose fastest rate is estimated as
    /// `fastest_rate` (1/s): `ceil(max(min_internal_rate_hz, fastest_rate / STEP_RATE_PRODUCT)
    /// / sample_rate_hz)`, at least 1.
    pub fn substeps_for(&self, fastest_rate: f64) -> usize {
        let rate = self
            .min_internal_rate_hz
            .max(fastest_rate / STEP_RATE_PRODUCT);
        ((rate / self.sample_rate_hz) - 1e-9).ceil().max(1.0) as usize
    }

    /// Whether the design lists its records (`[[records]]`) rather than giving a grid.
    pub fn is_list(&self) -> bool {
        !self.records.is_empty()
    }

    /// The design a robot is drawn for: this one, or for a list (records proposed for a robot
    /// already drawn, not a campaign to size its effects on) the default grid, so that a list
    /// runs on the robot the same seed and scenario draw for the default campaign.
    pub fn for_drawing(&self) -> Design {
        if self.is_list() {
            Design::default()
        } else {
            self.clone()
        }
    }

    /// The records, in file order.
    pub fn records(&self) -> Vec<RecordSpec> {
        let mut out = Vec::new();
        let push = |out: &mut Vec<RecordSpec>,
                    axis: AxisName,
                    omega: f64,
                    amplitude: f64,
                    op: [f64; 2]| {
            let period = 2.0 * PI / omega;
            let by_periods = (self.periods - 1e-9).ceil();
            let by_time = (self.min_steady_s / period - 1e-9).ceil();
            let steady_periods = by_periods.max(by_time).max(1.0) as usize;
            let duration = self.transient_s + steady_periods as f64 * period;
            let n_samples = (duration * self.sample_rate_hz + 1e-9).ceil() as usize + 1;
            out.push(RecordSpec {
                index: out.len(),
                excited: axis,
                omega,
                amplitude,
                operating_point: op,
                n_samples,
                steady_start_s: self.transient_s,
                steady_periods,
            });
        };
        for r in &self.records {
            push(&mut out, r.excited, r.omega, r.amplitude, r.operating_point);
        }
        for op in &self.operating_points {
            for &axis in &self.excited {
                for &amplitude in &self.amplitudes {
                    for &omega in &self.omegas {
                        push(&mut out, axis, omega, amplitude, *op);
                    }
                }
            }
        }
        out
    }
}
