//! Getting and setting the slave's variables: values, input derivatives, the outputs on
//! demand.

use super::Slave;
use crate::vars::{Causality, Role};

fn unknown_vr(vr: u32) -> String {
    format!("unknown value reference {vr}")
}

impl Slave {
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
}
