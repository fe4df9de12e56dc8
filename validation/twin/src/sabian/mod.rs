//! The SABIAN twin of the second seed: the robot (`models/mjcf/sabian.xml` plus an error mass),
//! whole-body inverse kinematics, the CoM calibration postures and the walking comparison (open
//! loop and with the seed's Torso Position Control).

pub mod calibrate;
pub mod cli;
pub mod compare;
pub mod effort;
pub mod experiment;
mod figures;
pub mod ik;
pub mod postures;
pub mod report;
pub mod robot;
pub mod tables;
pub mod tpc;
pub mod walk;

pub use robot::{PointMass, Sabian, Variant};
