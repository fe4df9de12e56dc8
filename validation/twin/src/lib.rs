//! MuJoCo twins of the seeds' robots (SILO2, SABIAN): the only crate of the workspace that links
//! MuJoCo (3.17.0 through `mujoco-rs`), so everything else builds without it.
//!
//! MuJoCo's fatal errors exit the process; this crate checks its inputs first and uses the
//! fallible (`try_*`) calls, so a bad model file or index is an error, never an exit.

// Index loops read as the physics they implement (joints, samples).
#![allow(clippy::needless_range_loop)]

pub mod mj;

pub use mj::{load_mjcf, load_mjcf_str, TwinError};
pub mod sabian;
