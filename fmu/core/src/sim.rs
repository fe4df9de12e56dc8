//! The co-simulation slave behind both FMI shells: variable values, initialisation and the
//! communication-step semantics. The physics is all in `zmp_models`.
//!
//! # Time grid
//!
//! Each FMU has a fixed internal step `h` (a parameter) and an internal time grid
//! `t_n = t_start + n h` (`n` an integer: time is never accumulated). A communication step
//! `[t, t + H]` may have any length `H > 0`:
//!
//! * **Plant.** The plant advances every grid step `t_n -> t_{n+1}` with `t_{n+1} <= t + H`.
//!   By default the CoM reference set at `t` is held constant over the whole communication step
//!   (FMI 2.0/3.0 co-simulation: inputs are constant over `[t, t + H]`), which the plant steps
//!   as the exact zero-order hold. When an input's first derivative is set
//!   (FMI 2.0 `fmi2SetRealInputDerivatives` with order 1; FMI 3.0 removed input derivatives
//!   from co-simulation, so the FMI 3.0 plant always holds), the input
//!   follows the line `u + du (tau - t_set)` instead (first-order hold), `t_set` the
//!   communication point at which the value or the derivative was last set; a derivative stays
//!   until it is set again. The outputs at `t + H` are those at the last grid point at or
//!   before `t + H`, computed with the input as it is there. An input set at a communication
//!   point between grid points therefore takes effect from the grid point before it, and a
//!   communication step shorter than `h` may leave the outputs unchanged: communication steps
//!   that are multiples of `h` are exact.
//!
//!   The operating point of `operating_point_dependence` is the CoM reference when
//!   initialisation ends (the inputs' values then), as a campaign record's operating point is
//!   the reference it starts from; the plant starts at rest there.
//! * **Controller.** Sample `n` is taken at `t_n` from the inputs current at that instant. The
//!   outputs depend directly on the inputs (the seed's cascade computes the CoM reference of
//!   sample `n` from the ZMP error at `t_n`): while the communication point is a sample instant
//!   whose sample has not yet been committed, getting an output evaluates that sample from the
//!   inputs just set, without committing it. `doStep(t, H)` commits every sample in
//!   `[t, t + H)`, all with the inputs set at `t`; between sample instants the outputs hold the
//!   last committed sample (zero-order hold).
//! * **Pass-through.** Outputs equal the inputs at all times.
//!
//! "At or before" allows a tolerance of `GRID_TOL * h` for rounding in the communication times.
//! `doStep` must start where the previous step ended (same tolerance); `H` must be positive and
//! finite.

use crate::vars::{Causality, CtrlParam, Kind, Role, VarTable};
use zmp_models::controller::{CascadeController, CascadeParams};
use zmp_models::{ModelSpec, Plant};

/// Tolerance of grid arithmetic, as a fraction of the internal step.
pub const GRID_TOL: f64 = 1e-6;

/// The internal time grid `t_n = t0 + n h`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    pub t0: f64,
    pub h: f64,
}

impl Grid {
    #[inline]
    pub fn time(&self, n: u64) -> f64 {
        self.t0 + n as f64 * self.h
    }

    #[inline]
    fn position(&self, t: f64) -> f64 {
        (t - self.t0) / self.h
    }

    /// Index of the last grid point at or before `t`.
    #[inline]
    pub fn floor(&self, t: f64) -> u64 {
        (self.position(t) + GRID_TOL).floor().max(0.0) as u64
    }

    /// Index of the first grid point at or after `t`.
    #[inline]
    pub fn ceil(&self, t: f64) -> u64 {
        (self.position(t) - GRID_TOL).ceil().max(0.0) as u64
    }

    /// `Some(n)` when `t` is grid point `n`.
    #[inline]
    pub fn on_grid(&self, t: f64) -> Option<u64> {
        let x = self.position(t);
        let n = x.round();
        ((x - n).abs() <= GRID_TOL && n >= 0.0).then_some(n as u64)
    }
}

/// The communication time as the importer drives it.
#[derive(Debug, Clone, Copy)]
struct CommClock {
    grid: Grid,
    /// End of the last communication step (the importer's value).
    t: f64,
}

impl CommClock {
    /// Checks `doStep(t, dt)`; returns the step's end.
    fn check(&self, t: f64, dt: f64) -> Result<f64, String> {
        if !t.is_finite() || !dt.is_finite() {
            return Err(format!(
                "doStep(currentCommunicationPoint = {t}, communicationStepSize = {dt}): not finite"
            ));
        }
        if dt <= 0.0 {
            return Err(format!(
                "doStep: communicationStepSize = {dt} s must be positive"
            ));
        }
        if (t - self.t).abs() > GRID_TOL * self.grid.h {
            return Err(format!(
                "doStep: currentCommunicationPoint = {t} s is not where the previous step ended \
                 ({} s)",
                self.t
            ));
        }
        let end = t + dt;
        if !end.is_finite() || self.grid.position(end) > 9.0e15 {
            return Err(format!(
                "doStep: t + H = {end} s is beyond the internal grid (h = {} s)",
                self.grid.h
            ));
        }
        Ok(end)
    }
}

#[derive(Debug)]
struct PlantSim {
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
struct ControllerSim {
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
enum Sim {
    Plant(PlantSim),
    Controller(ControllerSim),
    Passthrough(CommClock),
}

/// One FMU instance's model state, independent of the FMI version.
#[derive(Debug)]
pub struct Slave {
    table: VarTable,
    spec: ModelSpec,
    /// `(effect, index)` in `spec` of each model parameter.
    param_slots: Vec<(usize, usize)>,
    /// Current value of every variable, by index in the table.
    values: Vec<f64>,
    /// Table indices of the inputs and outputs, in role order.
    input_index: Vec<usize>,
    output_index: Vec<usize>,
    /// First time derivative of each input (FMI 2.0 `fmi2SetRealInputDerivatives`; the
    /// plant's only).
    input_derivative: [f64; 4],
    /// Communication time to which each input's value refers (its derivative's origin).
    input_time: [f64; 4],
    step_index: Option<usize>,
    sim: Option<Sim>,
    /// The simulation must be rebuilt before it is used (values changed before initialisation).
    stale: bool,
    outputs_dirty: bool,
    initialized: bool,
    t_start: f64,
}

fn unknown_vr(vr: u32) -> String {
    format!("unknown value reference {vr}")
}

impl Slave {
    /// A new instance of `kind` for the model file text `model_toml` (`file` names it in errors).
    pub fn new(kind: Kind, model_toml: &str, file: &str) -> Result<Slave, String> {
        let spec = ModelSpec::parse(model_toml, file).map_err(|e| e.to_string())?;
        Slave::from_spec(kind, spec)
    }

    pub fn from_spec(kind: Kind, spec: ModelSpec) -> Result<Slave, String> {
        let table = VarTable::new(kind, &spec)?;
        let param_slots = spec
            .parameters()
            .iter()
            .map(|p| (p.effect, p.index))
            .collect();
        let role_index = |want: fn(Role) -> Option<usize>, n: usize| {
            let mut idx = vec![usize::MAX; n];
            for (i, v) in table.vars.iter().enumerate() {
                if let Some(k) = want(v.role) {
                    idx[k] = i;
                }
            }
            idx
        };
        let input_index = role_index(
            |r| match r {
                Role::Input(k) => Some(k),
                _ => None,
            },
            table.n_inputs,
        );
        let output_index = role_index(
            |r| match r {
                Role::Output(k) => Some(k),
                _ => None,
            },
            table.n_outputs,
        );
        let step_index = table.vars.iter().position(|v| v.role == Role::Step);

        let values = table.vars.iter().map(|v| v.start).collect();
        Ok(Slave {
            table,
            spec,
            param_slots,
            values,
            input_index,
            output_index,
            input_derivative: [0.0; 4],
            input_time: [0.0; 4],
            step_index,
            sim: None,
            stale: true,
            outputs_dirty: false,
            initialized: false,
            t_start: 0.0,
        })
    }

    pub fn kind(&self) -> Kind {
        self.table.kind
    }

    pub fn table(&self) -> &VarTable {
        &self.table
    }

    pub fn is_initialized(&self) -> bool {
        self.initialized
    }

    /// Back to the state right after instantiation: start values, start time 0.
    pub fn reset(&mut self) {
        for (v, var) in self.values.iter_mut().zip(&self.table.vars) {
            *v = var.start;
        }
        self.sim = None;
        self.stale = true;
        self.outputs_dirty = false;
        self.initialized = false;
        self.t_start = 0.0;
        self.input_time = [0.0; 4];
        self.input_derivative = [0.0; 4];
    }

    /// Value of input `k` at time `t` (on its line when a derivative is set).
    fn input_at(&self, k: usize, t: f64) -> f64 {
        let u = self.values[self.input_index[k]];
        let du = self.input_derivative[k];
        if du == 0.0 {
            u
        } else {
            u + du * (t - self.input_time[k])
        }
    }

    /// The start time of the experiment (before initialisation).
    pub fn set_start_time(&mut self, t0: f64) -> Result<(), String> {
        if !t0.is_finite() {
            return Err(format!("start time {t0} is not finite"));
        }
        if self.initialized {
            return Err("the start time cannot change after initialisation".into());
        }
        self.t_start = t0;
        self.stale = true;
        Ok(())
    }

    /// Sets real variables; nothing is set unless every value is valid.
    pub fn set_real(&mut self, vrs: &[u32], vals: &[f64]) -> Result<(), String> {
        if vrs.len() != vals.len() {
            return Err("value reference and value arrays differ in length".into());
        }
        for (&vr, &v) in vrs.iter().zip(vals) {
            let i = self.table.index_of(vr).ok_or_else(|| unknown_vr(vr))?;
            let var = &self.table.vars[i];
            match var.causality {
                Causality::Output => {
                    return Err(format!("{} (value reference {vr}) is an output", var.name))
                }
                Causality::Parameter if self.initialized => {
                    return Err(format!(
                        "{} (value reference {vr}) is a fixed parameter: set it before \
                         initialisation ends",
                        var.name
                    ))
                }
                _ => {}
            }
            var.check(v)?;
        }
        let now = self.communication_time();
        for (&vr, &v) in vrs.iter().zip(vals) {
            let i = self.table.index_of(vr).expect("checked");
            // A new value starts the input's line now.
            if let Role::Input(k) = self.table.vars[i].role {
                self.input_time[k] = now;
            }
            self.values[i] = v;
        }
        if !self.initialized {
            self.stale = true;
        }
        self.outputs_dirty = true;
        Ok(())
    }

    /// `fmi2SetRealInputDerivatives`: sets the `orders[i]`-th time derivative of the input
    /// `vrs[i]`. First derivatives are used (the input follows its line over the
    /// communication step, see the module docs); higher ones are accepted and ignored, each
    /// named in the returned warnings. Nothing is set unless every argument is valid.
    pub fn set_input_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        vals: &[f64],
    ) -> Result<Vec<String>, String> {
        if vrs.len() != vals.len() || vrs.len() != orders.len() {
            return Err("value reference, order and value arrays differ in length".into());
        }
        if !self.table.interpolates_inputs() {
            return Err(format!(
                "the {} FMU does not use input derivatives (canInterpolateInputs = false)",
                self.table.kind.name()
            ));
        }
        let mut firsts = Vec::new();
        let mut warnings = Vec::new();
        for ((&vr, &order), &v) in vrs.iter().zip(orders).zip(vals) {
            let i = self.table.index_of(vr).ok_or_else(|| unknown_vr(vr))?;
            let var = &self.table.vars[i];
            let Role::Input(k) = var.role else {
                return Err(format!(
                    "{} (value reference {vr}) is not an input",
                    var.name
                ));
            };
            if order < 1 {
                return Err(format!(
                    "order {order} for {}: derivative orders start at 1",
                    var.name
                ));
            }
            if !v.is_finite() {
                return Err(format!(
                    "derivative of order {order} of {} = {v}: not a finite number",
                    var.name
                ));
            }
            if order == 1 {
                firsts.push((k, v));
            } else {
                warnings.push(format!(
                    "derivative of order {order} of {} ignored: only first derivatives are used",
                    var.name
                ));
            }
        }
        let now = self.communication_time();
        for (k, du) in firsts {
            // A new slope: the line goes on from where the input is now.
            let u = self.input_at(k, now);
            self.values[self.input_index[k]] = u;
            self.input_time[k] = now;
            self.input_derivative[k] = du;
        }
        if !self.initialized {
            self.stale = true;
        }
        self.outputs_dirty = true;
        Ok(warnings)
    }

    /// Gets real variables.
    pub fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Result<(), String> {
        if vrs.len() != out.len() {
            return Err("value reference and value arrays differ in length".into());
        }
        if self.outputs_dirty || self.stale {
            self.refresh_outputs()?;
        }
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            let i = self.table.index_of(vr).ok_or_else(|| unknown_vr(vr))?;
            *o = self.values[i];
        }
        Ok(())
    }

    /// Value of the variable at table index `i` (outputs as of the last refresh).
    pub fn value(&self, i: usize) -> f64 {
        self.values[i]
    }

    /// Value of value reference `vr` (outputs as of the last [`Slave::refresh`]).
    #[inline]
    pub fn value_of(&self, vr: u32) -> Option<f64> {
        self.table.index_of(vr).map(|i| self.values[i])
    }

    /// Brings the outputs up to date with the inputs and parameters set (before
    /// initialisation: builds a preview of the initial state).
    pub fn refresh(&mut self) -> Result<(), String> {
        if self.outputs_dirty || self.stale {
            self.refresh_outputs()?;
        }
        Ok(())
    }

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
    fn refresh_outputs(&mut self) -> Result<(), String> {
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

    const PAPER: &str = include_str!("../../../models/params/silo2-paper.toml");

    fn vr(s: &Slave, name: &str) -> u32 {
        s.table().by_name(name).unwrap().vr
    }

    #[test]
    fn grid_rounding() {
        let g = Grid { t0: 0.0, h: 1e-3 };
        assert_eq!(g.floor(0.0025), 2);
        assert_eq!(g.floor(0.003 - 1e-15), 3);
        assert_eq!(g.ceil(0.0025), 3);
        assert_eq!(g.ceil(0.003 + 1e-15), 3);
        assert_eq!(g.on_grid(0.1 + 0.2), Some(300));
        assert_eq!(g.on_grid(0.0005), None);
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
