//! The effective centre of mass from two ankle force/torque sensors (second seed, Muscolo et al.,
//! eqs. 1-7), and beyond it: N postures by least squares, the estimate's covariance, postures that
//! change the body's shape (the static regressor `c(q)`), sensor offsets as nuisance parameters
//! and posture design.
//!
//! Conventions used throughout (SI units):
//! - A sensor reading is the wrench that the sole below the sensor exerts on the body above it,
//!   in the sensor's frame, its moment taken about the sensor's origin.
//! - "The body" (`m_2` of the seed) is everything above the two sensors; the soles (the seed's
//!   feet) are below them and come from the CAD model (eq. 6).
//! - Static equilibrium of the body: the sensors' total wrench `(F, tau)` about the frame's origin
//!   and the weight at the centre of mass `c` balance, so `F = -m g` and `tau = c x F`. The last
//!   is the seed's pair of lines `X = alpha + beta Z`, `Y = gamma + delta Z` (eq. 3) with
//!   `alpha = -tau_y/F_z`, `beta = F_x/F_z`, `gamma = tau_x/F_z`, `delta = F_y/F_z`.

pub mod design;
pub mod least_squares;
pub mod regressor;
pub mod two_posture;
pub mod wrench;

pub use design::{d_optimal_subset, log_det, DesignChoice};
pub use least_squares::{rigid_com, NoiseModel, RigidEstimate};
pub use regressor::{
    estimate, information, CalibrationPosture, RegressorEstimate, RegressorModel, SoleCad,
    UNKNOWNS, UNKNOWN_NAMES,
};
pub use two_posture::{intersect, total_com_with_feet, CadCom, PostureLines};
pub use wrench::{
    joint_moment, joint_moments, ComError, JointAxis, MotorCurrent, PostureWrench, SensorReading,
    Wrench,
};

/// Standard gravity (m/s^2), the value the twin uses.
pub const G: f64 = 9.81;

/// 3-vectors and 3x3 matrices (nalgebra fixed size).
pub type Vec3 = nalgebra::Vector3<f64>;
/// See [`Vec3`].
pub type Mat3 = nalgebra::Matrix3<f64>;

/// The cross-product matrix: `skew(a) * b == a x b`.
pub fn skew(a: &Vec3) -> Mat3 {
    Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// Rotation about x by `angle` (rad).
pub fn rot_x(angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    Mat3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

/// Rotation about y by `angle` (rad).
pub fn rot_y(angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    Mat3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

/// Rotation about z by `angle` (rad).
pub fn rot_z(angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    Mat3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}
