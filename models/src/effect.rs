//! The effect trait and the registry: every physical effect of the plant is one type that
//! declares its parameters, its frequency response and its discrete-time step.
//!
//! Where an effect acts is its [`Site`]. The plant's signal path, in order:
//!
//! ```text
//! com_ref_j --Command effects (per input axis j)--> servo (tracking low-pass; Servo effects
//!   limit its acceleration) --> CoM x_cj, acceleration --> pendulum a_ij x_cj - b_ij x_cj''
//!   (Pendulum effects rescale a, b) --> Channel effects (per G_ij) --> sum over j
//!   --> Sensor effects (per output axis i) --> zmp_i
//! ```

use crate::axis::{Axis, Channel};
use num_complex::Complex64;
use std::fmt;

/// Where in the signal path an effect acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Site {
    /// On the CoM reference of one input axis, before the servo.
    Command,
    /// The servo of one input axis: the core tracking low-pass, or a limit on its acceleration.
    Servo,
    /// The 2×2 pendulum: the core coefficients, or a modifier of them.
    Pendulum,
    /// On one channel `G_ij`, multiplicatively.
    Channel,
    /// On the measured ZMP of one output axis.
    Sensor,
}

/// The place one instance of an effect is bound to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Binding {
    Global,
    Axis(Axis),
    Channel(Channel),
}

impl Binding {
    /// The bindings an effect at `site` can have, in canonical order.
    pub fn all_for(site: Site) -> &'static [Binding] {
        const AXES: [Binding; 2] = [Binding::Axis(Axis::X), Binding::Axis(Axis::Y)];
        const CHANNELS: [Binding; 4] = [
            Binding::Channel(Channel::ALL[0]),
            Binding::Channel(Channel::ALL[1]),
            Binding::Channel(Channel::ALL[2]),
            Binding::Channel(Channel::ALL[3]),
        ];
        match site {
            Site::Command | Site::Servo | Site::Sensor => &AXES,
            Site::Channel => &CHANNELS,
            Site::Pendulum => &[Binding::Global],
        }
    }

    /// The key of this binding in a model file (`x`, `G21`), `None` for global.
    pub fn key(self) -> Option<&'static str> {
        match self {
            Binding::Global => None,
            Binding::Axis(a) => Some(a.name()),
            Binding::Channel(c) => Some(c.name()),
        }
    }

    pub fn parse(site: Site, key: &str) -> Option<Binding> {
        Binding::all_for(site)
            .iter()
            .copied()
            .find(|b| b.key() == Some(key))
    }
}

impl fmt::Display for Binding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.key().unwrap_or("global"))
    }
}

/// One parameter of an effect. Units are SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    pub name: &'static str,
    pub unit: &'static str,
    /// Inclusive bounds; a value outside is a model-file error.
    pub min: f64,
    pub max: f64,
    /// Used when the model file omits the parameter; `None` makes it required.
    pub default: Option<f64>,
    pub doc: &'static str,
}

impl ParamSpec {
    pub const fn required(
        name: &'static str,
        unit: &'static str,
        min: f64,
        max: f64,
        doc: &'static str,
    ) -> ParamSpec {
        ParamSpec {
            name,
            unit,
            min,
            max,
            default: None,
            doc,
        }
    }

    pub const fn optional(
        name: &'static str,
        unit: &'static str,
        min: f64,
        max: f64,
        default: f64,
        doc: &'static str,
    ) -> ParamSpec {
        ParamSpec {
            name,
            unit,
            min,
            max,
            default: Some(default),
            doc,
        }
    }
}

/// What an effect's builder gets besides its parameter values.
#[derive(Debug, Clone, Copy)]
pub struct BuildContext {
    /// The plant's fixed internal step, s.
    pub h: f64,
    pub binding: Binding,
    /// The tracking low-pass of the bound input axis `(omega_n rad/s, zeta)`, for servo effects.
    pub servo: Option<(f64, f64)>,
    /// The flexible trunk the bound axis's servo drives inside its loop (`in_servo = 1`): the
    /// servo effects' describing functions simulate the two-body loop.
    pub link: Option<crate::effects::servo_link::TrunkLink>,
}

/// A cross-parameter check: `Err((index of the offending parameter, message))`.
pub type Validate = fn(&[f64]) -> Result<(), (usize, String)>;

/// The check of a parameter `k` that switches between two laws: 0 (`off`) or 1 (`on`).
pub fn check_switch(v: &[f64], k: usize, off: &str, on: &str) -> Result<(), (usize, String)> {
    match v.get(k) {
        Some(x) if *x != 0.0 && *x != 1.0 => Err((k, format!("{x}: 0 ({off}) or 1 ({on})"))),
        _ => Ok(()),
    }
}

/// The static description of an effect kind: one entry of the [`REGISTRY`].
pub struct EffectInfo {
    /// The kind; its name is what model files, diagnosis JSON and FMU variables carry.
    pub kind: crate::EffectKind,
    pub title: &'static str,
    pub doc: &'static str,
    pub site: Site,
    /// Core effects form the nominal plant and must be present in every model.
    pub core: bool,
    pub linear: bool,
    pub params: &'static [ParamSpec],
    pub validate: Option<Validate>,
    pub build: fn(&BuildContext, &[f64]) -> Box<dyn Effect>,
}

impl fmt::Debug for EffectInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("EffectInfo")
            .field("kind", &self.kind)
            .finish()
    }
}

impl EffectInfo {
    pub fn param_index(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|p| p.name == name)
    }
}

/// A physical effect at run time. Methods that do not apply to the effect's site keep their
/// identity default. `step` and friends never allocate and never panic.
pub trait Effect: Send + Sync + fmt::Debug {
    fn info(&self) -> &'static EffectInfo;

    /// First-harmonic gain from the effect's input to its output at `omega_rad_s` for an input
    /// sine of `amplitude` (in the unit of the effect's input). Exact for linear effects (the
    /// amplitude is ignored); a describing function or a simulated first harmonic otherwise.
    /// Servo effects return the servo's response with the effect divided by the one without.
    fn frequency_response(&self, omega_rad_s: f64, amplitude: f64) -> Complex64;

    /// Third harmonic of the effect's output over the input's amplitude, for an input
    /// `amplitude sin(omega t)` (sin-referenced phasor, `y_3(t) = Im(Y_3 e^{3 j omega t})`):
    /// zero for linear effects. Servo effects return the servo position's (the CoM's with a
    /// linked trunk), absolute: the linear servo has none.
    fn third_harmonic(&self, _omega_rad_s: f64, _amplitude: f64) -> Complex64 {
        Complex64::new(0.0, 0.0)
    }

    /// [`Effect::frequency_response`] and [`Effect::third_harmonic`] together (servo effects
    /// take both from one describing-function run).
    fn harmonics(&self, omega_rad_s: f64, amplitude: f64) -> (Complex64, Complex64) {
        (
            self.frequency_response(omega_rad_s, amplitude),
            self.third_harmonic(omega_rad_s, amplitude),
        )
    }

    /// Puts the effect at rest for the constant input `u`; returns its output at rest.
    fn reset(&mut self, u: f64) -> f64;

    /// One internal step of a signal effect (Command, Channel, Sensor sites): the input has
    /// moved linearly from its value at the step's start to `u`; returns the output at the
    /// step's end.
    #[inline]
    fn step(&mut self, u: f64) -> f64 {
        u
    }

    /// Signal effects: the input jumps to `u` at the current instant (the effect's state does
    /// not move); returns the output just after. The default suits effects whose output is a
    /// function of the input alone.
    #[inline]
    fn jump(&mut self, u: f64) -> f64 {
        u
    }

    /// One step whose input may jump at its start: `jump` is the input's value just after the
    /// start (`None`: continuous), `u` its value at the end. Returns the output's value just
    /// after the start (`None`: continuous) and at the end. An effect that delays its input
    /// passes a jump on later, at the step where it reaches the output.
    #[inline]
    fn step_span(&mut self, jump: Option<f64>, u: f64) -> (Option<f64>, f64) {
        let j = jump.map(|v| self.jump(v));
        (j, self.step(u))
    }

    /// Servo effects: the acceleration the servo achieves for a demanded one at `velocity`.
    #[inline]
    fn servo_acceleration(&mut self, demand: f64, _velocity: f64) -> f64 {
        demand
    }

    /// Servo effects that change the servo's motion: a copy to run in one servo simulation
    /// with the axis's other servo effects, and what names it in the describing-function
    /// cache ([`crate::effects::servo::joint_servo_harmonics`]). `None` for every other effect.
    fn servo_part(&self) -> Option<crate::effects::servo::ServoPart> {
        None
    }

    /// Servo effects: whether the effect leaves the servo's periodic motion untouched for a
    /// reference `amplitude sin(omega t)` when the axis's other servo effects add at most
    /// `extra` (m/s²) to the force the servo demands (a saturation whose limit that force
    /// never reaches). `false` when it may act.
    fn servo_idle(&self, _omega: f64, _amplitude: f64, _extra: f64) -> bool {
        false
    }

    /// Servo effects: the most the effect adds to the force the servo must demand (m/s²; a
    /// friction's level), 0 for none.
    fn servo_force_bound(&self) -> f64 {
        0.0
    }

    /// Servo effects: the steepest slope of the acceleration they remove against velocity,
    /// 1/s (0 for none). The servo's RK4 takes sub-steps short enough for it, so a stiff
    /// effect is integrated stably at any plant step.
    fn stiffness(&self) -> f64 {
        0.0
    }

    /// Servo effects: [`Effect::stiffness`] while the speed stays at or above `speed` (m/s)
    /// with one sign, at most the stiffness itself (the default: no less).
    fn stiffness_at(&self, _speed: f64) -> f64 {
        self.stiffness()
    }

    /// Pendulum modifiers: `(scale of a_ij, scale of b_ij)` at the operating point `[x, y]` m.
    fn pendulum_scale(&self, _operating_point: [f64; 2]) -> (f64, f64) {
        (1.0, 1.0)
    }

    /// Pendulum modifiers: the gradient of the scale of `a_ij` with the CoM position,
    /// `[d/dx, d/dy]` 1/m, at `[x, y]` m. The static ZMP `(scale a) x_c` then has the
    /// small-signal gain `a_ij scale + d scale/d x_j (a x_c)_i` (see [`Plant`](crate::Plant)).
    fn pendulum_scale_gradient(&self, _operating_point: [f64; 2]) -> [f64; 2] {
        [0.0, 0.0]
    }

    /// The linear continuous-time transfer function, when the effect has one.
    fn transfer_function(&self) -> Option<crate::lti::TransferFunction> {
        None
    }
}

/// Every effect kind, in the canonical order used within a site.
pub static REGISTRY: &[&EffectInfo] = &[
    &crate::effects::pendulum::INFO,
    &crate::effects::tracking_lowpass::INFO,
    &crate::effects::acceleration_saturation::INFO,
    &crate::effects::coulomb_friction::INFO,
    &crate::effects::time_delay::INFO,
    &crate::effects::backlash::INFO,
    &crate::effects::uncertainty::INFO,
    &crate::effects::operating_point::INFO,
    &crate::effects::structural_mode::INFO,
    &crate::effects::flexible_trunk::INFO,
    &crate::effects::sensor_lowpass::INFO,
    &crate::effects::sensor_drift::INFO,
];

/// The registry entry of the kind named `kind` on disk.
pub fn lookup(kind: &str) -> Option<&'static EffectInfo> {
    crate::EffectKind::parse(kind).map(crate::EffectKind::info)
}
