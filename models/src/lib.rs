#![doc = include_str!("../README.md")]

pub mod axis;

pub use axis::{Axis, Channel};
