//! The seed's section 6.6 experiment on the twin: the cascade ZMP controller
//! (`zmp_models::controller`, the code of the controller FMU) closes the loop through the twin's
//! load cells and trunk servos; the ZMP reference steps at t = 0, a 4 kg mass is added on the
//! robot's right side at t = 80 s. The same experiment on an identified model
//! (`zmp_models::closed_loop`) is the model's prediction.
//!
//! **Mapping the seed's step.** The seed moves the ZMP reference from 0.12 to 0.17 m in SILO2's
//! force-plate frame, whose origin it does not give. The twin starts where SILO2 started, at
//! rest with the trunk upright (ZMP = the upright CoM projection, the centre of the support
//! polygon), and the 5 cm step is scaled so that it asks the twin's trunk for the same tilt as
//! it asks SILO2's: the seed's model moves the ZMP by `a11 (m_t/m_r) l_t = 0.8293 * 0.17 *
//! 0.65 = 0.0916 m` per radian of trunk (controller convention of `CascadeParams::silo2`); the
//! twin by `a11 (m_t/m_r) l_t` with its own predicted `a11` and mass properties. A literal
//! 5 cm step would need the twin's CoM to move 5 cm with a trunk of 17 % of the mass: a tilt
//! beyond 80°.
//!
//! **Controller.** `K1 = 0.014`, `K2 = 0.2`, error in cm (the seed's, `CascadeParams::silo2`),
//! with the twin's `m_t/m_r` and `l_t` (they only convert the trunk angle into the CoM
//! reference the trace reports: the trunk servos receive the angle). It samples the measured
//! ZMP every 10 ms; the ZMP it sees is the last completed physics step's (1 ms old).
//!
//! **Load.** Body `load` (massless in the model file) gets 4 kg at t = 80 s; MuJoCo's derived
//! constants are recomputed (`mj_setConst`) with the simulation state kept.

use super::props::{MassProperties, OperatingPoint};
use super::{Silo2, STEP};
use crate::mj::TwinError;
use crate::zmp::{ZmpSensor, ZmpSensorSpec};
use mujoco_rs::prelude::*;
use serde::Serialize;
use zmp_models::closed_loop::{run, ClosedLoopTrace, StepExperiment, StepMetrics};
use zmp_models::controller::{CascadeController, CascadeParams};
use zmp_models::{ModelSpec, Plant};

/// ZMP per radian of trunk in the seed's model and controller convention: `a11 (m_t/m_r) l_t`.
pub fn seed_zmp_per_radian() -> f64 {
    let p = CascadeParams::silo2();
    0.8293 * p.trunk_gain()
}

/// The seed's step, m.
pub const SEED_STEP: f64 = 0.05;

/// The loaded mass, kg, and when, s.
pub const LOAD_MASS: f64 = 4.0;
/// When the load is placed, s.
pub const LOAD_TIME: f64 = 80.0;

/// The controller on the twin: the seed's gains and units, the twin's mass properties.
pub fn controller_params(props: &MassProperties) -> CascadeParams {
    CascadeParams {
        mass_ratio: props.trunk_mass_ratio,
        trunk_length: props.trunk_lever,
        ..CascadeParams::silo2()
    }
}

/// The experiment on the twin (see the module docs for the mapping).
pub fn experiment(
    twin: &Silo2,
    props: &MassProperties,
    upright: &OperatingPoint,
) -> Result<StepExperiment, TwinError> {
    let d = twin.stand()?;
    let load = d.xpos()[twin.load_body];
    let start = [upright.com[0], upright.com[1]];
    let step = SEED_STEP * upright.servo.a[0][0] * props.reference_gain() / seed_zmp_per_radian();
    Ok(StepExperiment {
        zmp_ref_before: start,
        zmp_ref_after: [start[0] + step, start[1]],
        load_time: LOAD_TIME,
        load_mass: LOAD_MASS,
        robot_mass: props.total_mass,
        load_position: [load[0], load[1]],
        duration: 160.0,
        controller_period: 0.01,
    })
}

/// The twin's run: the trace (one sample per controller period: `zmp` what the controller
/// measured, `com` the true CoM), the true ZMP (the load cells without sensor noise) and the
/// measured trunk angles.
#[derive(Debug, Clone, Default)]
pub struct TwinRun {
    /// The trace of the run.
    pub trace: ClosedLoopTrace,
    /// The true ZMP (load cells without sensor noise), m.
    pub zmp_true: Vec<[f64; 2]>,
    /// The measured trunk angles, rad.
    pub theta_measured: Vec<[f64; 2]>,
}

impl TwinRun {
    /// The trace with the true ZMP in place of the measured one.
    pub fn true_trace(&self) -> ClosedLoopTrace {
        ClosedLoopTrace {
            zmp: self.zmp_true.clone(),
            ..self.trace.clone()
        }
    }
}

/// Called at the frame times with the twin's data (model owned, so the load can be swapped in).
pub type Capture<'a> = dyn FnMut(f64, &mut MjData<Box<MjModel>>) -> Result<(), TwinError> + 'a;

/// Runs the experiment on the twin. `capture(t, data)` is called at the controller samples
/// closest to each time in `frames` (for pictures).
pub fn run_twin(
    twin: &Silo2,
    props: &MassProperties,
    exp: &StepExperiment,
    sensor: ZmpSensorSpec,
    frames: &[f64],
    capture: &mut Capture<'_>,
) -> Result<TwinRun, TwinError> {
    let err = |message: String| TwinError::Model {
        path: twin.path.clone(),
        message,
    };
    // The robot as loaded at t = 80 s: 4 kg at the load body (a 6 x 10 x 10 cm block).
    let mut loaded = twin.model.clone();
    let lb = twin.load_body;
    loaded.body_mass_mut()[lb] = exp.load_mass;
    loaded.body_inertia_mut()[lb] = [
        exp.load_mass * (0.01 + 0.01) / 12.0,
        exp.load_mass * (0.0036 + 0.01) / 12.0,
        exp.load_mass * (0.0036 + 0.01) / 12.0,
    ];
    loaded.body_ipos_mut()[lb] = [0.0; 3];
    let mut d = MjData::try_new(Box::new(twin.model.clone()))
        .map_err(|e| err(format!("cannot allocate the simulation data: {e}")))?;
    d.reset_keyframe(twin.stand_key)
        .map_err(|e| err(format!("keyframe 'stand': {e}")))?;
    d.ctrl_mut().fill(0.0);
    let mut loaded = Some(Box::new(loaded));

    let params = controller_params(props);
    let mut ctrl = CascadeController::new(params, exp.controller_period);
    let sub = (exp.controller_period / STEP).round().max(1.0) as usize;
    let tc = sub as f64 * STEP;
    let mut sensor = ZmpSensor::<8>::new(sensor, STEP, 1_000_000)
        .map_err(|m| err(format!("ZMP sensor: {m}")))?;
    // At rest, trunk upright.
    twin.settle(&mut d, [0.0; 2], 0.5, 1.5);
    let com0 = twin.com(&d);
    ctrl.com_offset = [com0[0], com0[1]];
    ctrl.reset_to_com([com0[0], com0[1]]);
    let mut last = twin.cells(&d);
    sensor.push(last);

    let n = (exp.duration / tc).round() as usize;
    let mut run = TwinRun::default();
    let mut next_frame = 0usize;
    let mut frames: Vec<f64> = frames.to_vec();
    frames.sort_by(f64::total_cmp);
    for k in 0..=n {
        let t = k as f64 * tc;
        if t >= exp.load_time {
            if let Some(m) = loaded.take() {
                // Keep the state across the model change; mj_setConst works on the data.
                let spec = MjtState::mjSTATE_INTEGRATION as u32;
                let state = d.state(spec);
                d.try_swap_model(m)
                    .map_err(|e| err(format!("adding the load: {e}")))?;
                d.set_const();
                d.set_state(&state, spec)
                    .map_err(|e| err(format!("adding the load: {e}")))?;
                d.forward();
            }
        }
        let zmp_ref = if k > 0 {
            exp.zmp_ref_after
        } else {
            exp.zmp_ref_before
        };
        let zmp = sensor
            .sample()
            .ok_or_else(|| err(format!("no load on the feet at t = {t:.2} s")))?;
        let com_ref = ctrl.step(zmp_ref, zmp);
        let theta = ctrl.theta();
        let com = twin.com(&d);
        run.trace.t.push(t);
        run.trace.zmp_ref.push(zmp_ref);
        run.trace.zmp.push(zmp);
        run.trace.com_ref.push(com_ref);
        run.trace.com.push([com[0], com[1]]);
        run.trace.theta.push(theta);
        run.zmp_true.push(
            last.zmp()
                .ok_or_else(|| err(format!("no load on the feet at t = {t:.2} s")))?,
        );
        run.theta_measured.push(twin.trunk_angles(&d));
        while next_frame < frames.len() && frames[next_frame] <= t + 0.5 * tc {
            capture(frames[next_frame], &mut d)?;
            next_frame += 1;
        }
        if k < n {
            twin.set_trunk(&mut d, theta);
            for _ in 0..sub {
                d.step();
                last = twin.cells(&d);
                sensor.push(last);
            }
        }
    }
    if !run.trace.zmp.iter().flatten().all(|v| v.is_finite()) {
        return Err(err("the closed loop diverged (non-finite ZMP)".into()));
    }
    Ok(run)
}

/// The identified model's prediction of the same experiment (`zmp_models::closed_loop::run`,
/// the in-process twin of the FMU pair).
pub fn run_model(
    spec: &ModelSpec,
    props: &MassProperties,
    exp: &StepExperiment,
) -> Result<ClosedLoopTrace, zmp_models::ModelError> {
    let mut plant = Plant::new(spec, zmp_models::DEFAULT_STEP)?;
    let mut ctrl = CascadeController::new(controller_params(props), exp.controller_period);
    Ok(run(&mut plant, &mut ctrl, exp))
}

/// Twin against model.
#[derive(Debug, Clone, Serialize)]
pub struct LoopComparison {
    /// The project's error measure for a time series: RMS of `zmp_twin - zmp_model` over the
    /// run divided by the RMS of the twin's ZMP excursion from its starting value (x axis).
    pub nrmse_x: f64,
    /// RMS of `zmp_twin - zmp_model`, m, per axis.
    pub rms_difference: [f64; 2],
    /// The same measure for the ZMP sensor's noise alone (what a perfect model would score).
    pub noise_floor_x: f64,
    /// The twin's step and load figures.
    pub twin: Metrics,
    /// The model's step and load figures.
    pub model: Metrics,
    /// Final trunk angles (mean of the last 10 s), rad: twin (measured) and model.
    pub final_theta_twin: f64,
    /// Final trunk angle of the model, rad.
    pub final_theta_model: f64,
}

/// Step and load figures (x axis), SI units.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Metrics {
    /// First time the ZMP reaches the new reference after the step, s (NaN if never).
    pub reach_time_s: f64,
    /// Time after which the ZMP stays within 2 % of the step of the reference, s (before the load).
    pub settling_time_2pct_s: f64,
    /// Largest excursion past the new reference, % of the step.
    pub overshoot_pct: f64,
    /// Largest ZMP deviation after the load is placed, m.
    pub load_peak_error_m: f64,
    /// Time from placing the load until the error stays within 2 % of the step, s.
    pub load_recovery_time_s: f64,
    /// Mean |zmp - reference| over the last 10 s, m.
    pub final_error_m: f64,
}

impl Metrics {
    /// The figures of the trace `tr` of experiment `exp`.
    pub fn of(tr: &ClosedLoopTrace, exp: &StepExperiment) -> Metrics {
        let m: StepMetrics = tr.metrics(0, exp);
        let tail: Vec<usize> = (0..tr.t.len())
            .filter(|&k| tr.t[k] >= exp.duration - 10.0)
            .collect();
        let final_error_m = tail
            .iter()
            .map(|&k| (tr.zmp[k][0] - tr.zmp_ref[k][0]).abs())
            .sum::<f64>()
            / tail.len().max(1) as f64;
        Metrics {
            reach_time_s: m.reach_time,
            settling_time_2pct_s: m.settling_time_2pct,
            overshoot_pct: 100.0 * m.overshoot,
            load_peak_error_m: m.load_peak_error,
            load_recovery_time_s: m.load_recovery_time,
            final_error_m,
        }
    }
}

/// Compares the twin's run (its true ZMP) with the model's (same time grid); the noise floor is
/// the RMS of the twin's measured minus true ZMP.
pub fn compare(twin: &TwinRun, model: &ClosedLoopTrace, exp: &StepExperiment) -> LoopComparison {
    let tw = &twin.true_trace();
    let n = tw.t.len().min(model.t.len());
    let rms =
        |f: &dyn Fn(usize) -> f64| (((0..n).map(|k| f(k).powi(2)).sum::<f64>()) / n as f64).sqrt();
    let diff = [
        rms(&|k| tw.zmp[k][0] - model.zmp[k][0]),
        rms(&|k| tw.zmp[k][1] - model.zmp[k][1]),
    ];
    let excursion = rms(&|k| tw.zmp[k][0] - tw.zmp[0][0]);
    let noise_rms = rms(&|k| twin.trace.zmp[k][0] - tw.zmp[k][0]);
    let tail = |v: &dyn Fn(usize) -> f64| {
        let ix: Vec<usize> = (0..n).filter(|&k| tw.t[k] >= exp.duration - 10.0).collect();
        ix.iter().map(|&k| v(k)).sum::<f64>() / ix.len().max(1) as f64
    };
    LoopComparison {
        nrmse_x: diff[0] / excursion,
        rms_difference: diff,
        noise_floor_x: noise_rms / excursion,
        twin: Metrics::of(tw, exp),
        model: Metrics::of(model, exp),
        final_theta_twin: tail(&|k| twin.theta_measured[k][0]),
        final_theta_model: tail(&|k| model.theta[k][0]),
    }
}
