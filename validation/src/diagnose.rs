//! Compare a model with a campaign, find where it fails, and name the physical effect that is
//! missing: every catalogued effect is fitted with the model's core parameters and scored on
//! held-out records.
//!
//! Work in progress: the observation, error measure, fitting and held-out scoring are here;
//! the command line, the report and the fast describing functions the nonlinear candidates
//! need (friction and saturation re-simulate the servo per evaluation today) are not yet.

pub mod candidates;
pub mod engine;
pub mod lm;
pub mod measure;
pub mod observe;
