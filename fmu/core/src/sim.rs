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

use crate::vars::{Kind, Role, VarTable};
use zmp_models::ModelSpec;

mod stepping;
mod values;

use stepping::Sim;

/// Tolerance of grid arithmetic, as a fraction of the internal step.
pub const GRID_TOL: f64 = 1e-6;

/// The internal time grid `t_n = t0 + n h`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Start time of the grid, s.
    pub t0: f64,
    /// Internal step, s.
    pub h: f64,
}

impl Grid {
    /// Time of grid point `n`, s.
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

impl Slave {
    /// A new instance of `kind` for the model file text `model_toml` (`file` names it in errors).
    pub fn new(kind: Kind, model_toml: &str, file: &str) -> Result<Slave, String> {
        let spec = ModelSpec::parse(model_toml, file).map_err(|e| e.to_string())?;
        Slave::from_spec(kind, spec)
    }

    /// A new instance of `kind` for a parsed model file (the error names what cannot be built).
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

    /// Which FMU this instance is.
    pub fn kind(&self) -> Kind {
        self.table.kind
    }

    /// The instance's variables: names, value references, units, bounds.
    pub fn table(&self) -> &VarTable {
        &self.table
    }

    /// Whether initialisation mode has ended (`fmi*ExitInitializationMode`).
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
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
