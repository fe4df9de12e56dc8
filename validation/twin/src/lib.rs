#![warn(missing_docs)]
//! MuJoCo twins of the seeds' robots (SILO2, SABIAN): the only crate of the workspace that links
//! MuJoCo (3.17.0 through `mujoco-rs`), so everything else builds without it.
//!
//! MuJoCo's fatal errors exit the process; this crate checks its inputs first and uses the
//! fallible (`try_*`) calls, so a bad model file or index is an error, never an exit.

// Index loops read as the matrix algebra they implement.
#![allow(clippy::needless_range_loop)]

pub mod mj;
#[cfg(feature = "renderer")]
pub mod render;
pub mod silo2;
pub mod zmp;

pub mod sabian;

pub use mj::{load_mjcf, load_mjcf_str, TwinError};
