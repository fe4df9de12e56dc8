//! The test harness of the toolkit's suites (a dev-only crate): blind draws on the virtual
//! robot ([`blind`]), out-of-sample draws of the independent simulator `zmp-indep-sim` run
//! through the user's loop ([`indep`], [`indep_loop`]) and as a sharded job ([`sharded`]), the
//! held-out record ([`history`]) and the table of designed records the design-next suites
//! write ([`design_table`]); the book sections a suite measures are written with
//! `zmp_files::sections::check_page`.

#![warn(missing_docs)]

pub mod blind;
pub mod design_table;
pub mod history;
pub mod indep;
pub mod indep_loop;
pub mod sharded;
