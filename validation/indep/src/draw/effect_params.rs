//! The parameters each hidden effect sets, drawn against the base robot at a size quantile:
//! one function per effect, its ranges in the crate README (section "Drawing robots").

use super::{demand, log_at, log_uniform, sign, CouplingForm, DrawOptions};
use crate::design::Design;
use crate::robot::{
    CrossCoupling, Effect, FlexibleMode, Friction, OpDependence, Robot, Transmission,
};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// The parameters one effect sets, drawn against the base robot.
#[derive(Clone, Debug)]
pub(super) enum EffectParams {
    Delay([f64; 2]),
    Transmission([Transmission; 2]),
    Friction([Friction; 2]),
    AccelLimit([f64; 2]),
    VelocityLimit([f64; 2]),
    Modes([Vec<FlexibleMode>; 2]),
    Lowpass([f64; 2]),
    OpDependence(OpDependence),
    Drift([f64; 2]),
    Coupling(CrossCoupling),
}

impl EffectParams {
    /// For an effect outside the catalogue, the catalogue forms of the same element with the
    /// same parameters but without what puts it outside: a cubic stiffness's linear
    /// transmission, a Stribeck friction's Coulomb friction at its kinetic and at its static
    /// level, a second structural mode's first mode alone. What makes the effect outside the
    /// catalogue is visible when it is visible against each of them. Empty for catalogue
    /// effects and for the rate-limited servo (its nearest catalogue effect, the acceleration
    /// limit, has no parameter in common with it).
    pub(super) fn catalogue_counterparts(&self, effect: Effect) -> Vec<EffectParams> {
        match (effect, self) {
            (Effect::CubicStiffness, EffectParams::Transmission(t)) => {
                let mut linear = t.clone();
                linear
                    .iter_mut()
                    .for_each(|t| t.hardening_deflection = None);
                vec![EffectParams::Transmission(linear)]
            }
            (Effect::StribeckFriction, EffectParams::Friction(f)) => {
                let coulomb = |level: fn(&Friction) -> f64| {
                    EffectParams::Friction(f.clone().map(|f| Friction {
                        kinetic: level(&f),
                        static_level: level(&f),
                        stribeck_velocity: None,
                    }))
                };
                vec![coulomb(|f| f.kinetic), coulomb(|f| f.static_level)]
            }
            (Effect::SecondStructuralMode, EffectParams::Modes(m)) => {
                vec![EffectParams::Modes(m.clone().map(|mut m| {
                    m.truncate(1);
                    m
                }))]
            }
            _ => Vec::new(),
        }
    }

    pub(super) fn install(&self, r: &mut Robot) {
        match self {
            EffectParams::Delay(d) => (0..2).for_each(|k| r.axes[k].command_delay = d[k]),
            EffectParams::Transmission(t) => {
                (0..2).for_each(|k| r.axes[k].transmission = Some(t[k].clone()))
            }
            EffectParams::Friction(f) => {
                (0..2).for_each(|k| r.axes[k].friction = Some(f[k].clone()))
            }
            EffectParams::AccelLimit(l) => (0..2).for_each(|k| r.axes[k].servo.accel_limit = l[k]),
            EffectParams::VelocityLimit(l) => {
                (0..2).for_each(|k| r.axes[k].servo.velocity_limit = Some(l[k]))
            }
            EffectParams::Modes(m) => (0..2).for_each(|k| r.axes[k].modes = m[k].clone()),
            EffectParams::Lowpass(c) => r.sensor.lowpass_cutoff = Some(*c),
            EffectParams::OpDependence(o) => r.op_dependence = Some(o.clone()),
            EffectParams::Drift(d) => r.sensor.drift_rate = *d,
            EffectParams::Coupling(c) => r.cross_coupling = Some(c.clone()),
        }
    }
}

/// A value for one axis and a related value for the other, randomly which is which.
fn pair_swapped(rng: &mut impl Rng, first: f64, second: f64) -> [f64; 2] {
    if rng.gen_bool(0.5) {
        [first, second]
    } else {
        [second, first]
    }
}

/// The parameters of `effect` at size quantile `q` (0: smallest, 1: largest of its range),
/// drawn against the base robot `base` and the design it is sized for. Each effect's other
/// random choices come from `rng`, in a fixed order.
pub(super) fn draw_effect(
    effect: Effect,
    base: &Robot,
    design: &Design,
    options: &DrawOptions,
    rng: &mut ChaCha8Rng,
    q: f64,
) -> EffectParams {
    let servo = |k: usize| &base.axes[k].servo;
    match effect {
        Effect::TimeDelay => draw_delay(rng, q),
        Effect::Backlash => draw_backlash(rng, q),
        Effect::CoulombFriction | Effect::StribeckFriction => draw_friction(effect, base, rng, q),
        Effect::AccelerationSaturation => {
            let factor = log_at(0.5, 0.25, q);
            EffectParams::AccelLimit([0, 1].map(|k| demand(servo(k), design, 2) * factor))
        }
        Effect::RateLimitedServo => {
            let factor = log_at(0.85, 0.4, q);
            EffectParams::VelocityLimit(
                [0, 1].map(|k| demand(servo(k), design, 1) * factor * rng.gen_range(0.95..1.05)),
            )
        }
        Effect::StructuralMode | Effect::SecondStructuralMode => draw_modes(effect, rng, q),
        Effect::CubicStiffness => draw_cubic_stiffness(base, design, rng, q),
        Effect::SensorLowpass => {
            let wc = log_at(150.0, 15.0, q);
            EffectParams::Lowpass([0, 1].map(|_| wc * rng.gen_range(0.85..1.15)))
        }
        Effect::OperatingPointDependence => draw_op_dependence(design, rng, q),
        Effect::SensorDrift => {
            let rate = log_at(0.02e-3, 0.5e-3, q);
            let first = sign(rng) * rate;
            let second = sign(rng) * rate * rng.gen_range(0.2..1.0);
            EffectParams::Drift(pair_swapped(rng, first, second))
        }
        Effect::CrossCoupling => draw_coupling(options, rng, q),
    }
}

/// A command delay of 10 to 150 ms, the same on both axes or up to half as much again on one.
fn draw_delay(rng: &mut ChaCha8Rng, q: f64) -> EffectParams {
    let tau = log_at(0.010, 0.150, q);
    let other = if rng.gen_bool(0.6) {
        tau
    } else {
        (tau * rng.gen_range(0.5..1.5)).clamp(0.010, 0.150)
    };
    EffectParams::Delay(pair_swapped(rng, tau, other))
}

/// A play of 0.3 to 2.5 mm in a stiff, damped transmission on each axis.
fn draw_backlash(rng: &mut ChaCha8Rng, q: f64) -> EffectParams {
    let w = log_at(0.3e-3, 2.5e-3, q);
    let other = (w * rng.gen_range(0.6..1.4)).clamp(0.3e-3, 2.5e-3);
    let widths = pair_swapped(rng, w, other);
    EffectParams::Transmission(widths.map(|play| Transmission {
        play,
        omega: rng.gen_range(100.0..250.0),
        zeta: rng.gen_range(0.1..0.3),
        hardening_deflection: None,
        load_drag_time: Some(rng.gen_range(0.02..0.1)),
    }))
}

/// A kinetic friction of 2 to 20 % of each servo's acceleration limit; a Stribeck friction
/// adds a static level 1.5 to 3 times it and a Stribeck velocity of 1 to 10 mm/s.
fn draw_friction(effect: Effect, base: &Robot, rng: &mut ChaCha8Rng, q: f64) -> EffectParams {
    let ratio = log_at(0.02, 0.2, q);
    EffectParams::Friction([0, 1].map(|k| {
        let kinetic = base.axes[k].servo.accel_limit * ratio * rng.gen_range(0.7..1.3);
        if effect == Effect::CoulombFriction {
            Friction {
                kinetic,
                static_level: kinetic,
                stribeck_velocity: None,
            }
        } else {
            Friction {
                kinetic,
                static_level: kinetic * rng.gen_range(1.5..3.0),
                stribeck_velocity: Some(log_uniform(rng, 1e-3, 1e-2)),
            }
        }
    }))
}

/// One lightly damped mode (10 to 35 rad/s) carrying 15 to 60 % of the moving mass on each
/// axis, or two (the second 1.5 to 2.5 times the first's frequency).
fn draw_modes(effect: Effect, rng: &mut ChaCha8Rng, q: f64) -> EffectParams {
    let share = log_at(0.15, 0.6, q);
    EffectParams::Modes([0, 1].map(|_| {
        let mass_fraction = (share * rng.gen_range(0.8..1.2)).clamp(0.15, 0.6);
        if effect == Effect::StructuralMode {
            vec![FlexibleMode {
                omega: rng.gen_range(10.0..35.0),
                zeta: log_uniform(rng, 0.02, 0.12),
                mass_fraction,
            }]
        } else {
            let w1 = rng.gen_range(10.0..25.0);
            vec![
                FlexibleMode {
                    omega: w1,
                    zeta: log_uniform(rng, 0.02, 0.12),
                    mass_fraction,
                },
                FlexibleMode {
                    omega: w1 * rng.gen_range(1.5..2.5),
                    zeta: log_uniform(rng, 0.02, 0.12),
                    mass_fraction: rng.gen_range(0.3..0.6),
                },
            ]
        }
    }))
}

/// A transmission of 20 to 40 rad/s that hardens at a deflection the servo's largest
/// acceleration on the design reaches.
fn draw_cubic_stiffness(
    base: &Robot,
    design: &Design,
    rng: &mut ChaCha8Rng,
    q: f64,
) -> EffectParams {
    EffectParams::Transmission([0, 1].map(|k| {
        let servo = &base.axes[k].servo;
        let omega = rng.gen_range(20.0..40.0);
        // The largest acceleration the servo reaches: the hardening acts below the limit.
        let reached = demand(servo, design, 2).min(servo.accel_limit);
        let deflection = reached / (omega * omega);
        Transmission {
            play: 0.0,
            omega,
            zeta: rng.gen_range(0.05..0.15),
            hardening_deflection: Some(deflection * log_at(1.0, 0.3, q)),
            load_drag_time: None,
        }
    }))
}

/// Slopes of `a` and `b` that change them by 2 to 20 % over the design's operating points.
fn draw_op_dependence(design: &Design, rng: &mut ChaCha8Rng, q: f64) -> EffectParams {
    let rho = log_at(0.02, 0.2, q);
    let span = [0, 1].map(|k| {
        design
            .operating_points
            .iter()
            .map(|op| op[k].abs())
            .fold(0.0, f64::max)
    });
    let mut slope = || {
        [0, 1].map(|k| {
            let s = sign(rng) * rho * rng.gen_range(0.5..1.0);
            if span[k] > 0.0 {
                s / span[k]
            } else {
                0.0
            }
        })
    };
    let a_slope = slope();
    let b_slope = slope();
    EffectParams::OpDependence(OpDependence { a_slope, b_slope })
}

/// A cross-axis coupling: pendulum terms `a12`, `a21`, `b12`, `b21`, or an inertial coupling
/// of the servos (the form drawn unless `options` fixes it).
fn draw_coupling(options: &DrawOptions, rng: &mut ChaCha8Rng, q: f64) -> EffectParams {
    let drawn = rng.gen_bool(0.5);
    let pendulum = match options.coupling_form {
        Some(form) => form == CouplingForm::Pendulum,
        None => drawn,
    };
    if pendulum {
        let mut term = |lo: f64, hi: f64| sign(rng) * log_at(lo, hi, q) * rng.gen_range(0.7..1.0);
        EffectParams::Coupling(CrossCoupling::Pendulum {
            da12: term(0.03, 0.25),
            da21: term(0.03, 0.25),
            db12: term(0.005, 0.05),
            db21: term(0.005, 0.05),
        })
    } else {
        let mut kappa = || sign(rng) * log_at(0.05, 0.3, q) * rng.gen_range(0.7..1.0);
        EffectParams::Coupling(CrossCoupling::Inertial {
            kappa_xy: kappa(),
            kappa_yx: kappa(),
        })
    }
}
