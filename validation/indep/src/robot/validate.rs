//! The robot's parameter checks: every sign and range, with the field named in the error.

use super::{AxisMechanics, CrossCoupling, FlexibleMode, Friction, Noise, Robot, Transmission};

impl Robot {
    /// Checks every parameter's sign and range; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        for i in 0..2 {
            for j in 0..2 {
                finite(self.pendulum.a[i][j], &format!("pendulum.a[{i}][{j}]"))?;
                finite(self.pendulum.b[i][j], &format!("pendulum.b[{i}][{j}]"))?;
            }
        }
        for (k, axis) in self.axes.iter().enumerate() {
            validate_axis(axis, ["x", "y"][k])?;
        }
        if let Some(c) = &self.cross_coupling {
            validate_coupling(c, &self.axes)?;
        }
        if let Some(op) = &self.op_dependence {
            for k in 0..2 {
                finite(op.a_slope[k], &format!("op_dependence.a_slope[{k}]"))?;
                finite(op.b_slope[k], &format!("op_dependence.b_slope[{k}]"))?;
            }
        }
        if let Some(op) = &self.op_per_channel {
            for i in 0..2 {
                for j in 0..2 {
                    for k in 0..2 {
                        let at = format!("[{i}][{j}][{k}]");
                        finite(op.a_slope[i][j][k], &format!("op_per_channel.a_slope{at}"))?;
                        finite(op.b_slope[i][j][k], &format!("op_per_channel.b_slope{at}"))?;
                    }
                }
            }
        }
        if let Some(z) = &self.sensor.rezero {
            for (i, v) in z.spread.iter().enumerate() {
                if !(v.is_finite() && *v >= 0.0) {
                    return Err(format!("sensor.rezero.spread[{i}] must be >= 0, got {v}"));
                }
            }
        }
        if let Some(c) = self.sensor.lowpass_cutoff {
            positive(c[0], "sensor.lowpass_cutoff[0]")?;
            positive(c[1], "sensor.lowpass_cutoff[1]")?;
        }
        finite(self.sensor.drift_rate[0], "sensor.drift_rate[0]")?;
        finite(self.sensor.drift_rate[1], "sensor.drift_rate[1]")?;
        validate_noise(&self.sensor.noise, "sensor.noise")
    }
}

/// `v` must be a finite number; the error names the field `what`.
fn finite(v: f64, what: &str) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{what} must be finite, got {v}"))
    }
}

/// `v` must be positive and finite; the error names the field `what`.
fn positive(v: f64, what: &str) -> Result<(), String> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(format!("{what} must be positive and finite, got {v}"))
    }
}

/// Checks the mechanics of the axis named `n` (`x` or `y`): servo, delay, drive share,
/// transmission, friction and flexible modes.
fn validate_axis(axis: &AxisMechanics, n: &str) -> Result<(), String> {
    positive(axis.servo.omega_n, &format!("axes.{n}.servo.omega_n"))?;
    positive(axis.servo.zeta, &format!("axes.{n}.servo.zeta"))?;
    positive(
        axis.servo.accel_limit,
        &format!("axes.{n}.servo.accel_limit"),
    )?;
    if let Some(v) = axis.servo.velocity_limit {
        positive(v, &format!("axes.{n}.servo.velocity_limit"))?;
    }
    if !(axis.command_delay.is_finite() && axis.command_delay >= 0.0) {
        return Err(format!(
            "axes.{n}.command_delay must be >= 0, got {}",
            axis.command_delay
        ));
    }
    let mu = axis.drive_mass_fraction;
    if !(mu > 0.0 && mu < 1.0) {
        return Err(format!(
            "axes.{n}.drive_mass_fraction must lie in (0, 1), got {mu}"
        ));
    }
    if let Some(t) = &axis.transmission {
        validate_transmission(t, n)?;
    }
    if let Some(f) = &axis.friction {
        validate_friction(f, n)?;
    }
    validate_modes(&axis.modes, n)
}

/// Checks the transmission of the axis named `n`.
fn validate_transmission(t: &Transmission, n: &str) -> Result<(), String> {
    if !(t.play.is_finite() && t.play >= 0.0) {
        return Err(format!(
            "axes.{n}.transmission.play must be >= 0, got {}",
            t.play
        ));
    }
    positive(t.omega, &format!("axes.{n}.transmission.omega"))?;
    positive(t.zeta, &format!("axes.{n}.transmission.zeta"))?;
    if let Some(d) = t.hardening_deflection {
        positive(d, &format!("axes.{n}.transmission.hardening_deflection"))?;
    }
    if let Some(d) = t.load_drag_time {
        positive(d, &format!("axes.{n}.transmission.load_drag_time"))?;
    }
    Ok(())
}

/// Checks the friction of the axis named `n`: the static level at least the kinetic.
fn validate_friction(f: &Friction, n: &str) -> Result<(), String> {
    positive(f.kinetic, &format!("axes.{n}.friction.kinetic"))?;
    if !(f.static_level.is_finite() && f.static_level >= f.kinetic) {
        return Err(format!(
            "axes.{n}.friction.static_level must be >= kinetic ({}), got {}",
            f.kinetic, f.static_level
        ));
    }
    if let Some(v) = f.stribeck_velocity {
        positive(v, &format!("axes.{n}.friction.stribeck_velocity"))?;
    }
    Ok(())
}

/// Checks the flexible modes of the axis named `n`: at most two, each mass share in (0, 1).
fn validate_modes(modes: &[FlexibleMode], n: &str) -> Result<(), String> {
    if modes.len() > 2 {
        return Err(format!(
            "axes.{n}.modes: at most 2 flexible links, got {}",
            modes.len()
        ));
    }
    for (m, mode) in modes.iter().enumerate() {
        positive(mode.omega, &format!("axes.{n}.modes[{m}].omega"))?;
        positive(mode.zeta, &format!("axes.{n}.modes[{m}].zeta"))?;
        if !(mode.mass_fraction > 0.0 && mode.mass_fraction < 1.0) {
            return Err(format!(
                "axes.{n}.modes[{m}].mass_fraction must lie in (0, 1), got {}",
                mode.mass_fraction
            ));
        }
    }
    Ok(())
}

/// Checks a cross-axis coupling; an inertial one must keep the loop gain of the two joints'
/// loads, solved together, below 0.5.
fn validate_coupling(c: &CrossCoupling, axes: &[AxisMechanics; 2]) -> Result<(), String> {
    match c {
        CrossCoupling::Pendulum {
            da12,
            da21,
            db12,
            db21,
        } => {
            for (v, w) in [
                (da12, "da12"),
                (da21, "da21"),
                (db12, "db12"),
                (db21, "db21"),
            ] {
                finite(*v, &format!("cross_coupling.{w}"))?;
            }
        }
        CrossCoupling::Inertial { kappa_xy, kappa_yx } => {
            for (v, w) in [(kappa_xy, "kappa_xy"), (kappa_yx, "kappa_yx")] {
                if !(v.is_finite() && v.abs() < 1.0) {
                    return Err(format!("cross_coupling.{w} must lie in (-1, 1), got {v}"));
                }
            }
            // The two joints' loads are solved together; the loop gain κ_xy κ_yx / (L_x L_y)
            // (L the load share behind a transmission) must stay well below 1.
            let load = |a: &AxisMechanics| {
                if a.transmission.is_some() {
                    1.0 - a.drive_mass_fraction
                } else {
                    1.0
                }
            };
            let gain = (kappa_xy * kappa_yx).abs() / (load(&axes[0]) * load(&axes[1]));
            if gain >= 0.5 {
                return Err(format!(
                    "cross_coupling: kappa_xy * kappa_yx / (load_x * load_y) = {gain} must stay below 0.5"
                ));
            }
        }
    }
    Ok(())
}

/// Checks a noise law; the message names the field under `what`.
pub(crate) fn validate_noise(n: &Noise, what: &str) -> Result<(), String> {
    for (v, f) in [(n.white_std, "white_std"), (n.coloured_std, "coloured_std")] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(format!("{what}.{f} must be >= 0, got {v}"));
        }
    }
    if !(n.coloured_tau.is_finite() && n.coloured_tau > 0.0) {
        return Err(format!(
            "{what}.coloured_tau must be positive, got {}",
            n.coloured_tau
        ));
    }
    Ok(())
}
