//! Compare a model with a campaign, find where it fails, and name the physical effects that
//! are missing: every catalogued effect is fitted with every parameter of the model and scored
//! on held-out records; effects are added forward (or in pairs when they mask each other)
//! while they pass a held-out likelihood-ratio test and remove a relevant part of what is
//! left.

pub mod augment;
pub mod candidates;
pub mod cells;
pub mod design;
pub mod engine;
pub mod evidence;
pub mod iterate;
pub mod lm;
pub mod measure;
pub mod observe;
pub mod run;
pub mod select;

pub use run::{diagnose, DiagnoseError, DiagnoseOptions, Diagnosis, Finding, DIAGNOSIS_FORMAT};
