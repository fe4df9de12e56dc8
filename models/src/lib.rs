#![doc = include_str!("../README.md")]
// Index loops read as the matrix algebra they implement.
#![allow(clippy::needless_range_loop)]

pub mod axis;
pub mod closed_loop;
pub mod com;
pub mod controller;
pub mod effect;
pub mod effects;
pub mod harmonic;
pub mod kind;
pub mod lti;
pub mod lti_effect;
pub mod memo;
pub mod model_file;
pub mod plant;
pub mod robust;
pub mod walking;

pub use axis::{Axis, Channel};
pub use effect::{lookup, Binding, Effect, EffectInfo, ParamSpec, Site, REGISTRY};
pub use kind::EffectKind;
pub use lti::logspace;
pub use model_file::{EffectInstance, ModelError, ModelSpec, MODEL_FORMAT};
pub use num_complex::Complex64;
pub use plant::{Plant, PlantOutput, DEFAULT_STEP};
