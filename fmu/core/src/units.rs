//! SI base-unit exponents of the unit strings used by the model registry and the FMUs, for the
//! `UnitDefinitions` of the model descriptions.

/// Exponents of the SI base units (and rad) of one unit; all zero for "1".
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BaseUnit {
    /// Exponent of the kilogram.
    pub kg: i32,
    /// Exponent of the metre.
    pub m: i32,
    /// Exponent of the second.
    pub s: i32,
    /// Exponent of the radian.
    pub rad: i32,
}

/// The base-unit exponents of `unit`, `None` for a unit this table does not know (the unit is
/// then still defined, without a base unit).
pub fn base_unit(unit: &str) -> Option<BaseUnit> {
    let u = |m, s, rad| Some(BaseUnit { kg: 0, m, s, rad });
    match unit {
        "1" => u(0, 0, 0),
        "m" => u(1, 0, 0),
        "1/m" => u(-1, 0, 0),
        "s" => u(0, 1, 0),
        "s2" => u(0, 2, 0),
        "1/s" => u(0, -1, 0),
        "m/s" => u(1, -1, 0),
        "m/s2" => u(1, -2, 0),
        "rad" => u(0, 0, 1),
        "rad/s" => u(0, -1, 1),
        "rad/m" => u(-1, 0, 1),
        "kg" => Some(BaseUnit {
            kg: 1,
            ..BaseUnit::default()
        }),
        _ => None,
    }
}

impl BaseUnit {
    /// `(attribute name, exponent)` pairs with a non-zero exponent, in FMI attribute names.
    pub fn exponents(&self) -> Vec<(&'static str, i32)> {
        [
            ("kg", self.kg),
            ("m", self.m),
            ("s", self.s),
            ("rad", self.rad),
        ]
        .into_iter()
        .filter(|(_, e)| *e != 0)
        .collect()
    }
}
