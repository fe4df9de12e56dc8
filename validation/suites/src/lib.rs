//! The test harness of the toolkit's suites (a dev-only crate): blind draws on the virtual
//! robot ([`blind`]), out-of-sample draws of the independent simulator `zmp-indep-sim` run
//! through the user's loop ([`indep`], [`indep_loop`]), and the held-out record ([`history`]); the
//! book sections a suite measures are written with `zmp_files::sections::check_page`.

pub mod blind;
pub mod history;
pub mod indep;
pub mod indep_loop;
