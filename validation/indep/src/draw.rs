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
//! response, `sensor_drift` from its exact first-harmonic projection `2|rate|/ω`, nonlinear
//! ones by noise-free simulation of each (axis, amplitude, frequency) at the first operating
//! point over the design's transient and one period (a change counts for every operating
//! point: the mechanics do not depend on it). An effect outside the catalogue must also be
//! visible, by the same rule, against its catalogue form with the same parameters
//! (`EffectParams::catalogue_counterparts`: the linear transmission of a cubic stiffness, the
//! Coulomb friction at a Stribeck friction's kinetic and at its static level, the first of two
//! modes): what puts it outside the catalogue must show. The size quantile is drawn U(0, 1)
//! and, while the effect is invisible, redrawn U(q, 1) (8 draws at most, the last at q = 1);
//! an effect still invisible is kept and reported with `visible = false`.

use crate::design::Design;
use crate::integrate::simulate_records;
use crate::response::{record_noise_std, small_signal_response, steady_harmonic, Complex};
use crate::robot::{AxisMechanics, Effect, HiddenEffect, Noise, Pendulum, Robot, Sensor, Servo};
use crate::scenario::Scenario;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod effect_params;
use effect_params::draw_effect;

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
    let mut probe_cache = None;
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
            name: effect.name().into(),
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
        sensor: Sensor {
            lowpass_cutoff: None,
            drift_rate: [0.0; 2],
            noise,
        },
        hidden: Vec::new(),
    }
}

/// How visible an effect is on a design.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Visibility {
    /// The verdict of the rule in the module docs.
    pub visible: bool,
    /// Largest change of a record's first harmonic, in noise standard deviations.
    pub max_sigmas: f64,
    /// Largest change of a record's first harmonic relative to it without the effect.
    pub max_relative: f64,
    /// Records that changed visibly.
    pub records: usize,
}

impl Visibility {
    /// Adds one record's first harmonics (per output) with and without the effect; the
    /// record counts `weight` times.
    fn add(&mut self, without: [Complex; 2], with: [Complex; 2], sigma: f64, weight: usize) {
        let mut counts = false;
        for i in 0..2 {
            let d = (with[i] - without[i]).abs();
            let sig = d / sigma.max(1e-300);
            let rel = d / without[i].abs().max(1e-300);
            self.max_sigmas = self.max_sigmas.max(sig);
            self.max_relative = self.max_relative.max(rel);
            counts |= sig >= VISIBLE_SIGMAS && rel >= VISIBLE_RELATIVE;
        }
        if counts {
            self.records += weight;
        }
        self.visible = self.records >= VISIBLE_MIN_RECORDS;
    }
}

/// The probe design of the nonlinear visibility test: the first operating point, noise-free,
/// the design's transient and one steady period.
fn probe_design(design: &Design) -> Design {
    Design {
        operating_points: vec![design.operating_points[0]],
        periods: 1.0,
        min_steady_s: 0.0,
        quantisation: 0.0,
        noise: Some(Noise::zero()),
        zmp_noise_std: None,
        ..design.clone()
    }
}

fn probe_harmonics(robot: &Robot, probe: &Design) -> Vec<[Complex; 2]> {
    let specs = probe.records();
    simulate_records(robot, probe, &specs)
        .iter()
        .map(|r| {
            let z = &r.truth.zmp_noise_free;
            [
                steady_harmonic(&r.meta, &r.t, &z[0]),
                steady_harmonic(&r.meta, &r.t, &z[1]),
            ]
        })
        .collect()
}

/// How visible `effect` (installed in `with`) is against `base` on `design`. `probe_cache`
/// keeps the base robot's probe harmonics between calls (same base, same design).
pub(crate) fn visibility(
    effect: Effect,
    base: &Robot,
    with: &Robot,
    design: &Design,
    probe_cache: &mut Option<Vec<[Complex; 2]>>,
) -> Visibility {
    let mut vis = Visibility::default();
    let records = design.records();
    match effect {
        Effect::Backlash
        | Effect::CoulombFriction
        | Effect::StribeckFriction
        | Effect::AccelerationSaturation
        | Effect::RateLimitedServo
        | Effect::CubicStiffness => {
            let probe = probe_design(design);
            let without = probe_cache
                .get_or_insert_with(|| probe_harmonics(base, &probe))
                .clone();
            let changed = probe_harmonics(with, &probe);
            let n_ops = design.operating_points.len();
            for k in 0..probe.records().len() {
                // Noise of the matching design record (the same at every operating point).
                let sigma = record_noise_std(base, design, &records[k]);
                vis.add(without[k], changed[k], sigma, n_ops);
            }
        }
        Effect::SensorDrift => {
            for spec in &records {
                let Some(g) = small_signal_response(base, spec.operating_point, spec.omega) else {
                    continue;
                };
                let j = spec.excited.index();
                let without = [g[0][j].scale(spec.amplitude), g[1][j].scale(spec.amplitude)];
                let mut changed = without;
                for (i, c) in changed.iter_mut().enumerate() {
                    let d = 2.0 * with.sensor.drift_rate[i].abs() / spec.omega;
                    *c = *c + Complex::new(d, 0.0);
                }
                vis.add(without, changed, record_noise_std(base, design, spec), 1);
            }
        }
        _ => {
            for spec in &records {
                let (Some(g0), Some(g1)) = (
                    small_signal_response(base, spec.operating_point, spec.omega),
                    small_signal_response(with, spec.operating_point, spec.omega),
                ) else {
                    continue;
                };
                let j = spec.excited.index();
                let a = spec.amplitude;
                vis.add(
                    [g0[0][j].scale(a), g0[1][j].scale(a)],
                    [g1[0][j].scale(a), g1[1][j].scale(a)],
                    record_noise_std(base, design, spec),
                    1,
                );
            }
        }
    }
    vis
}
