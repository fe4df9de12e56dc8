//! Random robots: `draw(seed, scenario)` draws every parameter within documented ranges and
//! sizes each hidden effect so that it is physically plausible and visible above the noise.
//!
//! The ranges of every parameter, the size quantile of each effect and the visibility rule
//! are tabulated in the crate README (section "Drawing robots"); the test
//! `every_effect_draws_a_valid_visible_robot_within_its_ranges` holds the code to them. In
//! short: an effect is *visible* on a design when it changes the first harmonic of at least
//! [`VISIBLE_MIN_RECORDS`] records, on some output channel, by at least [`VISIBLE_SIGMAS`]
//! first-harmonic noise standard deviations ([`crate::response::record_noise_std`]) and by at
//! least [`VISIBLE_RELATIVE`] of that channel's first harmonic without the effect, compared
//! with the same draw without any hidden effect: linear effects from the small-signal
//! response, `sensor_drift` and `sensor_rezero` from the drift's exact first-harmonic
//! projection `2|rate|/ω` (each record's own rate for `sensor_rezero`), nonlinear
//! ones by noise-free simulation of each (axis, amplitude, frequency) at the first operating
//! point over the design's transient and one period (a change counts for every operating
//! point: the mechanics do not depend on it). An effect outside the catalogue must also be
//! visible, by the same rule, against its catalogue form with the same parameters
//! (`EffectParams::catalogue_counterparts`: the linear transmission of a cubic stiffness, the
//! Coulomb friction at a Stribeck friction's kinetic and at its static level, the first of two
//! modes): what puts it outside the catalogue must show; likewise a sensor re-zeroed at every
//! record against one rate for every record, the records' mean. The size quantile is drawn U(0, 1)
//! and, while the effect is invisible, redrawn U(q, 1) (8 draws at most, the last at q = 1);
//! an effect still invisible is kept and reported with `visible = false`.

use crate::design::Design;
use crate::robot::{
    AxisMechanics, CrossCoupling, Effect, FlexibleMode, Friction, HiddenEffect, Noise,
    OpDependence, OpPerChannel, Pendulum, Rezero, Robot, Sensor, Servo, Transmission,
};
use crate::scenario::Scenario;
pub use crate::visibility::Visibility;
use crate::visibility::{visibility, Harmonics};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// First-harmonic change, in noise standard deviations, for a record to count as changed.
pub const VISIBLE_SIGMAS: f64 = 6.0;
/// First-harmonic change relative to the response without the effect, for a record to count.
pub const VISIBLE_RELATIVE: f64 = 0.02;
/// Records that must change for an effect to be visible.
pub const VISIBLE_MIN_RECORDS: usize = 3;
const SIZE_ATTEMPTS: usize = 8;

/// Draws a robot for the scenario, sized for the default design ([`Design::default`]).
pub fn draw(seed: u64, scenario: &Scenario) -> Robot {
    draw_for_design(seed, scenario, &Design::default())
}

/// The form of a drawn `cross_coupling`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CouplingForm {
    /// Extra off-diagonal pendulum terms `Δa − Δb s²`.
    Pendulum,
    /// Inertial load of each joint by the other axis's CoM acceleration.
    Inertial,
}

impl std::str::FromStr for CouplingForm {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "pendulum" => Ok(CouplingForm::Pendulum),
            "inertial" => Ok(CouplingForm::Inertial),
            _ => Err(format!(
                "unknown coupling form `{s}`: use pendulum or inertial"
            )),
        }
    }
}

/// Choices `draw_with` leaves to the caller.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DrawOptions {
    /// Form of a `cross_coupling` effect; `None`: drawn, each form with probability 1/2.
    pub coupling_form: Option<CouplingForm>,
}

/// Draws a robot for the scenario, with its saturation and effect sizes set for `design`.
///
/// # Panics
/// If the scenario or the design is invalid (`Scenario::validate`, `Design::validate`).
pub fn draw_for_design(seed: u64, scenario: &Scenario, design: &Design) -> Robot {
    draw_with(seed, scenario, design, &DrawOptions::default())
}

/// [`draw_for_design`] with options (every other parameter is drawn as without them). A
/// design in the list form draws the robot of the default design ([`Design::for_drawing`]).
///
/// # Panics
/// If the scenario or the design is invalid (`Scenario::validate`, `Design::validate`).
pub fn draw_with(seed: u64, scenario: &Scenario, design: &Design, options: &DrawOptions) -> Robot {
    scenario
        .validate()
        .unwrap_or_else(|e| panic!("draw: scenario: {e}"));
    design
        .validate()
        .unwrap_or_else(|e| panic!("draw: design: {e}"));
    // A list of records is run on the robot drawn for the default campaign.
    let design = &design.for_drawing();
    let scenario = scenario.resolve(&mut stream(seed, 1));
    let mut rng = stream(seed, 0);
    let base = draw_base(&mut rng, design);
    let mut robot = base.clone();
    let mut probe_cache: Option<Harmonics> = None;
    for effect in scenario.effects() {
        let mut rng = stream(seed, 100 + effect as u64);
        let mut q_lo = 0.0;
        let mut chosen = None;
        for attempt in 0..SIZE_ATTEMPTS {
            let q = if attempt + 1 == SIZE_ATTEMPTS {
                1.0
            } else {
                rng.gen_range(q_lo..=1.0)
            };
            let params = draw_effect(effect, &base, design, options, &mut rng, q);
            let mut candidate = base.clone();
            params.install(&mut candidate);
            let vis = visibility(effect, &base, &candidate, design, &mut probe_cache);
            let beyond = params
                .catalogue_counterparts(effect)
                .into_iter()
                .map(|cp| {
                    let mut without = base.clone();
                    cp.install(&mut without);
                    visibility(effect, &without, &candidate, design, &mut None)
                })
                .min_by_key(|v| v.records);
            let visible = vis.visible && beyond.is_none_or(|b| b.visible);
            chosen = Some((params, vis, beyond, visible));
            if visible {
                break;
            }
            q_lo = q;
        }
        let (params, vis, beyond, visible) = chosen.expect("at least one attempt");
        params.install(&mut robot);
        robot.hidden.push(HiddenEffect {
            effect,
            name: effect.catalogue_name().into(),
            in_catalogue: effect.in_catalogue(),
            nearest_catalogue: effect.nearest_catalogue().map(|e| e.name().into()),
            visible,
            max_sigmas: vis.max_sigmas,
            max_relative: vis.max_relative,
            records_visible: vis.records,
            records_visible_beyond_catalogue: beyond.map(|b| b.records),
        });
    }
    robot.name = format!("zmp-indep-sim draw {seed} ({scenario})");
    robot.scenario = scenario.to_string();
    robot.seed = Some(seed);
    robot
}

fn stream(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

fn log_uniform(rng: &mut impl Rng, lo: f64, hi: f64) -> f64 {
    log_at(lo, hi, rng.gen::<f64>())
}
fn log_at(lo: f64, hi: f64, q: f64) -> f64 {
    lo * (hi / lo).powf(q)
}
fn sign(rng: &mut impl Rng) -> f64 {
    if rng.gen_bool(0.5) {
        1.0
    } else {
        -1.0
    }
}

/// `|H_j(jω)|` of the seed's tracking low-pass.
fn servo_gain(s: &Servo, omega: f64) -> f64 {
    let wn = s.omega_n;
    let re = wn * wn - omega * omega;
    let im = 2.0 * s.zeta * wn * omega;
    wn * wn / re.hypot(im)
}

/// The largest steady acceleration (`power = 2`) or velocity (`power = 1`) the design
/// demands of a linear servo: `max_A A · max_ω ω^power |H(jω)|`.
fn demand(s: &Servo, design: &Design, power: i32) -> f64 {
    let a_max = design.amplitudes.iter().copied().fold(0.0, f64::max);
    let w = design
        .omegas
        .iter()
        .map(|&w| w.powi(power) * servo_gain(s, w))
        .fold(0.0, f64::max);
    a_max * w
}

fn draw_base(rng: &mut ChaCha8Rng, design: &Design) -> Robot {
    let seed = Pendulum::silo2();
    let mut p = seed.clone();
    for i in 0..2 {
        for j in 0..2 {
            let spread = if i == j { 0.2 } else { 0.3 };
            p.a[i][j] = seed.a[i][j] * rng.gen_range(1.0 - spread..1.0 + spread);
            p.b[i][j] = seed.b[i][j] * rng.gen_range(1.0 - spread..1.0 + spread);
        }
    }
    // One tracking low-pass for both axes, as the seed's H11 = H12 = H21 = H22 (§6.3): a
    // clean robot must be one the seed's model structure explains.
    // One acceleration limit too: the seed speaks of "the system's maximum acceleration".
    let omega_n = rng.gen_range(22.0..40.0);
    let zeta = rng.gen_range(0.75..1.1);
    let limit_factor = log_uniform(rng, 0.6, 1.5);
    let mut axis = || {
        let mut servo = Servo {
            omega_n,
            zeta,
            accel_limit: 1.0,
            velocity_limit: None,
        };
        servo.accel_limit = demand(&servo, design, 2) * limit_factor;
        AxisMechanics {
            servo,
            command_delay: 0.0,
            drive_mass_fraction: rng.gen_range(0.2..0.5),
            transmission: None,
            friction: None,
            modes: Vec::new(),
        }
    };
    let axes = [axis(), axis()];
    let noise = Noise {
        white_std: rng.gen_range(0.2e-3..0.8e-3),
        coloured_std: rng.gen_range(0.1e-3..0.4e-3),
        coloured_tau: log_uniform(rng, 0.1, 1.0),
    };
    Robot {
        name: String::new(),
        scenario: "clean".into(),
        seed: None,
        pendulum: p,
        axes,
        cross_coupling: None,
        op_dependence: None,
        op_per_channel: None,
        sensor: Sensor {
            lowpass_cutoff: None,
            drift_rate: [0.0; 2],
            rezero: None,
            noise,
        },
        hidden: Vec::new(),
    }
}

/// The parameters one effect sets, drawn against the base robot.
#[derive(Clone, Debug)]
enum EffectParams {
    Delay([f64; 2]),
    Transmission([Transmission; 2]),
    Friction([Friction; 2]),
    AccelLimit([f64; 2]),
    VelocityLimit([f64; 2]),
    Modes([Vec<FlexibleMode>; 2]),
    Lowpass([f64; 2]),
    OpDependence(OpDependence),
    OpPerChannel(OpPerChannel),
    Drift([f64; 2]),
    /// The mean rates and the record-to-record part.
    Rezero([f64; 2], Rezero),
    Coupling(CrossCoupling),
}

impl EffectParams {
    /// For an effect outside the catalogue, the catalogue forms of the same element with the
    /// same parameters but without what puts it outside: a cubic stiffness's linear
    /// transmission, a Stribeck friction's Coulomb friction at its kinetic and at its static
    /// level, a second structural mode's first mode alone. What makes the effect outside the
    /// catalogue is visible when it is visible against each of them. Empty for catalogue
    /// effects and for the rate-limited servo (its nearest catalogue effect, the acceleration
    /// limit, has no parameter in common with it). A sensor re-zeroed at every record is held
    /// to the same rule against one rate for every record, its mean: what makes it a form of
    /// its own, the rates that change from record to record, must show.
    fn catalogue_counterparts(&self, effect: Effect) -> Vec<EffectParams> {
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
            (Effect::SensorRezero, EffectParams::Rezero(mean, _)) => {
                vec![EffectParams::Drift(*mean)]
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

    fn install(&self, r: &mut Robot) {
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
            EffectParams::OpPerChannel(o) => r.op_per_channel = Some(o.clone()),
            EffectParams::Drift(d) => r.sensor.drift_rate = *d,
            EffectParams::Rezero(mean, z) => {
                r.sensor.drift_rate = *mean;
                r.sensor.rezero = Some(z.clone());
            }
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

/// The parameters of one hidden effect at quantile `q` of its visible range, the rest of its
/// shape drawn from `rng`.
fn draw_effect(
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
        Effect::OperatingPointDependence => {
            let rho = log_at(0.02, 0.2, q);
            let span = op_span(design);
            let a_slope = op_slope(rng, rho, span);
            let b_slope = op_slope(rng, rho, span);
            EffectParams::OpDependence(OpDependence { a_slope, b_slope })
        }
        Effect::SensorDrift => {
            let rate = log_at(0.02e-3, 0.5e-3, q);
            let first = sign(rng) * rate;
            let second = sign(rng) * rate * rng.gen_range(0.2..1.0);
            EffectParams::Drift(pair_swapped(rng, first, second))
        }
        Effect::SensorRezero => draw_rezero(rng, q),
        Effect::OpPerChannel => draw_op_per_channel(design, rng, q),
        Effect::CrossCoupling => draw_coupling(options, rng, q),
    }
}

/// A pure delay of 10-150 ms per axis, the second axis the same or within a factor 1.5.
fn draw_delay(rng: &mut ChaCha8Rng, q: f64) -> EffectParams {
    let tau = log_at(0.010, 0.150, q);
    let other = if rng.gen_bool(0.6) {
        tau
    } else {
        (tau * rng.gen_range(0.5..1.5)).clamp(0.010, 0.150)
    };
    EffectParams::Delay(pair_swapped(rng, tau, other))
}

/// A play of 0.3-2.5 mm (CoM-equivalent) per axis in a compliant transmission of
/// 100-250 rad/s with load drag.
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

/// A Coulomb (or Stribeck) friction of 2-20 % of each servo's acceleration limit.
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

/// One flexible mode of 10-35 rad/s per axis (or two, the second 1.5-2.5 times the first)
/// carrying 15-60 % of the moving mass.
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

/// A hardening transmission of 20-40 rad/s whose cubic term acts within the accelerations
/// the design reaches.
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

/// A drift rate that changes from record to record: a spread of 0.02-0.5 mm/s per axis about
/// a mean rate of random sign up to half of it.
fn draw_rezero(rng: &mut ChaCha8Rng, q: f64) -> EffectParams {
    let s = log_at(0.02e-3, 0.5e-3, q);
    let other = s * rng.gen_range(0.2..1.0);
    let spread = pair_swapped(rng, s, other);
    let mean = spread.map(|s| sign(rng) * s * rng.gen_range(0.0..0.5));
    let seed = u64::from(rng.gen::<u32>());
    EffectParams::Rezero(mean, Rezero { spread, seed })
}

/// Operating-point slopes on one or two of the four channels, 2-20 % change at the farthest
/// operating point.
fn draw_op_per_channel(design: &Design, rng: &mut ChaCha8Rng, q: f64) -> EffectParams {
    let rho = log_at(0.02, 0.2, q);
    let span = op_span(design);
    // One or two of the four channels move, each with its own slopes.
    let mut channels = vec![(0, 0), (0, 1), (1, 0), (1, 1)];
    let moving = if rng.gen_bool(0.5) { 1 } else { 2 };
    let mut o = OpPerChannel {
        a_slope: [[[0.0; 2]; 2]; 2],
        b_slope: [[[0.0; 2]; 2]; 2],
    };
    for _ in 0..moving {
        let (i, j) = channels.swap_remove(rng.gen_range(0..channels.len()));
        o.a_slope[i][j] = op_slope(rng, rho, span);
        o.b_slope[i][j] = op_slope(rng, rho, span);
    }
    EffectParams::OpPerChannel(o)
}

/// A cross-coupling between the axes, in pendulum form (off-diagonal `a`, `b`) or inertial
/// form (`kappa`), drawn or as the options fix it.
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

/// The largest `|op_k|` of the design's operating points per CoM axis, m.
fn op_span(design: &Design) -> [f64; 2] {
    [0, 1].map(|k| {
        design
            .operating_points
            .iter()
            .map(|op| op[k].abs())
            .fold(0.0, f64::max)
    })
}

/// Slopes along x and y (1/m) whose relative change at the farthest operating point is
/// `± rho · U(0.5, 1)`, independent signs; 0 along an axis the design does not move.
fn op_slope(rng: &mut ChaCha8Rng, rho: f64, span: [f64; 2]) -> [f64; 2] {
    [0, 1].map(|k| {
        let s = sign(rng) * rho * rng.gen_range(0.5..1.0);
        if span[k] > 0.0 {
            s / span[k]
        } else {
            0.0
        }
    })
}
