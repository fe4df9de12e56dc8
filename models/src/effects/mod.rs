//! One module per physical effect. Adding an effect: a file here and a line in
//! [`crate::effect::REGISTRY`].

pub mod acceleration_saturation;
pub mod backlash;
pub mod coulomb_friction;
pub mod flexible_trunk;
pub mod operating_point;
pub mod pendulum;
pub mod sensor_drift;
pub mod sensor_lowpass;
pub mod servo;
pub mod servo_link;
pub mod structural_mode;
pub mod time_delay;
pub mod tracking_lowpass;
pub mod uncertainty;
