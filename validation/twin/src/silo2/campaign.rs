//! The stepped-sine campaign of seed section 6.1 on the twin, written as `zmp-campaign/1`.
//!
//! Per record the trunk servos get `theta_r(t) = theta_0 + theta_A sin(omega t)` on the excited
//! axis, and the CoM reference written to the record is the seed's eq. 26 with the twin's own
//! mass properties: `x_cr = x_c0 + (m_t/m_r) l_t theta_r` (`x_c0`: the upright CoM). The ZMP is
//! what the 8 corner load cells give through [`ZmpSensorSpec`] (noise, resolution, delay); the
//! true CoM of the whole robot is written beside it as `x_c`, `y_c`.
//!
//! Every record starts from the standing keyframe: the trunk is brought to the operating point
//! along a half cosine, held until the robot is at rest, then the sine starts at the record's
//! `t = 0` (the transient is in the file, as the format asks). Records are independent, so they
//! run in parallel; the noise of record `k` is stream `k` of the sensor's seed, so the result
//! does not depend on the thread count.

use super::props::MassProperties;
use super::{Silo2, STEP};
use crate::mj::TwinError;
use crate::zmp::{ZmpSensor, ZmpSensorSpec};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use zmp_campaign::{Campaign, Record, RecordMeta};
use zmp_models::Axis;

/// What to run on the twin: every operating point × amplitude × excited axis × frequency.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwinDesign {
    pub name: String,
    /// CoM references `[x, y]` (eq. 26) the sines oscillate around, m.
    pub operating_points: Vec<[f64; 2]>,
    /// Sine amplitudes of the excited CoM reference, m.
    pub amplitudes: Vec<f64>,
    /// Excitation frequencies, rad/s.
    pub omegas: Vec<f64>,
    pub excited: Vec<Axis>,
    /// Sample rate of the records, Hz (a whole number of 1 ms physics steps per sample).
    pub sample_rate_hz: f64,
    /// Recorded from the start of the sine before the steady state is expected, s.
    pub transient_s: f64,
    /// Whole periods of steady state recorded, at least `min_steady_s`.
    pub periods: u32,
    pub min_steady_s: f64,
    /// Time to bring the trunk to the operating point and come to rest, s (the first 0.5 s
    /// ramp the references).
    pub settle_s: f64,
    pub sensor: ZmpSensorSpec,
    /// Records above the main band with amplitudes of their own (at every operating point and
    /// excited axis), after the main grid's.
    #[serde(default)]
    pub high_band: Option<Band>,
}

/// Extra frequencies with their own (smaller) amplitudes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Band {
    /// rad/s.
    pub omegas: Vec<f64>,
    /// m.
    pub amplitudes: Vec<f64>,
}

fn logspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    zmp_models::logspace(lo, hi, n)
}

impl TwinDesign {
    /// The campaign of `cargo xtask validate silo2`: 3 operating points × 2 amplitudes × 2 axes
    /// × 12 frequencies from 0.5 to 12 rad/s (144 records).
    ///
    /// Amplitudes (1.5 and 3.5 mm of CoM, 1.7° and 3.9° of trunk) are smaller than the seed's 3
    /// and 8 mm because the twin's ZMP must stay inside its support polygon: at 12 rad/s the
    /// ZMP swings `(a + b w^2) = 19` times the CoM, 67 mm for 3.5 mm, against a half-length of
    /// 110 mm (sagittal) and a half-width of 160 mm (lateral). The operating points tilt the
    /// trunk by 0.16 rad (lateral) and 0.08 rad (sagittal) both ways.
    pub fn full() -> TwinDesign {
        TwinDesign {
            name: "silo2-twin".into(),
            operating_points: vec![[0.0, 0.0], [0.008, 0.004], [-0.008, -0.004]],
            amplitudes: vec![0.0015, 0.0035],
            omegas: logspace(0.5, 12.0, 12),
            excited: vec![Axis::X, Axis::Y],
            sample_rate_hz: 200.0,
            transient_s: 2.0,
            periods: 4,
            min_steady_s: 6.0,
            settle_s: 2.0,
            sensor: ZmpSensorSpec::silo2(),
            high_band: None,
        }
    }

    /// [`TwinDesign::full`] extended to 50 rad/s (`validate silo2 --extended`): 8 more
    /// frequencies from 14 to 50 rad/s at 0.1 and 0.2 mm of CoM (240 records). The twin's ZMP
    /// swings `(a + b w^2) |H| S` times the CoM, with the servo's `|H|` and the stance factor
    /// `S` (up to 3 near 40 rad/s, sagittal): about 200 at 40-50 rad/s, so 0.2 mm gives 40 mm,
    /// inside the 110 mm half-length of the polygon at every operating point (a test checks
    /// the most demanding records keep 40 mm from the edge), and 0.1 mm still about 2 mm at
    /// 14 rad/s, several times the load cells' ZMP noise per sample (0.5 N per cell over the
    /// 470 N weight at corners up to 0.16 m out: about 0.35 mm RMS), averaged over thousands
    /// of samples by the fit. Nothing else limits the band: the servos have no force limit (a 0.2 mm sine at 50 rad/s needs
    /// 8 N m), the feet stay flat (the ZMP inside the polygon), and 200 Hz samples a 50 rad/s
    /// sine 25 times a period (1 ms physics steps: 125).
    pub fn extended() -> TwinDesign {
        TwinDesign {
            name: "silo2-twin-extended".into(),
            high_band: Some(Band {
                omegas: logspace(14.0, 50.0, 8),
                amplitudes: vec![0.0001, 0.0002],
            }),
            ..TwinDesign::full()
        }
    }

    /// The short campaign of CI and the demo: one operating point, one amplitude, 5
    /// frequencies from 1 to 12 rad/s, both axes (10 records, about 130 s of simulated time).
    pub fn short() -> TwinDesign {
        TwinDesign {
            name: "silo2-twin-short".into(),
            operating_points: vec![[0.0, 0.0]],
            amplitudes: vec![0.0035],
            omegas: logspace(1.0, 12.0, 5),
            ..TwinDesign::full()
        }
    }

    /// Record metadata in campaign order: operating point, amplitude, axis, frequency; then
    /// the high band's in the same order.
    pub fn records(&self) -> Vec<RecordMeta> {
        let mut out = Vec::new();
        let main = (&self.amplitudes, &self.omegas);
        let high = self.high_band.as_ref().map(|b| (&b.amplitudes, &b.omegas));
        for (amplitudes, omegas) in std::iter::once(main).chain(high) {
            self.grid(amplitudes, omegas, &mut out);
        }
        out
    }

    fn grid(&self, amplitudes: &[f64], omegas: &[f64], out: &mut Vec<RecordMeta>) {
        for op in &self.operating_points {
            for &amplitude in amplitudes {
                for &excited in &self.excited {
                    for &omega in omegas {
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
    }

    /// Physics steps per sample.
    pub fn decimation(&self) -> usize {
        (1.0 / (self.sample_rate_hz * STEP)).round().max(1.0) as usize
    }

    /// Length of the record at `omega`, s (a whole number of samples).
    pub fn record_length(&self, omega: f64) -> f64 {
        let period = 2.0 * std::f64::consts::PI / omega;
        let steady = (self.periods as f64 * period).max(self.min_steady_s);
        self.transient_s + steady
    }

    /// Simulated seconds of the whole campaign (settling included).
    pub fn simulated_seconds(&self) -> f64 {
        self.records()
            .iter()
            .map(|m| self.settle_s + self.record_length(m.omega))
            .sum()
    }

    /// Checks the design; the message names the field.
    pub fn check(&self) -> Result<(), String> {
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be a positive number, got {v}"))
            }
        };
        positive("sample_rate_hz", self.sample_rate_hz)?;
        let dec = 1.0 / (self.sample_rate_hz * STEP);
        if (dec - dec.round()).abs() > 1e-9 || dec < 1.0 {
            return Err(format!(
                "sample_rate_hz = {} is not a whole number of {} ms steps",
                self.sample_rate_hz,
                STEP * 1e3
            ));
        }
        if self.settle_s < 0.5 {
            return Err(format!(
                "settle_s must be at least 0.5 s, got {}",
                self.settle_s
            ));
        }
        if !(self.transient_s >= 0.0 && self.min_steady_s >= 0.0) {
            return Err("transient_s and min_steady_s must be >= 0".into());
        }
        let empty = Vec::new();
        let (band_amplitudes, band_omegas) = match &self.high_band {
            Some(b) if b.amplitudes.is_empty() || b.omegas.is_empty() => {
                return Err("high_band: amplitudes and omegas must not be empty".into())
            }
            Some(b) => (&b.amplitudes, &b.omegas),
            None => (&empty, &empty),
        };
        for (name, v) in [
            ("amplitudes", &self.amplitudes),
            ("omegas", &self.omegas),
            ("high_band.amplitudes", band_amplitudes),
            ("high_band.omegas", band_omegas),
        ] {
            if v.is_empty() && !name.starts_with("high_band") {
                return Err(format!("{name} is empty"));
            }
            for &x in v {
                positive(name, x)?;
            }
        }
        if self.operating_points.is_empty() || self.excited.is_empty() {
            return Err("operating_points and excited must not be empty".into());
        }
        if self.periods < 2 {
            return Err("periods must be at least 2".into());
        }
        crate::zmp::ZmpSensor::<1>::new(self.sensor, STEP, 0)
            .map_err(|m| format!("sensor: {m}"))?;
        Ok(())
    }
}

/// Runs one record; `index` selects the sensor noise stream.
pub fn simulate_record(
    twin: &Silo2,
    props: &MassProperties,
    design: &TwinDesign,
    meta: &RecordMeta,
    index: usize,
) -> Result<Record, TwinError> {
    let kr = props.reference_gain();
    let c0 = props.com_upright;
    let op = meta.operating_point;
    let theta0 = [(op[0] - c0[0]) / kr, (op[1] - c0[1]) / kr];
    let theta_amp = meta.amplitude / kr;
    let ax = meta.excited.index();
    let mut d = twin.stand()?;
    twin.settle(&mut d, theta0, 0.5, design.settle_s - 0.5);
    let mut sensor =
        ZmpSensor::<8>::new(design.sensor, STEP, index as u64).map_err(|m| TwinError::Model {
            path: twin.path.clone(),
            message: format!("ZMP sensor: {m}"),
        })?;
    let dec = design.decimation();
    let n_samples = (design.record_length(meta.omega) * design.sample_rate_hz).round() as usize;
    let mut rec = Record {
        meta: meta.clone(),
        t: Vec::with_capacity(n_samples),
        x_cr: Vec::with_capacity(n_samples),
        y_cr: Vec::with_capacity(n_samples),
        zmp_x: Vec::with_capacity(n_samples),
        zmp_y: Vec::with_capacity(n_samples),
        extra: vec![
            ("x_c".into(), Vec::with_capacity(n_samples)),
            ("y_c".into(), Vec::with_capacity(n_samples)),
        ],
    };
    for k in 0..n_samples * dec {
        // Time as k * step, never accumulated.
        let t = k as f64 * STEP;
        let s = (meta.omega * t).sin();
        let mut theta = theta0;
        theta[ax] += theta_amp * s;
        twin.set_trunk(&mut d, theta);
        // mj_step evaluates the state at t (sensors, contacts, CoM), then integrates.
        d.step();
        sensor.push(twin.cells(&d));
        if k % dec == 0 {
            let zmp = sensor.sample().ok_or_else(|| TwinError::Model {
                path: twin.path.clone(),
                message: format!(
                    "record {index}: no load on the feet at t = {t:.3} s (the robot left the floor)"
                ),
            })?;
            let com = twin.com(&d);
            let mut cr = op;
            cr[ax] += meta.amplitude * s;
            rec.t.push(t);
            rec.x_cr.push(cr[0]);
            rec.y_cr.push(cr[1]);
            rec.zmp_x.push(zmp[0]);
            rec.zmp_y.push(zmp[1]);
            rec.extra[0].1.push(com[0]);
            rec.extra[1].1.push(com[1]);
        }
    }
    if !rec.zmp_x.iter().chain(&rec.zmp_y).all(|v| v.is_finite()) {
        return Err(TwinError::Model {
            path: twin.path.clone(),
            message: format!("record {index}: the simulation diverged (non-finite ZMP)"),
        });
    }
    Ok(rec)
}

/// Runs the whole campaign on `threads` threads; `progress(records done)`.
pub fn run_campaign(
    twin: &Silo2,
    props: &MassProperties,
    design: &TwinDesign,
    threads: usize,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Campaign, TwinError> {
    design.check().map_err(|m| TwinError::Model {
        path: "campaign design".into(),
        message: m,
    })?;
    let metas = design.records();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let records = zmp_campaign::par::try_parallel_map(metas.len(), threads, |k| {
        let r = simulate_record(twin, props, design, &metas[k], k);
        progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1);
        r
    })?;
    Ok(Campaign {
        name: Some(design.name.clone()),
        robot: Some(format!(
            "SILO2 MuJoCo twin ({}, MuJoCo 3.17.0, 1 ms step); x_cr, y_cr: seed eq. 26 with \
             m_t/m_r = {:.4}, l_t = {:.4} m; {}",
            super::MJCF_RELATIVE,
            props.trunk_mass_ratio,
            props.trunk_lever,
            design.sensor.describe()
        )),
        sample_rate_hz: Some(design.sample_rate_hz),
        records,
    })
}

/// The twin's first-harmonic response `ZMP_i / x_cr,i` on the excited axis at `omega`, from
/// one noise-free record (no sensor noise or resolution, the campaign's settling) of CoM
/// amplitude `amplitude` around the upright posture, over whole periods of the steady state.
pub fn response(
    twin: &Silo2,
    props: &MassProperties,
    axis: Axis,
    omega: f64,
    amplitude: f64,
) -> Result<num_complex::Complex64, TwinError> {
    use zmp_models::harmonic::first_harmonic;
    let mut design = TwinDesign::short();
    design.sensor = ZmpSensorSpec {
        force_noise_std: 0.0,
        quantisation: 0.0,
        delay: 0.0,
        seed: 0,
    };
    design.min_steady_s = 3.0;
    design.periods = 10;
    let meta = RecordMeta {
        file: "response.csv".into(),
        excited: axis,
        omega,
        amplitude,
        operating_point: [props.com_upright[0], props.com_upright[1]],
    };
    let r = simulate_record(twin, props, &design, &meta, 0)?;
    let dt = r.dt();
    let per = 2.0 * std::f64::consts::PI / omega / dt;
    let n0 = (design.transient_s / dt) as usize;
    let n = (((r.len() - n0) as f64 / per).floor() * per).round() as usize;
    let (z, u) = match axis {
        Axis::X => (&r.zmp_x, &r.x_cr),
        Axis::Y => (&r.zmp_y, &r.y_cr),
    };
    let zh = first_harmonic(&z[n0..n0 + n], omega, dt, r.t[n0]);
    let uh = first_harmonic(&u[n0..n0 + n], omega, dt, r.t[n0]);
    Ok(zh / uh)
}
