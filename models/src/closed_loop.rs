//! Plant and cascade controller in closed loop: the seed's experiment of section 6.6.
//! The ZMP reference steps 0.12 -> 0.17 m at t = 0; at t = 80 s a 4 kg mass is placed on the
//! robot's right side.
//!
//! The load is modelled statically on the measured ZMP: the force plates see the ZMP of robot
//! plus load, `(M zmp + m p_load)/(M + m)`. The seed does not give where the mass was set; we
//! place it 0.30 m out on the lateral axis, which moves the measured ZMP by about 1 cm.

use crate::controller::CascadeController;
use crate::plant::Plant;

/// The experiment's design.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepExperiment {
    /// ZMP reference before and after the step at t = 0, m.
    pub zmp_ref_before: [f64; 2],
    /// ZMP reference after the step, m.
    pub zmp_ref_after: [f64; 2],
    /// When the load is placed, s.
    pub load_time: f64,
    /// Mass of the load, kg.
    pub load_mass: f64,
    /// Mass of the robot without the load, kg.
    pub robot_mass: f64,
    /// Where the load sits, absolute ZMP-plane coordinates, m.
    pub load_position: [f64; 2],
    /// Length of the run, s.
    pub duration: f64,
    /// Controller sample period, s; a whole number of plant steps.
    pub controller_period: f64,
}

impl StepExperiment {
    /// Section 6.6 of the first seed.
    pub fn silo2() -> StepExperiment {
        StepExperiment {
            zmp_ref_before: [0.12, 0.0],
            zmp_ref_after: [0.17, 0.0],
            load_time: 80.0,
            load_mass: 4.0,
            robot_mass: 48.0,
            load_position: [0.30, 0.0],
            duration: 160.0,
            controller_period: 0.01,
        }
    }
}

/// Time series of a closed-loop run, one sample per controller period.
#[derive(Debug, Clone, Default)]
pub struct ClosedLoopTrace {
    /// Sample times, s.
    pub t: Vec<f64>,
    /// ZMP reference, m.
    pub zmp_ref: Vec<[f64; 2]>,
    /// Measured ZMP (load included), m.
    pub zmp: Vec<[f64; 2]>,
    /// CoM reference the controller sends to the plant, m.
    pub com_ref: Vec<[f64; 2]>,
    /// CoM position of the plant, m.
    pub com: Vec<[f64; 2]>,
    /// Trunk angle, rad.
    pub theta: Vec<[f64; 2]>,
}

/// Step-response figures of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepMetrics {
    /// First time the ZMP reaches the new set point, s (NaN if never).
    pub reach_time: f64,
    /// Time after which the ZMP stays within 2 % of the step of the set point, s (before the load).
    pub settling_time_2pct: f64,
    /// Largest excursion past the set point, as a fraction of the step.
    pub overshoot: f64,
    /// Largest ZMP deviation after the load is placed, m.
    pub load_peak_error: f64,
    /// Time from placing the load until the error stays within 2 % of the step, s.
    pub load_recovery_time: f64,
}

/// CoM reference that holds the plant's ZMP at `zmp` (solves `a c = zmp`, `a` at the plant's
/// operating point).
pub fn com_for_zmp(plant: &Plant, zmp: [f64; 2]) -> [f64; 2] {
    let a = plant.pendulum_at_operating_point().0;
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    [
        (a[1][1] * zmp[0] - a[0][1] * zmp[1]) / det,
        (-a[1][0] * zmp[0] + a[0][0] * zmp[1]) / det,
    ]
}

/// Runs the experiment from rest at the initial reference.
pub fn run(
    plant: &mut Plant,
    ctrl: &mut CascadeController,
    exp: &StepExperiment,
) -> ClosedLoopTrace {
    let h = plant.step_size();
    let sub = (exp.controller_period / h).round().max(1.0) as usize;
    let tc = sub as f64 * h;
    let com0 = com_for_zmp(plant, exp.zmp_ref_before);
    plant.reset(com0);
    // The trunk is upright at the initial operating point.
    ctrl.com_offset = com0;
    ctrl.reset_to_com(com0);
    let n = (exp.duration / tc).round() as usize;
    let mut tr = ClosedLoopTrace::default();
    let measure = |zmp: [f64; 2], t: f64| -> [f64; 2] {
        if t >= exp.load_time {
            let m = exp.robot_mass + exp.load_mass;
            [
                (exp.robot_mass * zmp[0] + exp.load_mass * exp.load_position[0]) / m,
                (exp.robot_mass * zmp[1] + exp.load_mass * exp.load_position[1]) / m,
            ]
        } else {
            zmp
        }
    };
    let mut out = plant.last_output();
    for k in 0..=n {
        // Time as k * period, never accumulated.
        let t = k as f64 * tc;
        let zmp_ref = if t >= 0.0 && k > 0 {
            exp.zmp_ref_after
        } else {
            exp.zmp_ref_before
        };
        let zmp = measure(out.zmp, t);
        let com_ref = ctrl.step(zmp_ref, zmp);
        tr.t.push(t);
        tr.zmp_ref.push(zmp_ref);
        tr.zmp.push(zmp);
        tr.com_ref.push(com_ref);
        tr.com.push(out.com);
        tr.theta.push(ctrl.theta());
        if k < n {
            out = plant.advance(com_ref, sub);
        }
    }
    tr
}

impl ClosedLoopTrace {
    /// Step and load figures of `axis` (0 = x) for the experiment that produced the trace.
    pub fn metrics(&self, axis: usize, exp: &StepExperiment) -> StepMetrics {
        let target = exp.zmp_ref_after[axis];
        let step = target - exp.zmp_ref_before[axis];
        let band = 0.02 * step.abs();
        let before: Vec<usize> = (0..self.t.len())
            .filter(|&k| self.t[k] < exp.load_time)
            .collect();
        let reach_time = before
            .iter()
            .find(|&&k| (self.zmp[k][axis] - target) * step.signum() >= 0.0)
            .map(|&k| self.t[k])
            .unwrap_or(f64::NAN);
        let last_out = before
            .iter()
            .rev()
            .find(|&&k| (self.zmp[k][axis] - target).abs() > band);
        let settling_time_2pct = last_out
            .map(|&k| self.t[(k + 1).min(self.t.len() - 1)])
            .unwrap_or(0.0);
        let overshoot = before
            .iter()
            .map(|&k| (self.zmp[k][axis] - target) * step.signum() / step.abs())
            .fold(0.0, f64::max);
        let after: Vec<usize> = (0..self.t.len())
            .filter(|&k| self.t[k] >= exp.load_time)
            .collect();
        let load_peak_error = after
            .iter()
            .map(|&k| (self.zmp[k][axis] - target).abs())
            .fold(0.0, f64::max);
        let load_recovery_time = after
            .iter()
            .rev()
            .find(|&&k| (self.zmp[k][axis] - target).abs() > band)
            .map(|&k| self.t[(k + 1).min(self.t.len() - 1)] - exp.load_time)
            .unwrap_or(0.0);
        StepMetrics {
            reach_time,
            settling_time_2pct,
            overshoot,
            load_peak_error,
            load_recovery_time,
        }
    }
}
