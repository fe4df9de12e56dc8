//! The virtual robot: runs a stepped-sine campaign on a model (the same `zmp_models::Plant` every
//! other tool uses) and returns it in the `zmp-campaign/1` form, with ZMP sensor noise and
//! quantisation. Deterministic for a seed: record `k` draws its noise from `(seed, k)` alone, so
//! records can be simulated in parallel and the result does not depend on the thread count.
//! The plant runs record `k` as record `k` ([`Plant::set_record`]): a ZMP sensor re-zeroed at
//! every record drifts at that record's rate, drawn from the model's `sensor_drift.rate_seed`
//! and `k` (a normal law of mean `rate` and standard deviation `rate_spread`; see
//! `zmp_models::effects::sensor_drift`).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use zmp_campaign::{Campaign, Record, RecordMeta};
use zmp_models::{Axis, ModelSpec, Plant};

/// What to run: every operating point × amplitude × frequency × excited channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentDesign {
    /// Campaign name written to `campaign.toml`.
    #[serde(default = "default_name")]
    pub name: String,
    /// Constant CoM references `[x, y]` the sines oscillate around, m.
    pub operating_points: Vec<[f64; 2]>,
    /// Sine amplitudes of the excited reference, m.
    pub amplitudes: Vec<f64>,
    /// Excitation frequencies, rad/s.
    pub omegas: Vec<f64>,
    /// Excited reference channels.
    pub excited: Vec<Axis>,
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

    /// Record metadata in campaign order: operating point, amplitude, excited channel, frequency.
    pub fn records(&self) -> Vec<RecordMeta> {
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
        let range = |name: &str, v: f64, lo: f64, hi: f64, lo_open: bool| {
            let above = if lo_open { v > lo } else { v >= lo };
            if v.is_finite() && above && v <= hi {
                Ok(())
            } else {
                let open = if lo_open { "(" } else { "[" };
                Err(format!(
                    "{name} = {v}: must be a finite number in {open}{lo}, {hi}]"
                ))
            }
        };
        let list = |name: &str, n: usize| {
            if n == 0 {
                Err(format!("{name} is empty"))
            } else if n > MAX_LIST {
                Err(format!("{name} has {n} entries; at most {MAX_LIST}"))
            } else {
                Ok(())
            }
        };
        if self.name.len() > 1000 {
            return Err(format!(
                "name is {} bytes long; at most 1000",
                self.name.len()
            ));
        }
        range(
            "sample_rate_hz",
            self.sample_rate_hz,
            0.0,
            MAX_SAMPLE_RATE_HZ,
            true,
        )?;
        range("internal_step", self.internal_step, 0.0, 0.1, true)?;
        range("transient_s", self.transient_s, 0.0, MAX_DURATION_S, false)?;
        range(
            "min_steady_s",
            self.min_steady_s,
            0.0,
            MAX_DURATION_S,
            false,
        )?;
        range("zmp_noise_std", self.zmp_noise_std, 0.0, 1.0, false)?;
        range("quantisation", self.quantisation, 0.0, 1.0, false)?;
        if self.periods == 0 || self.periods > MAX_PERIODS {
            return Err(format!(
                "periods = {}: must be a whole number from 1 to {MAX_PERIODS}",
                self.periods
            ));
        }
        list("operating_points", self.operating_points.len())?;
        for (k, op) in self.operating_points.iter().enumerate() {
            for (axis, v) in ["x", "y"].iter().zip(op) {
                if !(v.is_finite() && v.abs() <= 10.0) {
                    return Err(format!(
                        "operating_points[{k}].{axis} = {v}: must be a finite number in \
                         [-10, 10] m"
                    ));
                }
            }
        }
        list("amplitudes", self.amplitudes.len())?;
        for (k, a) in self.amplitudes.iter().enumerate() {
            range(&format!("amplitudes[{k}]"), *a, 0.0, 1.0, true)?;
        }
        list("omegas", self.omegas.len())?;
        let nyquist = std::f64::consts::PI * self.sample_rate_hz;
        for (k, w) in self.omegas.iter().enumerate() {
            range(&format!("omegas[{k}]"), *w, 0.0, nyquist, true).map_err(|_| {
                format!(
                    "omegas[{k}] = {w}: must be a positive number below the Nyquist frequency \
                     {nyquist} rad/s"
                )
            })?;
            if *w >= nyquist {
                return Err(format!(
                    "omegas[{k}] = {w} rad/s is at or above the Nyquist frequency {nyquist} rad/s"
                ));
            }
        }
        list("excited", self.excited.len())?;
        if self.excited.len() > 2 || (self.excited.len() == 2 && self.excited[0] == self.excited[1])
        {
            return Err("excited must name each of \"x\", \"y\" at most once".into());
        }
        let dt = 1.0 / self.sample_rate_hz;
        let ratio = dt / self.internal_step;
        if (ratio - ratio.round()).abs() > 1e-9 * ratio.max(1.0) || ratio.round() < 1.0 {
            return Err(format!(
                "sample_rate_hz: the sample period {dt} s must be a whole number of internal \
                 steps (internal_step = {} s)",
                self.internal_step
            ));
        }
        // Sizes: a record's rows, the campaign's rows and the plant steps, before anything is
        // allocated.
        let per_set =
            (self.operating_points.len() * self.amplitudes.len() * self.excited.len()) as f64;
        let records = per_set * self.omegas.len() as f64;
        if records > MAX_RECORDS as f64 {
            return Err(format!(
                "operating_points, amplitudes, excited, omegas: {records} records; at most \
                 {MAX_RECORDS}"
            ));
        }
        let mut total_rows = 0.0;
        for (k, w) in self.omegas.iter().enumerate() {
            let rows = self.rows_at(*w);
            if rows > MAX_RECORD_ROWS as f64 {
                return Err(format!(
                    "transient_s, min_steady_s, periods: a record at omegas[{k}] = {w} rad/s \
                     would have {rows:.3e} rows; at most {MAX_RECORD_ROWS:.0e}"
                ));
            }
            total_rows += rows * per_set;
        }
        if total_rows > MAX_CAMPAIGN_ROWS as f64 {
            return Err(format!(
                "operating_points, amplitudes, excited, omegas: the campaign would have \
                 {total_rows:.3e} rows; at most {MAX_CAMPAIGN_ROWS:.0e}"
            ));
        }
        let steps = total_rows * ratio.round();
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

/// Rounds to the sensor resolution `q`, keeping decimal-friendly values (k / (1/q)).
fn quantise(v: f64, q: f64) -> f64 {
    if q <= 0.0 {
        return v;
    }
    let inv = (1.0 / q).round();
    if (inv * q - 1.0).abs() < 1e-12 {
        (v * inv).round() / inv
    } else {
        (v / q).round() * q
    }
}

/// Commanded references are written to the nanometre: far below any sensor, short in CSV.
fn to_nm(v: f64) -> f64 {
    (v * 1e9).round() / 1e9
}

/// Simulates one record.
pub fn simulate_record(
    spec: &ModelSpec,
    design: &ExperimentDesign,
    index: usize,
    meta: RecordMeta,
) -> Result<Record, zmp_models::ModelError> {
    let mut plant = Plant::new(spec, design.internal_step)?;
    plant.set_record(index as u64);
    let h = design.internal_step;
    let dt = 1.0 / design.sample_rate_hz;
    let sub = (dt / h).round() as usize;
    let period = 2.0 * std::f64::consts::PI / meta.omega;
    let steady = (design.periods as f64 * period).max(design.min_steady_s);
    let steady = (steady / period).ceil() * period;
    let n = ((design.transient_s + steady) / dt).round() as usize + 1;
    let mut rng =
        ChaCha8Rng::seed_from_u64(design.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ index as u64);
    let noise = Normal::new(0.0, design.zmp_noise_std.max(0.0)).expect("std >= 0");
    let op = meta.operating_point;
    plant.set_operating_point(op);
    plant.reset(op);
    let (ax, amp, omega) = (meta.excited.index(), meta.amplitude, meta.omega);
    let reference = move |t: f64| -> [f64; 2] {
        let mut r = op;
        r[ax] += amp * (omega * t).sin();
        r
    };
    let mut rec = Record {
        meta,
        t: Vec::with_capacity(n),
        x_cr: Vec::with_capacity(n),
        y_cr: Vec::with_capacity(n),
        zmp_x: Vec::with_capacity(n),
        zmp_y: Vec::with_capacity(n),
        extra: Vec::new(),
    };
    let (mut xc, mut yc) = (Vec::new(), Vec::new());
    let mut out = plant.last_output();
    let mut step = 0usize;
    for k in 0..n {
        let t = k as f64 * dt;
        while step < k * sub {
            step += 1;
            out = plant.step(reference(step as f64 * h));
        }
        let r = reference(t);
        rec.t.push(t);
        rec.x_cr.push(to_nm(r[0]));
        rec.y_cr.push(to_nm(r[1]));
        let zx = out.zmp[0]
            + if design.zmp_noise_std > 0.0 {
                noise.sample(&mut rng)
            } else {
                0.0
            };
        let zy = out.zmp[1]
            + if design.zmp_noise_std > 0.0 {
                noise.sample(&mut rng)
            } else {
                0.0
            };
        rec.zmp_x.push(quantise(zx, design.quantisation));
        rec.zmp_y.push(quantise(zy, design.quantisation));
        if design.record_com {
            xc.push(to_nm(out.com[0]));
            yc.push(to_nm(out.com[1]));
        }
    }
    if design.record_com {
        rec.extra = vec![("x_c".into(), xc), ("y_c".into(), yc)];
    }
    Ok(rec)
}

/// Runs the whole design on `spec`, records in parallel on the available cores.
pub fn simulate_campaign(spec: &ModelSpec, design: &ExperimentDesign) -> anyhow::Result<Campaign> {
    simulate_campaign_with_progress(spec, design, &|_| {})
}

/// As [`simulate_campaign`], calling `progress(done)` after each record.
pub fn simulate_campaign_with_progress(
    spec: &ModelSpec,
    design: &ExperimentDesign,
    progress: &(dyn Fn(usize) + Sync),
) -> anyhow::Result<Campaign> {
    design
        .check()
        .map_err(|e| anyhow::anyhow!("experiment design: {e}"))?;
    Plant::new(spec, design.internal_step)?;
    let metas = design.records();
    let workers = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .min(metas.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let mut slots: Vec<Option<Record>> = vec![None; metas.len()];
    let results: Vec<Vec<(usize, Record)>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                s.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        if k >= metas.len() {
                            break;
                        }
                        let rec = simulate_record(spec, design, k, metas[k].clone())
                            .expect("model checked above");
                        mine.push((k, rec));
                        let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                        progress(d);
                    }
                    mine
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("simulation thread"))
            .collect()
    });
    for (k, r) in results.into_iter().flatten() {
        slots[k] = Some(r);
    }
    Ok(Campaign {
        name: Some(design.name.clone()),
        robot: Some(format!(
            "virtual: {}",
            spec.name.clone().unwrap_or_else(|| "model".into())
        )),
        sample_rate_hz: Some(design.sample_rate_hz),
        records: slots
            .into_iter()
            .map(|r| r.expect("every record simulated"))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use zmp_models::harmonic::first_harmonic;

    fn paper() -> ModelSpec {
        ModelSpec::parse(
            include_str!("../../../models/params/silo2-paper.toml"),
            "silo2-paper.toml",
        )
        .unwrap()
    }

    fn small_design() -> ExperimentDesign {
        ExperimentDesign {
            operating_points: vec![[0.0, 0.0]],
            amplitudes: vec![0.005],
            omegas: vec![1.0, 8.0],
            excited: vec![Axis::X, Axis::Y],
            ..ExperimentDesign::reference()
        }
    }

    #[test]
    fn deterministic_for_a_seed_and_seed_sensitive() {
        let spec = paper();
        let d = small_design();
        let a = simulate_campaign(&spec, &d).unwrap();
        let b = simulate_campaign(&spec, &d).unwrap();
        assert_eq!(a, b);
        let c = simulate_campaign(&spec, &ExperimentDesign { seed: 2, ..d }).unwrap();
        assert_ne!(a.records[0].zmp_x, c.records[0].zmp_x);
    }

    #[test]
    fn noiseless_record_steady_state_matches_frequency_response() {
        let spec = paper();
        let d = ExperimentDesign {
            zmp_noise_std: 0.0,
            quantisation: 0.0,
            ..small_design()
        };
        let camp = simulate_campaign(&spec, &d).unwrap();
        let plant = Plant::new(&spec, d.internal_step).unwrap();
        for rec in &camp.records {
            let w = rec.meta.omega;
            let dt = rec.dt();
            let period = 2.0 * std::f64::consts::PI / w;
            let start = (d.transient_s / dt).ceil() as usize;
            let n_per = (period / dt).round() as usize;
            let keep = ((rec.len() - start) / n_per) * n_per;
            let j = rec.meta.excited.index();
            let g = plant.frequency_response(w);
            let u = first_harmonic(
                &rec.input(rec.meta.excited)[start..start + keep],
                w,
                dt,
                rec.t[start],
            );
            for (i, out) in [&rec.zmp_x, &rec.zmp_y].iter().enumerate() {
                let y = first_harmonic(&out[start..start + keep], w, dt, rec.t[start]);
                let rel = ((y / u) - g[i][j]).norm() / g[i][j].norm();
                assert!(rel < 2e-3, "omega {w} G{}{}: rel err {rel}", i + 1, j + 1);
            }
        }
    }

    #[test]
    fn quantisation_and_noise_level() {
        let spec = paper();
        let d = small_design();
        let camp = simulate_campaign(&spec, &d).unwrap();
        for v in &camp.records[0].zmp_x {
            let k = v / d.quantisation;
            assert!((k - k.round()).abs() < 1e-6, "{v} not on the 0.1 mm grid");
        }
        let clean = simulate_campaign(
            &spec,
            &ExperimentDesign {
                zmp_noise_std: 0.0,
                quantisation: 0.0,
                ..d.clone()
            },
        )
        .unwrap();
        let r = &camp.records[1];
        let diff: Vec<f64> = r
            .zmp_y
            .iter()
            .zip(&clean.records[1].zmp_y)
            .map(|(a, b)| a - b)
            .collect();
        let std = (diff.iter().map(|e| e * e).sum::<f64>() / diff.len() as f64).sqrt();
        // Noise 0.5 mm plus uniform quantisation error 0.1 mm / sqrt(12).
        let expect = (0.0005f64.powi(2) + 0.0001f64.powi(2) / 12.0).sqrt();
        assert!(
            (std / expect - 1.0).abs() < 0.05,
            "noise std {std} vs {expect}"
        );
    }

    #[test]
    fn design_errors_name_the_field() {
        let d = ExperimentDesign {
            omegas: vec![1.0, 1000.0],
            ..small_design()
        };
        assert!(d.check().unwrap_err().contains("Nyquist"));
        let d = ExperimentDesign {
            sample_rate_hz: 300.0,
            ..small_design()
        };
        assert!(d.check().unwrap_err().contains("internal steps"));
        let d = ExperimentDesign {
            amplitudes: vec![0.0],
            ..small_design()
        };
        assert!(d.check().unwrap_err().contains("amplitudes"));
    }

    #[test]
    fn reference_design_size() {
        let d = ExperimentDesign::reference();
        assert_eq!(d.records().len(), 168);
    }
}
