//! Compare a model with a campaign, find where it fails, and name the physical effect that is
//! missing: every catalogued effect is fitted with the model's core parameters and scored on
//! held-out records; effects are added forward while they remove a significant part of the
//! error.

pub mod augment;
pub mod candidates;
pub mod cells;
pub mod engine;
pub mod evidence;
pub mod lm;
pub mod measure;
pub mod observe;
pub mod report;
pub mod run;

pub use run::{diagnose, DiagnoseError, DiagnoseOptions, Diagnosis, Finding, DIAGNOSIS_FORMAT};
