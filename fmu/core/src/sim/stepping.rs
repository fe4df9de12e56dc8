//! The simulations behind the slave and the communication step: building the plant,
//! controller or pass-through from the values set, initialisation, `doStep` on the internal
//! grid.

use super::{CommClock, Grid, Slave};
use crate::vars::{CtrlParam, Kind, Role};
use zmp_models::controller::{CascadeController, CascadeParams};
use zmp_models::Plant;

#[derive(Debug)]
pub(super) struct PlantSim {
    plant: Plant,
    clock: CommClock,
    n: u64,
    out: [f64; 4],
}

impl PlantSim {
    fn outputs(o: zmp_models::PlantOutput) -> [f64; 4] {
        [o.zmp[0], o.zmp[1], o.com[0], o.com[1]]
    }
}

#[derive(Debug, Clone)]
pub(super) struct ControllerSim {
    committed: CascadeController,
    clock: CommClock,
    /// First sample not yet committed.
    next: u64,
    /// `[x_cr, y_cr, theta_x, theta_y]` of the last committed sample (at rest before any).
    last: [f64; 4],
}

impl ControllerSim {
    fn sample_outputs(c: &mut CascadeController, inputs: &[f64]) -> [f64; 4] {
        let r = c.step([inputs[0], inputs[1]], [inputs[2], inputs[3]]);
        let th = c.theta();
        [r[0], r[1], th[0], th[1]]
    }

    fn outputs(&self, inputs: &[f64]) -> [f64; 4] {
        match self.clock.grid.on_grid(self.clock.t) {
            Some(n) if n == self.next => {
                let mut c = self.committed.clone();
                Self::sample_outputs(&mut c, inputs)
            }
            _ => self.last,
        }
    }
}

#[derive(Debug)]
// One per instance, never moved in the hot path: the size difference does not matter.
#[allow(clippy::large_enum_variant)]
pub(super) enum Sim {
    Plant(PlantSim),
    Controller(ControllerSim),
    Passthrough(CommClock),
}

impl Slave {
    fn step_size(&self) -> f64 {
        self.step_index.map(|i| self.values[i]).unwrap_or(1e-3)
    }

    fn build_sim(&self) -> Result<Sim, String> {
        let h = self.step_size();
        let grid = Grid {
            t0: self.t_start,
            h,
        };
        let clock = CommClock {
            grid,
            t: self.t_start,
        };
        let input = |k: usize| self.values[self.input_index[k]];
        Ok(match self.table.kind {
            Kind::Plant => {
                let mut spec = self.spec.clone();
                for (p, var) in self.table.vars.iter().enumerate() {
                    if let Role::ModelParam(k) = var.role {
                        let (e, j) = self.param_slots[k];
                        spec.effects[e].values[j] = self.values[p];
                    }
                }
                let mut plant = Plant::new(&spec, h).map_err(|e| e.to_string())?;
                // The operating point is the reference the plant starts at rest from.
                plant.set_operating_point([input(0), input(1)]);
                let out = plant.reset([input(0), input(1)]);
                Sim::Plant(PlantSim {
                    plant,
                    clock,
                    n: 0,
                    out: PlantSim::outputs(out),
                })
            }
            Kind::Controller => {
                let get = |c: CtrlParam| {
                    let i = self
                        .table
                        .vars
                        .iter()
                        .position(|v| v.role == Role::Controller(c))
                        .expect("every controller parameter is in the table");
                    self.values[i]
                };
                let p = CascadeParams {
                    k1: get(CtrlParam::K1),
                    k2: get(CtrlParam::K2),
                    error_scale: get(CtrlParam::ErrorScale),
                    mass_ratio: get(CtrlParam::MassRatio),
                    trunk_length: get(CtrlParam::TrunkLength),
                    theta_min: get(CtrlParam::ThetaMin),
                    theta_max: get(CtrlParam::ThetaMax),
                };
                if p.theta_min > p.theta_max {
                    return Err(format!(
                        "theta_min = {} rad must not exceed theta_max = {} rad",
                        p.theta_min, p.theta_max
                    ));
                }
                let offset = [get(CtrlParam::OffsetX), get(CtrlParam::OffsetY)];
                let mut c = CascadeController::new(p, h);
                c.com_offset = offset;
                c.reset_to_com(offset);
                let th = c.theta();
                let g = p.trunk_gain();
                let last = [offset[0] + g * th[0], offset[1] + g * th[1], th[0], th[1]];
                Sim::Controller(ControllerSim {
                    committed: c,
                    clock,
                    next: 0,
                    last,
                })
            }
            Kind::Passthrough => Sim::Passthrough(clock),
        })
    }

    /// Recomputes the outputs into `values` (building a preview of the initial state before
    /// initialisation).
    pub(super) fn refresh_outputs(&mut self) -> Result<(), String> {
        if self.stale || self.sim.is_none() {
            self.sim = Some(self.build_sim()?);
            self.stale = false;
        }
        let out = match self.sim.as_ref().expect("built") {
            Sim::Plant(p) => p.out,
            Sim::Controller(c) => {
                let inputs: [f64; 4] = std::array::from_fn(|k| self.values[self.input_index[k]]);
                c.outputs(&inputs)
            }
            Sim::Passthrough(_) => {
                let u = [
                    self.values[self.input_index[0]],
                    self.values[self.input_index[1]],
                ];
                [u[0], u[1], u[0], u[1]]
            }
        };
        for (k, &i) in self.output_index.iter().enumerate() {
            self.values[i] = out[k];
        }
        self.outputs_dirty = false;
        Ok(())
    }

    /// Ends initialisation: builds the simulation from the parameter and input values set.
    pub fn initialize(&mut self) -> Result<(), String> {
        if self.initialized {
            return Err("already initialised".into());
        }
        self.sim = Some(self.build_sim()?);
        self.stale = false;
        self.initialized = true;
        // Values and derivatives set so far refer to the start time.
        self.input_time = [self.t_start; 4];
        self.refresh_outputs()
    }

    /// End of the last communication step (the start time before any).
    pub fn communication_time(&self) -> f64 {
        match &self.sim {
            Some(Sim::Plant(p)) => p.clock.t,
            Some(Sim::Controller(c)) => c.clock.t,
            Some(Sim::Passthrough(c)) => c.t,
            None => self.t_start,
        }
    }

    /// One communication step `[t, t + dt]`.
    pub fn do_step(&mut self, t: f64, dt: f64) -> Result<(), String> {
        if !self.initialized {
            return Err("doStep before initialisation has ended".into());
        }
        let inputs: [f64; 4] = std::array::from_fn(|k| {
            self.input_index
                .get(k)
                .map(|&i| self.values[i])
                .unwrap_or(0.0)
        });
        let ramps = self.input_derivative.iter().any(|d| *d != 0.0);
        // The plant's inputs on their lines (first-order hold), at grid time `tau`.
        let line: [(f64, f64, f64); 2] =
            std::array::from_fn(|k| (inputs[k], self.input_derivative[k], self.input_time[k]));
        let at = |k: usize, tau: f64| line[k].0 + line[k].1 * (tau - line[k].2);
        match self.sim.as_mut().expect("initialised") {
            Sim::Plant(p) => {
                let end = p.clock.check(t, dt)?;
                let n1 = p.clock.grid.floor(end);
                if n1 > p.n {
                    let out = if ramps {
                        let mut out = p.plant.last_output();
                        for m in p.n..n1 {
                            let (ta, tb) = (p.clock.grid.time(m), p.clock.grid.time(m + 1));
                            let (ua, ub) = ([at(0, ta), at(1, ta)], [at(0, tb), at(1, tb)]);
                            if !ua.iter().chain(&ub).all(|v| v.is_finite()) {
                                return Err(format!(
                                    "the inputs on their derivatives' lines are no longer \
                                     finite at t = {tb} s"
                                ));
                            }
                            out = p.plant.step_from(ua, ub);
                        }
                        out
                    } else {
                        // Held over the step: the exact zero-order hold.
                        p.plant.advance([inputs[0], inputs[1]], (n1 - p.n) as usize)
                    };
                    p.n = n1;
                    p.out = PlantSim::outputs(out);
                    if p.out.iter().any(|v| !v.is_finite()) {
                        return Err(format!(
                            "the plant's outputs are no longer finite at t = {} s: check the \
                             parameters",
                            p.clock.grid.time(n1)
                        ));
                    }
                }
                p.clock.t = end;
            }
            Sim::Controller(c) => {
                let end = c.clock.check(t, dt)?;
                let m_end = c.clock.grid.ceil(end);
                while c.next < m_end {
                    c.last = ControllerSim::sample_outputs(&mut c.committed, &inputs);
                    c.next += 1;
                }
                c.clock.t = end;
            }
            Sim::Passthrough(c) => {
                c.t = c.check(t, dt)?;
            }
        }
        self.outputs_dirty = true;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use zmp_models::ModelSpec;

    const PAPER: &str = include_str!("../../../../models/params/silo2-paper.toml");

    fn vr(s: &Slave, name: &str) -> u32 {
        s.table().by_name(name).unwrap().vr
    }

    /// Controller samples: every communication-step length gives the samples of the plain
    /// `CascadeController` stepped at t_n with the inputs current at t_n.
    #[test]
    fn controller_samples_whatever_the_communication_step() {
        let ts = 0.01;
        let zref = |t: f64| 0.12 + 0.05 * (t > 0.0) as i32 as f64;
        let zmp = |t: f64| 0.12 + 0.02 * (3.0 * t).sin();
        // Reference: one sample per 10 ms, inputs at the sample instant.
        let mut reference = Vec::new();
        {
            let mut s = Slave::new(Kind::Controller, PAPER, "p").unwrap();
            s.initialize().unwrap();
            let (vin, vout) = ([vr(&s, "zmp_ref_x"), vr(&s, "zmp_x")], [vr(&s, "x_cr")]);
            for k in 0..100 {
                let t = k as f64 * ts;
                s.set_real(&vin, &[zref(t), zmp(t)]).unwrap();
                let mut o = [0.0];
                s.get_real(&vout, &mut o).unwrap();
                reference.push(o[0]);
                s.do_step(t, ts).unwrap();
            }
        }
        // Half steps: inputs set at every sample instant and in between; outputs at sample
        // instants are the same samples, in between they hold.
        let mut s = Slave::new(Kind::Controller, PAPER, "p").unwrap();
        s.initialize().unwrap();
        let (vin, vout) = ([vr(&s, "zmp_ref_x"), vr(&s, "zmp_x")], [vr(&s, "x_cr")]);
        let mut held = 0.0;
        for k in 0..200 {
            let t = k as f64 * ts / 2.0;
            s.set_real(&vin, &[zref(t), zmp(t)]).unwrap();
            let mut o = [0.0];
            s.get_real(&vout, &mut o).unwrap();
            if k % 2 == 0 {
                assert_eq!(o[0], reference[k / 2], "sample {}", k / 2);
                held = o[0];
            } else {
                assert_eq!(o[0], held, "between samples the output holds");
            }
            s.do_step(t, ts / 2.0).unwrap();
        }
    }

    /// `operating_point_dependence` acts in the FMU: its parameters change the outputs, and
    /// the operating point is the CoM reference at initialisation (as the in-process plant
    /// with `set_operating_point` at that reference).
    #[test]
    fn operating_point_dependence_acts_at_the_initial_reference() {
        let text = format!("{PAPER}\n[operating_point_dependence]\nda_dx = 2.0\ndb_dy = -3.0\n");
        let spec = ModelSpec::parse(&text, "op.toml").unwrap();
        let op = [0.05, 0.03];
        let run = |da_dx: f64| {
            let mut s = Slave::from_spec(Kind::Plant, spec.clone()).unwrap();
            let (x, y) = (vr(&s, "x_cr"), vr(&s, "y_cr"));
            let p = vr(&s, "operating_point_dependence.da_dx");
            s.set_real(&[x, y, p], &[op[0], op[1], da_dx]).unwrap();
            s.initialize().unwrap();
            let mut zmp = Vec::new();
            for k in 0..300 {
                let u = [op[0] + 0.004 * (3e-3 * k as f64).sin(), op[1]];
                s.set_real(&[x, y], &u).unwrap();
                s.do_step(k as f64 * 1e-3, 1e-3).unwrap();
                let mut o = [0.0; 2];
                s.get_real(&[vr(&s, "zmp_x"), vr(&s, "zmp_y")], &mut o)
                    .unwrap();
                zmp.push(o);
            }
            zmp
        };
        let fmu = run(2.0);
        let mut plant = Plant::new(&spec, 1e-3).unwrap();
        plant.set_operating_point(op);
        plant.reset(op);
        for (k, got) in fmu.iter().enumerate() {
            let u = [op[0] + 0.004 * (3e-3 * k as f64).sin(), op[1]];
            let want = plant.advance(u, 1).zmp;
            for i in 0..2 {
                assert!(
                    (got[i] - want[i]).abs() < 1e-15,
                    "step {k}: {got:?} vs {want:?}"
                );
            }
        }
        // The parameter does something: a(op) = a (1 + da_dx x) moves the ZMP by ~10 %.
        let flat = run(0.0);
        let moved = (fmu[299][0] - flat[299][0]).abs() / flat[299][0].abs();
        assert!(moved > 0.05, "da_dx changed zmp_x by only {moved:.2e}");
    }

    /// A per-channel operating-point dependence and a drift whose rate changes from record
    /// to record are FMU parameters like every other: `operating_point_dependence.G12.da_dx`
    /// (a channel's own slope) moves the outputs as the in-process plant's does, and the
    /// drift's seed takes whole numbers only. An FMU runs record 0.
    #[test]
    fn per_channel_slopes_and_record_drift_are_fmu_parameters() {
        let text = format!(
            "{PAPER}\n[operating_point_dependence.G12]\nda_dy = 4.0\n\
             [sensor_drift]\nrate = 1e-4\nrate_spread = 2e-4\nrate_seed = 3\n"
        );
        let spec = ModelSpec::parse(&text, "pc.toml").unwrap();
        let op = [0.02, 0.05];
        let run = |slope: f64| {
            let mut s = Slave::from_spec(Kind::Plant, spec.clone()).unwrap();
            let (x, y) = (vr(&s, "x_cr"), vr(&s, "y_cr"));
            let p = vr(&s, "operating_point_dependence.G12.da_dy");
            s.set_real(&[x, y, p], &[op[0], op[1], slope]).unwrap();
            let seed = vr(&s, "sensor_drift.x.rate_seed");
            let e = s.set_real(&[seed], &[2.5]).unwrap_err();
            assert!(e.contains("whole number"), "{e}");
            s.initialize().unwrap();
            let mut zmp = Vec::new();
            for k in 0..300 {
                let u = [op[0], op[1] + 0.004 * (3e-3 * k as f64).sin()];
                s.set_real(&[x, y], &u).unwrap();
                s.do_step(k as f64 * 1e-3, 1e-3).unwrap();
                let mut o = [0.0; 2];
                s.get_real(&[vr(&s, "zmp_x"), vr(&s, "zmp_y")], &mut o)
                    .unwrap();
                zmp.push(o);
            }
            zmp
        };
        let fmu = run(4.0);
        let mut plant = Plant::new(&spec, 1e-3).unwrap();
        plant.set_record(0);
        plant.set_operating_point(op);
        plant.reset(op);
        for (k, got) in fmu.iter().enumerate() {
            let u = [op[0], op[1] + 0.004 * (3e-3 * k as f64).sin()];
            let want = plant.advance(u, 1).zmp;
            for i in 0..2 {
                assert!(
                    (got[i] - want[i]).abs() < 1e-15,
                    "step {k}: {got:?} vs {want:?}"
                );
            }
        }
        // G12's slope moves zmp_x (a12 op_y da_dy of the static map and more).
        let flat = run(0.0);
        let moved = (fmu[299][0] - flat[299][0]).abs();
        assert!(moved > 1e-4, "G12.da_dy moved zmp_x by only {moved:.2e} m");
    }

    /// Plant: a step of n h equals n steps of h with the same held input.
    #[test]
    fn plant_long_step_equals_sub_steps() {
        let mut a = Slave::new(Kind::Plant, PAPER, "p").unwrap();
        let mut b = Slave::new(Kind::Plant, PAPER, "p").unwrap();
        a.initialize().unwrap();
        b.initialize().unwrap();
        let (x, z) = (vr(&a, "x_cr"), vr(&a, "zmp_x"));
        a.set_real(&[x], &[0.2]).unwrap();
        b.set_real(&[x], &[0.2]).unwrap();
        a.do_step(0.0, 0.05).unwrap();
        for k in 0..50 {
            b.do_step(k as f64 * 1e-3, 1e-3).unwrap();
        }
        let (mut oa, mut ob) = ([0.0], [0.0]);
        a.get_real(&[z], &mut oa).unwrap();
        b.get_real(&[z], &mut ob).unwrap();
        assert!((oa[0] - ob[0]).abs() < 1e-15, "{} vs {}", oa[0], ob[0]);
        assert!(oa[0] > 0.13, "the plant moved: {}", oa[0]);
    }
}
