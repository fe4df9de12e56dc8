//! The kinds of effect the plant knows, as a type: what crosses crate boundaries (the
//! diagnosis's findings, the model's structure, the FMU's variables) is an [`EffectKind`], and
//! its stable name ([`EffectKind::name`]) is what model files, diagnosis JSON and FMU variable
//! names carry on disk.

use crate::effect::EffectInfo;
use std::fmt;
use std::str::FromStr;

/// One kind of effect: the core (pendulum, tracking low-pass), the seed's acceleration
/// saturation and uncertainty, and the effects a real robot adds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum EffectKind {
    /// The 2×2 inverted pendulum `a_ij − b_ij s²` (core).
    Pendulum,
    /// The servo's second-order tracking low-pass (core).
    TrackingLowpass,
    /// The servo's acceleration (force) limit.
    AccelerationSaturation,
    /// Coulomb friction against the servo's motion.
    CoulombFriction,
    /// A pure delay of the CoM command.
    TimeDelay,
    /// A play, on the command or between drive and trunk.
    Backlash,
    /// The seed's multiplicative uncertainty `1 + W Δ` per channel.
    Uncertainty,
    /// Pendulum coefficients that change with the CoM position.
    OperatingPointDependence,
    /// A lightly damped mode on the ZMP path.
    StructuralMode,
    /// Part of the trunk's mass on a flexible link the servo drives.
    FlexibleTrunk,
    /// A first-order low-pass on the ZMP measurement.
    SensorLowpass,
    /// An offset and a linear drift of the ZMP reading.
    SensorDrift,
}

impl EffectKind {
    /// Every kind, in the registry's canonical order.
    pub const ALL: [EffectKind; 12] = [
        EffectKind::Pendulum,
        EffectKind::TrackingLowpass,
        EffectKind::AccelerationSaturation,
        EffectKind::CoulombFriction,
        EffectKind::TimeDelay,
        EffectKind::Backlash,
        EffectKind::Uncertainty,
        EffectKind::OperatingPointDependence,
        EffectKind::StructuralMode,
        EffectKind::FlexibleTrunk,
        EffectKind::SensorLowpass,
        EffectKind::SensorDrift,
    ];

    /// The stable name on disk (model-file table, JSON value, FMU variable prefix).
    pub const fn name(self) -> &'static str {
        match self {
            EffectKind::Pendulum => "pendulum",
            EffectKind::TrackingLowpass => "tracking_lowpass",
            EffectKind::AccelerationSaturation => "acceleration_saturation",
            EffectKind::CoulombFriction => "coulomb_friction",
            EffectKind::TimeDelay => "time_delay",
            EffectKind::Backlash => "backlash",
            EffectKind::Uncertainty => "uncertainty",
            EffectKind::OperatingPointDependence => "operating_point_dependence",
            EffectKind::StructuralMode => "structural_mode",
            EffectKind::FlexibleTrunk => "flexible_trunk",
            EffectKind::SensorLowpass => "sensor_lowpass",
            EffectKind::SensorDrift => "sensor_drift",
        }
    }

    /// The kind named `name` on disk.
    pub fn parse(name: &str) -> Option<EffectKind> {
        EffectKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Its registry entry (parameters, site, builder).
    pub fn info(self) -> &'static EffectInfo {
        crate::effect::REGISTRY
            .iter()
            .copied()
            .find(|i| i.kind == self)
            .expect("every kind has a registry entry (tested)")
    }
}

impl fmt::Display for EffectKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name on disk equals the kind it names.
impl PartialEq<EffectKind> for str {
    fn eq(&self, k: &EffectKind) -> bool {
        self == k.name()
    }
}

impl PartialEq<EffectKind> for &str {
    fn eq(&self, k: &EffectKind) -> bool {
        *self == k.name()
    }
}

impl PartialEq<EffectKind> for String {
    fn eq(&self, k: &EffectKind) -> bool {
        self == k.name()
    }
}

impl PartialEq<EffectKind> for &String {
    fn eq(&self, k: &EffectKind) -> bool {
        *self == k.name()
    }
}

impl From<EffectKind> for String {
    fn from(k: EffectKind) -> String {
        k.name().to_string()
    }
}

impl FromStr for EffectKind {
    type Err = String;
    fn from_str(s: &str) -> Result<EffectKind, String> {
        EffectKind::parse(s).ok_or_else(|| {
            let names: Vec<&str> = EffectKind::ALL.iter().map(|k| k.name()).collect();
            format!("unknown effect {s:?} (known: {})", names.join(", "))
        })
    }
}

impl serde::Serialize for EffectKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for EffectKind {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<EffectKind, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_is_in_the_registry_once_and_names_read_back() {
        assert_eq!(crate::effect::REGISTRY.len(), EffectKind::ALL.len());
        for (k, info) in EffectKind::ALL.iter().zip(crate::effect::REGISTRY) {
            assert_eq!(info.kind, *k, "registry order");
            assert_eq!(k.info().kind, *k);
            assert_eq!(EffectKind::parse(k.name()), Some(*k));
            assert_eq!(k.to_string().parse::<EffectKind>(), Ok(*k));
        }
        assert!("friction"
            .parse::<EffectKind>()
            .unwrap_err()
            .contains("time_delay"));
    }
}
