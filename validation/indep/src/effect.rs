//! The hidden effects: their catalogue names and how they relate to the project's catalogue.

use serde::{Deserialize, Serialize};

/// The hidden physical effects this simulator can add to the seed's model.
///
/// The project's catalogue is the first nine (`zmp-diagnosis/1` effect names) and two further
/// forms of its effects, the last two variants (added last so that every older effect keeps
/// its random stream, see `draw`): an operating-point dependence with slopes per channel
/// (`op_per_channel`, a diagnosis names it `operating_point_dependence`) and a sensor
/// re-zeroed at every record with a drift rate that changes from record to record
/// (`sensor_rezero`, named `sensor_drift`). The four between are deliberately outside it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Command latency between the reference and the servo (`time_delay`).
    TimeDelay,
    /// Play in the transmission between drive and trunk (`backlash`).
    Backlash,
    /// Stick-slip Coulomb friction on the trunk joint (`coulomb_friction`).
    CoulombFriction,
    /// A much tighter actuator force limit than the clean draw's (`acceleration_saturation`).
    AccelerationSaturation,
    /// A lightly damped flexible mode of the trunk (`structural_mode`).
    StructuralMode,
    /// First-order filter of the force-sensor ZMP (`sensor_lowpass`).
    SensorLowpass,
    /// Pendulum gains changing with the CoM position (`operating_point_dependence`).
    OperatingPointDependence,
    /// Linear drift of the ZMP reading (`sensor_drift`).
    SensorDrift,
    /// Extra coupling between the planes (`cross_coupling`).
    CrossCoupling,
    /// Two flexible modes in series (outside the catalogue).
    SecondStructuralMode,
    /// Friction whose static level exceeds the kinetic one, with Stribeck decay (outside).
    StribeckFriction,
    /// A velocity limit in the servo's velocity loop (outside).
    RateLimitedServo,
    /// A compliant transmission with a hardening (cubic) spring (outside).
    CubicStiffness,
    /// Pendulum gains changing with the CoM position, on some channels only, each with its
    /// own slopes (`operating_point_dependence` per channel).
    OpPerChannel,
    /// A ZMP sensor re-zeroed at every record, drifting at a rate that changes from record
    /// to record (`sensor_drift` with a rate per record).
    SensorRezero,
}

impl Effect {
    /// The project's catalogue, in the order of `/work/shared/spec/diagnosis-json.md`, then
    /// the two further forms of its effects.
    pub const CATALOGUE: [Effect; 11] = [
        Effect::TimeDelay,
        Effect::Backlash,
        Effect::CoulombFriction,
        Effect::AccelerationSaturation,
        Effect::StructuralMode,
        Effect::SensorLowpass,
        Effect::OperatingPointDependence,
        Effect::SensorDrift,
        Effect::CrossCoupling,
        Effect::OpPerChannel,
        Effect::SensorRezero,
    ];
    /// The effects outside the catalogue.
    pub const OUTSIDE: [Effect; 4] = [
        Effect::SecondStructuralMode,
        Effect::StribeckFriction,
        Effect::RateLimitedServo,
        Effect::CubicStiffness,
    ];

    /// Every effect, catalogue first.
    pub fn all() -> impl Iterator<Item = Effect> {
        Self::CATALOGUE.into_iter().chain(Self::OUTSIDE)
    }

    /// The snake-case name (the catalogue name for catalogue effects).
    pub fn name(self) -> &'static str {
        match self {
            Effect::TimeDelay => "time_delay",
            Effect::Backlash => "backlash",
            Effect::CoulombFriction => "coulomb_friction",
            Effect::AccelerationSaturation => "acceleration_saturation",
            Effect::StructuralMode => "structural_mode",
            Effect::SensorLowpass => "sensor_lowpass",
            Effect::OperatingPointDependence => "operating_point_dependence",
            Effect::SensorDrift => "sensor_drift",
            Effect::CrossCoupling => "cross_coupling",
            Effect::SecondStructuralMode => "second_structural_mode",
            Effect::StribeckFriction => "stribeck_friction",
            Effect::RateLimitedServo => "rate_limited_servo",
            Effect::CubicStiffness => "cubic_stiffness",
            Effect::OpPerChannel => "op_per_channel",
            Effect::SensorRezero => "sensor_rezero",
        }
    }

    /// The name a diagnosis restricted to the catalogue gives it when it names it right: the
    /// catalogue effect's name for a catalogue effect or form (`op_per_channel` →
    /// `operating_point_dependence`, `sensor_rezero` → `sensor_drift`), the own name for an
    /// effect outside the catalogue.
    pub fn catalogue_name(self) -> &'static str {
        match self {
            Effect::OpPerChannel => Effect::OperatingPointDependence.name(),
            Effect::SensorRezero => Effect::SensorDrift.name(),
            e => e.name(),
        }
    }

    /// The effect of a name, `None` for an unknown name.
    pub fn from_name(name: &str) -> Option<Effect> {
        Self::all().find(|e| e.name() == name)
    }

    /// Whether the project's catalogue names this effect.
    pub fn in_catalogue(self) -> bool {
        Self::CATALOGUE.contains(&self)
    }

    /// For an effect outside the catalogue, the catalogue effect whose signature is closest
    /// (what a diagnosis restricted to the catalogue would most plausibly name); `None` for
    /// catalogue effects. `second_structural_mode` → `structural_mode`, `stribeck_friction` → `coulomb_friction`,
    /// `rate_limited_servo` → `acceleration_saturation` (both cut the response of large, fast
    /// records), `cubic_stiffness` → `structural_mode` (its linear part is a compliance mode).
    pub fn nearest_catalogue(self) -> Option<Effect> {
        match self {
            Effect::SecondStructuralMode => Some(Effect::StructuralMode),
            Effect::StribeckFriction => Some(Effect::CoulombFriction),
            Effect::RateLimitedServo => Some(Effect::AccelerationSaturation),
            Effect::CubicStiffness => Some(Effect::StructuralMode),
            _ => None,
        }
    }

    /// Two effects that cannot be drawn together because they describe the same element.
    pub fn conflicts_with(self, other: Effect) -> bool {
        use Effect::*;
        let pair = |a, b| (self == a && other == b) || (self == b && other == a);
        self == other
            || pair(CoulombFriction, StribeckFriction)
            || pair(StructuralMode, SecondStructuralMode)
            || pair(Backlash, CubicStiffness)
            || pair(OperatingPointDependence, OpPerChannel)
            || pair(SensorDrift, SensorRezero)
    }
}

impl std::fmt::Display for Effect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
