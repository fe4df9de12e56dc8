#![doc = include_str!("../README.md")]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod design;
pub mod draw;
pub mod effect;
pub mod integrate;
mod mechanics;
mod noise;
pub mod response;
pub mod robot;
pub mod scenario;
mod visibility;
pub mod write;

pub use design::{AxisName, Design, ListedRecord, RecordSpec};
pub use draw::{draw, draw_for_design, draw_with, CouplingForm, DrawOptions, Visibility};
pub use integrate::{simulate, simulate_records, try_simulate, RecordData, RecordTruth};
pub use robot::{
    AxisMechanics, CrossCoupling, Effect, FlexibleMode, Friction, HiddenEffect, Noise,
    OpDependence, OpPerChannel, Pendulum, Rezero, Robot, Sensor, Servo, Transmission,
};
pub use scenario::Scenario;
pub use write::{write_campaign, write_records, GENERATOR};
