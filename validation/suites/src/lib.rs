//! The test harness of the toolkit's suites (a dev-only crate): blind draws on the virtual
//! robot ([`blind`]), out-of-sample draws of the independent simulator `zmp-indep-sim` run
//! through the user's loop ([`indep`], [`indep_loop`]), the writer of the book sections
//! that a suite measures ([`docs`]) and the held-out record ([`history`]).

pub mod blind;
pub mod docs;
pub mod history;
pub mod indep;
pub mod indep_loop;
