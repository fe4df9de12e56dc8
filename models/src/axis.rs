//! Axis and channel names of the 2×2 ZMP plant (x: lateral plane, y: sagittal plane).

use serde::{Deserialize, Serialize};
use std::fmt;

/// One horizontal axis. `X` is the lateral plane, `Y` the sagittal plane (first seed, section 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// Lateral plane (first axis, index 0).
    X,
    /// Sagittal plane (second axis, index 1).
    Y,
}

impl Axis {
    /// Both axes, x first.
    pub const BOTH: [Axis; 2] = [Axis::X, Axis::Y];

    /// 0 for x, 1 for y: the row/column index in the 2×2 plant.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
        }
    }

    /// The axis of index `i` (0: x, 1: y); `None` for any other index.
    pub fn from_index(i: usize) -> Option<Axis> {
        match i {
            0 => Some(Axis::X),
            1 => Some(Axis::Y),
            _ => None,
        }
    }

    /// The axis's name in model files and keys: "x" or "y".
    pub fn name(self) -> &'static str {
        match self {
            Axis::X => "x",
            Axis::Y => "y",
        }
    }

    /// The axis named `s` ("x" or "y"), `None` for anything else.
    pub fn parse(s: &str) -> Option<Axis> {
        match s {
            "x" => Some(Axis::X),
            "y" => Some(Axis::Y),
            _ => None,
        }
    }
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Channel `G_ij` of the plant: output `zmp_i` from input `i_cr`, `j` the excited reference.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Channel {
    /// The ZMP axis the channel measures (`i` of `G_ij`).
    pub output: Axis,
    /// The CoM reference axis that excites it (`j` of `G_ij`).
    pub input: Axis,
}

impl Channel {
    /// The four channels, row by row: G11, G12, G21, G22.
    pub const ALL: [Channel; 4] = [
        Channel::new(Axis::X, Axis::X),
        Channel::new(Axis::X, Axis::Y),
        Channel::new(Axis::Y, Axis::X),
        Channel::new(Axis::Y, Axis::Y),
    ];

    /// The channel from reference `input` to ZMP `output`.
    pub const fn new(output: Axis, input: Axis) -> Channel {
        Channel { output, input }
    }

    /// "G11", "G12", "G21", "G22".
    pub fn name(self) -> &'static str {
        match (self.output, self.input) {
            (Axis::X, Axis::X) => "G11",
            (Axis::X, Axis::Y) => "G12",
            (Axis::Y, Axis::X) => "G21",
            (Axis::Y, Axis::Y) => "G22",
        }
    }

    /// "11", "12", "21", "22": the suffix used for parameter keys (`a11`, `b21`, ...).
    pub fn suffix(self) -> &'static str {
        &self.name()[1..]
    }

    /// The channel named `s`, as "G12" or as its suffix "12"; `None` otherwise.
    pub fn parse(s: &str) -> Option<Channel> {
        Channel::ALL
            .into_iter()
            .find(|c| c.name() == s || c.suffix() == s)
    }
}

impl fmt::Display for Channel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
