pub mod blind;
pub mod campaign;
pub mod diagnose;
pub mod identify;
pub mod io;
pub mod ledger;
pub mod plot;
pub mod virtual_robot;
