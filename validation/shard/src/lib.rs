//! Many-unit jobs past one machine (issue 57): the contract every sharded command keeps.
//!
//! A **job** is a list of **units** with stable ids and an expected cost ([`UnitSpec`]) plus
//! the command's parameters ([`Job`]); it lives in one folder (`job.json`, a `.zmp-job`
//! marker, `units/<id>.json`).
//!
//! - `--shard i/n` ([`Shard`]) takes the units of one part of a deterministic partition
//!   balanced by expected cost ([`partition`]: longest-processing-time-first on the expected
//!   costs, ties by id), so every run of the same job and `n` gives the same parts.
//! - Each unit writes one result file ([`unit::write_unit`], atomically through `zmp_files`),
//!   named by its id, with its wall time and its outcome or its error. Re-running a shard or
//!   one unit replaces only those units' files; nothing is appended, so no unit is lost or
//!   counted twice.
//! - [`collect::collect`] reads the folder back for a merge, keyed by unit id: the units done
//!   in job order, the failed ones, the missing ones. What a unit computes is the command's
//!   business: its outcome is JSON to this crate.
//! - [`cost`]: the critical path and the wall time predicted on N workers by a
//!   longest-processing-time-first schedule over the measured unit times.
//!
//! It is its own crate (not a module of the dev-only suites harness) because three crates
//! keep it: the suites (`cargo xtask suite`), `cargo xtask fleet`, and the SABIAN twin's
//! `calibrate-com`, which links MuJoCo and must not depend on the harness.

#![warn(missing_docs)]

pub mod claim;
pub mod cli;
pub mod collect;
pub mod cost;
pub mod job;
mod partition;
pub mod unit;

pub use collect::{collect, Collected, Merged};
pub use job::{open_job, read_job, run_units, Job, JobKind, RunOptions, ShardRun};
pub use partition::{lpt_order, partition, shard_sequence, shard_units, Shard, UnitSpec};
