//! The robot: every truth parameter of one simulated biped, serialisable to JSON and TOML.
//!
//! Coordinates: the CoM displacement that the trunk produces, in metres, per input axis
//! (x lateral, y sagittal, as in the seed). Every mechanical body of an axis is described in
//! these "CoM-equivalent" coordinates, and every force is a *specific* force: force divided by
//! the axis's total moving inertia (drive + trunk), in m/s². With that normalisation the servo
//! gains need no mass, and an acceleration limit is a force limit.

pub use crate::effect::Effect;
use serde::{Deserialize, Serialize};

mod validate;
pub(crate) use validate::validate_noise;

/// The equivalent inverted pendulum of the seed (eqs. 22-24): `zmp_i = Σ_j a_ij x_cj − b_ij x_cj''`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pendulum {
    /// `a[i][j]`: static gain from CoM axis j to ZMP axis i (m/m). Index 0 = x, 1 = y.
    pub a: [[f64; 2]; 2],
    /// `b[i][j]`: gain from CoM acceleration of axis j to ZMP axis i (s²).
    pub b: [[f64; 2]; 2],
}

impl Pendulum {
    /// The SILO2 values of the seed, section 6.2.
    pub fn silo2() -> Self {
        Pendulum {
            a: [[0.8293, 0.07455], [0.1895, 1.245]],
            b: [[0.2767, 0.005428], [0.09979, 0.1012]],
        }
    }
}

/// The position servo of one axis: a cascade of a proportional position loop, a proportional
/// velocity loop and a force (current) limit, acting on the drive body.
///
/// `v_ref = clamp(Kp (r − p), ±velocity_limit)`, `F = clamp(Kv (v_ref − v), ±accel_limit)` with
/// `Kp = ωn/(2ζ)`, `Kv = 2ζωn`, so that unsaturated and on a rigid load
/// `p/r = ωn²/(s² + 2ζωn s + ωn²)`, the seed's tracking low-pass (section 6.3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Servo {
    /// Natural frequency of the closed position loop, rad/s.
    pub omega_n: f64,
    /// Damping ratio of the closed position loop, 1.
    pub zeta: f64,
    /// Actuator force limit divided by the axis's total moving inertia, m/s² (the seed's
    /// acceleration saturation: a rigid axis never accelerates faster than this).
    pub accel_limit: f64,
    /// Clamp on the velocity loop's reference, m/s (`rate_limited_servo`); `None`: no limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity_limit: Option<f64>,
}

/// A compliant transmission between the drive and the trunk joint body, optionally with play
/// (`backlash`) and a hardening spring (`cubic_stiffness`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Transmission {
    /// Total width of the play, m (0: no play). No force is transmitted while the relative
    /// position of drive and trunk lies within `±play/2`.
    pub play: f64,
    /// Natural frequency of the load on the transmission with the drive clamped and the load
    /// taken as rigid, at small deflection, rad/s (stiffness `k = omega² · load mass`).
    pub omega: f64,
    /// Damping ratio of the same oscillator, 1 (damping `c = 2 zeta omega · load mass`).
    pub zeta: f64,
    /// Deflection at which the hardening spring is twice as stiff as at zero, m:
    /// `F = k e (1 + (e/hardening_deflection)²)`. `None`: a linear spring.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hardening_deflection: Option<f64>,
    /// Viscous drag of the trunk joint (bearings, seals), as the time in which it would slow
    /// the free trunk by a factor e, s: force `−m_J v_J / load_drag_time` on the joint body.
    /// Drawn with the play so that the trunk, once disengaged, settles in the gap instead of
    /// rattling between the flanks for ever. `None`: no drag.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_drag_time: Option<f64>,
}

/// Friction on the trunk joint (body J), a true stick-slip law.
///
/// Sliding: `F = −sign(v) (kinetic + (static_level − kinetic) exp(−(v/v_s)²))`. Sticking
/// (`v = 0`): the joint holds while the other forces on it stay within `±static_level`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Friction {
    /// Kinetic (Coulomb) level, m/s² (specific force).
    pub kinetic: f64,
    /// Static (break-away) level, m/s²; equal to `kinetic` for pure Coulomb friction.
    pub static_level: f64,
    /// Stribeck velocity `v_s`, m/s; `None` for pure Coulomb friction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stribeck_velocity: Option<f64>,
}

/// A flexible link carrying part of the trunk: a spring-damper between the inner body and an
/// outboard mass.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FlexibleMode {
    /// Natural frequency of the outboard mass on this link with the inner body clamped, rad/s.
    pub omega: f64,
    /// Damping ratio of the same oscillator, 1.
    pub zeta: f64,
    /// Fraction of the inner body's load that sits outboard of this link, 1 (first link: of
    /// the trunk; second link: of the first outboard mass).
    pub mass_fraction: f64,
}

/// The mechanics of one input axis: latency, servo, drive, transmission, joint, trunk.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AxisMechanics {
    /// The position servo.
    pub servo: Servo,
    /// Latency between the reference and the servo, s (`time_delay`; 0 = none).
    #[serde(default)]
    pub command_delay: f64,
    /// Share of the axis's total moving inertia that is the drive (reflected motor inertia),
    /// 1. Matters only when a transmission separates drive and trunk.
    pub drive_mass_fraction: f64,
    /// Compliant transmission between drive and trunk; `None`: rigid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transmission: Option<Transmission>,
    /// Friction on the trunk joint; `None`: frictionless.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<Friction>,
    /// Flexible links of the trunk, innermost first (0, 1 or 2).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub modes: Vec<FlexibleMode>,
}

/// Coupling between the planes beyond the base pendulum's off-diagonal terms.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "form", rename_all = "snake_case")]
pub enum CrossCoupling {
    /// Extra off-diagonal pendulum terms, added to `a12, a21` (1) and `b12, b21` (s²).
    Pendulum {
        /// Added to `a12`.
        da12: f64,
        /// Added to `a21`.
        da21: f64,
        /// Added to `b12`.
        db12: f64,
        /// Added to `b21`.
        db21: f64,
    },
    /// Inertial coupling through non-orthogonal joint axes (or a product of inertia of the
    /// trunk): the trunk's inertial force along axis j loads the joint of axis i with
    /// `−kappa_ij · x_cj''` (specific force, with the actual accelerations of both axes, solved
    /// simultaneously), which axis i's servo rejects with its own compliance. Zero at DC,
    /// growing like `ω²` through the servo's disturbance response: unlike the pendulum form.
    Inertial {
        /// Load on the x joint per unit y CoM acceleration, 1.
        kappa_xy: f64,
        /// Load on the y joint per unit x CoM acceleration, 1.
        kappa_yx: f64,
    },
}

/// Pendulum gains that change with the CoM position: `a_ij(x_c) = a_ij (1 + a_slope·x_c)`,
/// `b_ij(x_c) = b_ij (1 + b_slope·x_c)`, evaluated at the instantaneous absolute CoM.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OpDependence {
    /// Relative change of every `a_ij` per metre of CoM along x and y, 1/m.
    pub a_slope: [f64; 2],
    /// Relative change of every `b_ij` (the pendulum height) per metre along x and y, 1/m.
    pub b_slope: [f64; 2],
}

/// Pendulum gains with slopes of their own per channel (`op_per_channel`): `a_ij(x_c) =
/// a_ij (1 + a_slope[i][j]·x_c)`, `b_ij(x_c) = b_ij (1 + b_slope[i][j]·x_c)` at the
/// instantaneous absolute CoM; a channel whose slopes are zero keeps its gains (the foot's
/// compliance or a load shift that moves one channel's static gain, not the others'). With
/// [`OpDependence`] too, a channel's factors multiply.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OpPerChannel {
    /// `a_slope[i][j]`: relative change of `a_ij` per metre of CoM along x and y, 1/m.
    pub a_slope: [[[f64; 2]; 2]; 2],
    /// `b_slope[i][j]`: relative change of `b_ij` per metre along x and y, 1/m.
    pub b_slope: [[[f64; 2]; 2]; 2],
}

impl OpPerChannel {
    /// The channels `(i, j)` with a non-zero slope.
    pub fn moving(&self) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for i in 0..2 {
            for j in 0..2 {
                if self.a_slope[i][j] != [0.0; 2] || self.b_slope[i][j] != [0.0; 2] {
                    out.push((i, j));
                }
            }
        }
        out
    }
}

/// A ZMP sensor re-zeroed at the start of every record whose drift rate changes from record
/// to record (`sensor_rezero`, thermal drift that differs each time the sensor is tared):
/// record `k` drifts on axis `i` at `drift_rate[i] + spread[i] · u`, `u` uniform on
/// `(−√3, √3)` (unit variance), drawn from ChaCha8 seeded with `seed` on stream `k`, the x
/// axis's number first, then the y axis's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Rezero {
    /// Standard deviation of a record's rate about the sensor's `drift_rate`, per axis, m/s.
    pub spread: [f64; 2],
    /// Seed of the records' rates.
    pub seed: u64,
}

/// Random measurement noise of the force-sensor ZMP, the same law on both axes, independent
/// realisations.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Noise {
    /// Standard deviation of the white part, m.
    pub white_std: f64,
    /// Stationary standard deviation of the coloured (first-order, AR(1)) part, m.
    pub coloured_std: f64,
    /// Correlation time of the coloured part, s.
    pub coloured_tau: f64,
}

impl Noise {
    /// No noise at all.
    pub fn zero() -> Self {
        Noise {
            white_std: 0.0,
            coloured_std: 0.0,
            coloured_tau: 1.0,
        }
    }
}

/// The force-sensor ZMP measurement.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sensor {
    /// First-order low-pass cutoff per output axis (x, y), rad/s (`sensor_lowpass`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lowpass_cutoff: Option<[f64; 2]>,
    /// Linear drift of the reading per output axis, m/s, starting from zero at the start of
    /// each record (`sensor_drift`); with `rezero`, the mean of the records' rates.
    #[serde(default)]
    pub drift_rate: [f64; 2],
    /// A drift rate that changes from record to record (`sensor_rezero`); `None`: one rate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rezero: Option<Rezero>,
    /// Random noise.
    pub noise: Noise,
}

impl Sensor {
    /// The drift rate of record `record` per axis, m/s: `drift_rate`, plus with `rezero` the
    /// record's own part ([`Rezero`]).
    pub fn record_drift_rate(&self, record: usize) -> [f64; 2] {
        use rand::{Rng, SeedableRng};
        let Some(z) = &self.rezero else {
            return self.drift_rate;
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(z.seed);
        rng.set_stream(record as u64);
        let root3 = 3f64.sqrt();
        let mut r = self.drift_rate;
        for (i, ri) in r.iter_mut().enumerate() {
            *ri += z.spread[i] * rng.gen_range(-root3..root3);
        }
        r
    }
}

/// One hidden effect of a drawn robot, with what a test needs to score a verdict.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HiddenEffect {
    /// Which effect.
    pub effect: Effect,
    /// Its catalogue name (`effect.catalogue_name()`: the name a diagnosis gives it, which
    /// for a catalogue effect's form, `op_per_channel` or `sensor_rezero`, is the effect's).
    pub name: String,
    /// Whether the project's catalogue names it.
    pub in_catalogue: bool,
    /// For an out-of-catalogue effect, the closest catalogue effect.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nearest_catalogue: Option<String>,
    /// Whether it passed the visibility test of `draw` on the design it was drawn for (for an
    /// outside effect, against its catalogue form too: `records_visible_beyond_catalogue`).
    pub visible: bool,
    /// Largest first-harmonic change of a record, in first-harmonic noise std.
    pub max_sigmas: f64,
    /// Largest first-harmonic change of a record relative to the response without the effect.
    pub max_relative: f64,
    /// Records of the design whose first harmonic the effect changes visibly.
    pub records_visible: usize,
    /// For an effect outside the catalogue with a catalogue form (all but the rate-limited
    /// servo), the records whose first harmonic it changes visibly against that form with the
    /// same parameters (the fewest over the forms): what puts it outside the catalogue must be
    /// visible too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub records_visible_beyond_catalogue: Option<usize>,
}

/// Every truth parameter of one simulated robot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Robot {
    /// Free text.
    pub name: String,
    /// The scenario it was drawn for (free text, e.g. `pair:time_delay,backlash`).
    #[serde(default)]
    pub scenario: String,
    /// The seed of `draw`, if drawn.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// The base pendulum (seed eq. 24) including its off-diagonal terms.
    pub pendulum: Pendulum,
    /// Mechanics of the x axis (index 0) and the y axis (index 1).
    pub axes: [AxisMechanics; 2],
    /// Coupling beyond the base pendulum.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cross_coupling: Option<CrossCoupling>,
    /// Dependence of the pendulum on the CoM position.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub op_dependence: Option<OpDependence>,
    /// Dependence of the pendulum on the CoM position with slopes per channel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub op_per_channel: Option<OpPerChannel>,
    /// The ZMP sensor.
    pub sensor: Sensor,
    /// The hidden effects (what the seed's model lacks).
    #[serde(default)]
    pub hidden: Vec<HiddenEffect>,
}

impl Robot {
    /// The seed's nominal SILO2: pendulum of section 6.2, `ωn = 30`, `ζ = 1` on both axes,
    /// an actuator limit of 1000 m/s² (never reached by a stepped sine of a few mm), no
    /// hidden effect, 0.5 mm white noise.
    pub fn seed_nominal() -> Self {
        let axis = AxisMechanics {
            servo: Servo {
                omega_n: 30.0,
                zeta: 1.0,
                accel_limit: 1000.0,
                velocity_limit: None,
            },
            command_delay: 0.0,
            drive_mass_fraction: 0.3,
            transmission: None,
            friction: None,
            modes: Vec::new(),
        };
        Robot {
            name: "SILO2 (seed, section 6)".into(),
            scenario: "clean".into(),
            seed: None,
            pendulum: Pendulum::silo2(),
            axes: [axis.clone(), axis],
            cross_coupling: None,
            op_dependence: None,
            op_per_channel: None,
            sensor: Sensor {
                lowpass_cutoff: None,
                drift_rate: [0.0; 2],
                rezero: None,
                noise: Noise {
                    white_std: 5e-4,
                    coloured_std: 0.0,
                    coloured_tau: 0.5,
                },
            },
            hidden: Vec::new(),
        }
    }

    /// The pendulum the ZMP map uses: the base plus a pendulum-form cross-coupling.
    pub fn effective_pendulum(&self) -> Pendulum {
        let mut p = self.pendulum.clone();
        if let Some(CrossCoupling::Pendulum {
            da12,
            da21,
            db12,
            db21,
        }) = self.cross_coupling
        {
            p.a[0][1] += da12;
            p.a[1][0] += da21;
            p.b[0][1] += db12;
            p.b[1][0] += db21;
        }
        p
    }

    /// The catalogue names of the hidden effects (in the order they were drawn; a form of a
    /// catalogue effect by the effect's name, see [`Effect::catalogue_name`]).
    pub fn hidden_names(&self) -> Vec<&'static str> {
        self.hidden
            .iter()
            .map(|h| h.effect.catalogue_name())
            .collect()
    }

    /// Whether any hidden effect lies outside the project's catalogue.
    pub fn has_outside_effect(&self) -> bool {
        self.hidden.iter().any(|h| !h.in_catalogue)
    }

    /// Pretty JSON of every truth parameter.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a robot always serialises")
    }

    /// Reads `to_json`'s output (and validates it).
    pub fn from_json(text: &str) -> Result<Self, String> {
        let r: Robot = serde_json::from_str(text).map_err(|e| format!("robot JSON: {e}"))?;
        r.validate()?;
        Ok(r)
    }

    /// TOML of every truth parameter.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a robot always serialises")
    }

    /// Reads `to_toml`'s output (and validates it).
    pub fn from_toml(text: &str) -> Result<Self, String> {
        let r: Robot = toml::from_str(text).map_err(|e| format!("robot TOML: {e}"))?;
        r.validate()?;
        Ok(r)
    }
}
