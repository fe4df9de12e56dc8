#![warn(missing_docs)]
//! FMU logic shared by the FMI 2.0 shell (`zmp-fmu`) and the FMI 3.0 shells
//! (`zmp-fmi3-plant`, `zmp-fmi3-controller`), and the packaging used by `cargo xtask fmu`.
//!
//! - [`vars`]: the one variable table (value references, names, units, start values, bounds);
//! - [`sim`]: the co-simulation slave and its communication-step semantics;
//! - [`xml2`]: the FMI 2.0 model description written from the table;
//! - [`guid`]: the GUID, a hash of the model file and the binary version;
//! - [`resource`]: the `fmuResourceLocation` URI;
//! - [`package`]: `cargo build` and zipping of the `.fmu` files;
//! - `fmi3` (feature `fmi3`): the glue to `fmi-export`.
//!
//! No physics here: the plant and the controller are `zmp_models`'.

pub mod guid;
pub mod package;
pub mod resource;
pub mod sim;
pub mod units;
pub mod vars;
pub mod xml2;

#[cfg(feature = "fmi3")]
pub mod fmi3;

pub use sim::Slave;
pub use vars::{FmiVersion, Kind, VarTable};

/// One-paragraph summary of the stepping semantics (see [`sim`]), for the FMU documentation.
pub const STEPPING_DOC: &str = "Internal time grid t_n = t_start + n h with a fixed step h \
(parameter). Plant: a communication step [t, t+H] advances every grid step ending at or before \
t+H; the CoM reference set at t ramps linearly over the first of them and is held over the rest; \
outputs at t+H are those at the last grid point at or before t+H. Controller: samples at the \
grid points, each computed from the inputs current at that instant; outputs at a sample instant \
depend directly on the inputs set there; between samples they hold the last sample. Grid \
comparisons allow 1e-6 h of rounding in the communication times.";
