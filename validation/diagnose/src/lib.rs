//! Compare a model with a campaign, find where it fails, and name the physical effects that
//! are missing: one search over model structures (the identified model plus up to four
//! effects of the catalogue, each under its law), every structure scored by its held-out
//! chi-square and compared by one paired test at a stated significance level; when the
//! records cannot separate several structures, the verdict says so and names them.

#![warn(missing_docs)]

pub mod augment;
pub mod cells;
pub mod criterion;
pub mod design;
pub mod fit;
pub mod iterate;
pub mod lm;
pub mod measure;
pub mod observe;
pub mod profiles;
pub mod run;
pub mod search;
pub mod structure;
pub mod words;

pub use run::{diagnose, DiagnoseError, DiagnoseOptions, Diagnosis, Finding, DIAGNOSIS_FORMAT};
pub use structure::{Candidate, Law, Structure, Verdict};
