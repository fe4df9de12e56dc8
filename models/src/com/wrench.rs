//! Wrenches of the two ankle sensors (seed 2, eqs. 1-2) and the joint moments from motor
//! currents (eq. 7), with the input checks every estimator relies on.

use super::{skew, Mat3, Vec3};

/// What the CoM calculation refuses, and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ComError {
    /// An input is NaN or infinite.
    #[error("{what} is not a finite number")]
    NonFinite {
        /// Which input.
        what: String,
    },
    #[error(
        "the {foot} foot carries {normal_force_n:.3} N, below the {min_n:.3} N the calculation \
         needs: both feet must be loaded (is the foot lifted or the sensor unplugged?)"
    )]
    /// A foot presses on its sensor with less than the least load that counts as standing.
    UnloadedFoot {
        /// "left" or "right".
        foot: &'static str,
        /// The force along the sensor's z axis, N.
        normal_force_n: f64,
        /// The least load that counts as standing, N.
        min_n: f64,
    },
    #[error(
        "postures {a} and {b} are too close to separate Z: their slopes differ by {gap:.3e} \
         (tan of the tilt difference), at least {min:.3e} is needed"
    )]
    /// Two postures tilt the body too little apart to separate the CoM's height.
    PosturesTooClose {
        /// Index of the first posture.
        a: usize,
        /// Index of the second posture.
        b: usize,
        /// Difference of their slopes (tan of the tilt difference), dimensionless.
        gap: f64,
        /// The least difference that separates them, dimensionless.
        min: f64,
    },
    /// Fewer postures than the estimator has unknowns to determine.
    #[error("need at least {need} postures, got {got}")]
    TooFewPostures {
        /// The postures the estimator needs.
        need: usize,
        /// The postures given.
        got: usize,
    },
    #[error(
        "the postures do not determine {what}: the stacked system's condition number is \
         {condition:.3e} (tilt the body in more than one way, or unload each foot once)"
    )]
    /// The postures leave a combination of the unknowns undetermined.
    Singular {
        /// The unknowns not determined.
        what: String,
        /// Condition number of the stacked system.
        condition: f64,
    },
    /// A quantity that must be positive (a mass, a noise level) is not.
    #[error("{what} must be positive, got {value}")]
    NotPositive {
        /// Which quantity.
        what: String,
        /// Its value, in its unit.
        value: f64,
    },
}

/// A force (N) and a moment (N m) about a stated point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wrench {
    /// Force (N).
    pub force: Vec3,
    /// Moment (N m) about the wrench's reference point.
    pub moment: Vec3,
}

impl Wrench {
    /// The wrench of `force` (N) and `moment` (N m).
    pub fn new(force: Vec3, moment: Vec3) -> Wrench {
        Wrench { force, moment }
    }

    /// No force and no moment.
    pub fn zero() -> Wrench {
        Wrench::new(Vec3::zeros(), Vec3::zeros())
    }

    /// Whether every component is a finite number.
    pub fn is_finite(&self) -> bool {
        self.force
            .iter()
            .chain(self.moment.iter())
            .all(|v| v.is_finite())
    }

    /// The same wrench expressed in a frame rotated by `r` (columns: the old axes in the new
    /// frame).
    pub fn rotated(&self, r: &Mat3) -> Wrench {
        Wrench::new(r * self.force, r * self.moment)
    }

    /// The moment taken about the origin instead of the point `at`, where the wrench's reference
    /// point sits (both in the same frame): `m + at x f`.
    pub fn about_origin_from(&self, at: &Vec3) -> Wrench {
        Wrench::new(self.force, self.moment + at.cross(&self.force))
    }

    /// The components in the order fx, fy, fz, mx, my, mz (N, N m).
    pub fn as_array(&self) -> [f64; 6] {
        [
            self.force.x,
            self.force.y,
            self.force.z,
            self.moment.x,
            self.moment.y,
            self.moment.z,
        ]
    }

    /// The wrench of components fx, fy, fz, mx, my, mz (N, N m).
    pub fn from_array(v: [f64; 6]) -> Wrench {
        Wrench::new(Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]))
    }
}

impl std::ops::Add for Wrench {
    type Output = Wrench;
    fn add(self, o: Wrench) -> Wrench {
        Wrench::new(self.force + o.force, self.moment + o.moment)
    }
}

impl std::ops::Sub for Wrench {
    type Output = Wrench;
    fn sub(self, o: Wrench) -> Wrench {
        Wrench::new(self.force - o.force, self.moment - o.moment)
    }
}

/// One ankle sensor's reading and where the sensor is: the wrench the sole exerts on the body,
/// in the sensor frame about the sensor origin, and the sensor's pose in the calibration frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorReading {
    /// Sensor origin in the calibration frame (m).
    pub position: Vec3,
    /// Sensor axes in the calibration frame (rotation sensor -> calibration frame).
    pub rotation: Mat3,
    /// The reading (N, N m) in the sensor frame.
    pub wrench: Wrench,
}

impl SensorReading {
    /// The reading in the calibration frame, moment about the frame's origin.
    pub fn in_frame(&self) -> Wrench {
        self.wrench
            .rotated(&self.rotation)
            .about_origin_from(&self.position)
    }

    /// The 6x6 map from a perturbation of the reading (sensor frame) to the wrench in the
    /// calibration frame about its origin: `[R 0; skew(p) R  R]`.
    pub fn jacobian(&self) -> nalgebra::SMatrix<f64, 6, 6> {
        let mut j = nalgebra::SMatrix::<f64, 6, 6>::zeros();
        j.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.rotation);
        j.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(skew(&self.position) * self.rotation));
        j.fixed_view_mut::<3, 3>(3, 3).copy_from(&self.rotation);
        j
    }
}

/// The axis about which a joint's moment acts in the seed's eq. 7 sums.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointAxis {
    /// Roll joints: summed into `M_X2`, the x component of the calibration frame.
    Roll,
    /// Pitch joints: summed into `M_Y2`, the y component.
    Pitch,
    /// Yaw joints: summed into `M_Z2`, the z component.
    Yaw,
}

/// A motor's torque constant and measured current.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorCurrent {
    /// The axis the joint's moment acts about.
    pub axis: JointAxis,
    /// Torque constant including the gear ratio (N m / A).
    pub torque_constant_nm_per_a: f64,
    /// Measured current (A).
    pub current_a: f64,
}

/// The seed's eq. 7: a joint's moment `M = K I` (N m).
pub fn joint_moment(torque_constant_nm_per_a: f64, current_a: f64) -> f64 {
    torque_constant_nm_per_a * current_a
}

/// The seed's `(M_X2, M_Y2, M_Z2)`: the sums of the roll, pitch and yaw joints' moments (eq. 7).
pub fn joint_moments(currents: &[MotorCurrent]) -> Result<Vec3, ComError> {
    let mut m = Vec3::zeros();
    for (k, c) in currents.iter().enumerate() {
        let v = joint_moment(c.torque_constant_nm_per_a, c.current_a);
        if !v.is_finite() {
            return Err(ComError::NonFinite {
                what: format!("motor {k}'s moment K*I"),
            });
        }
        match c.axis {
            JointAxis::Roll => m.x += v,
            JointAxis::Pitch => m.y += v,
            JointAxis::Yaw => m.z += v,
        }
    }
    Ok(m)
}

/// Both feet's readings in one static posture, with the seed's extra moment `M_2`.
///
/// The seed's eq. 2 adds `M_2 = (sum of roll, pitch, yaw joint moments)` (eq. 7) to the
/// sensors' moments. For the free body above the sensors the joint moments are internal (each
/// acts on both of the links it joins) and cancel, so a body whose whole weight goes through the
/// sensors has `M_2 = 0`; the term is kept for the seed's formula (it is the place where an
/// external moment on the body, e.g. a cable pulled from outside, would enter) and the twin
/// passes zero. A test shows what a non-zero `M_2` does to the estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PostureWrench {
    /// The left ankle sensor's reading.
    pub left: SensorReading,
    /// The right ankle sensor's reading.
    pub right: SensorReading,
    /// The seed's `M_2` (N m) in the calibration frame.
    pub extra_moment: Vec3,
}

impl PostureWrench {
    /// The posture of the two readings with no extra moment (`M_2 = 0`).
    pub fn new(left: SensorReading, right: SensorReading) -> PostureWrench {
        PostureWrench {
            left,
            right,
            extra_moment: Vec3::zeros(),
        }
    }

    /// Checks the inputs: every number finite, each foot pressing on its sensor with at least
    /// `min_foot_load_n` along the sensor's z axis.
    pub fn check(&self, min_foot_load_n: f64) -> Result<(), ComError> {
        for (name, s) in [("left", &self.left), ("right", &self.right)] {
            if !s.wrench.is_finite() {
                return Err(ComError::NonFinite {
                    what: format!("the {name} foot's wrench"),
                });
            }
            if !s
                .position
                .iter()
                .chain(s.rotation.iter())
                .all(|v| v.is_finite())
            {
                return Err(ComError::NonFinite {
                    what: format!("the {name} sensor's pose"),
                });
            }
            // The sole pushes the body up: +z in the sensor frame.
            let fz = s.wrench.force.z;
            if fz.is_nan() || fz < min_foot_load_n {
                return Err(ComError::UnloadedFoot {
                    foot: if name == "left" { "left" } else { "right" },
                    normal_force_n: fz,
                    min_n: min_foot_load_n,
                });
            }
        }
        if !self.extra_moment.iter().all(|v| v.is_finite()) {
            return Err(ComError::NonFinite {
                what: "the joint moment M_2".into(),
            });
        }
        Ok(())
    }

    /// Eq. 1: the total wrench on the body about the frame's origin (both feet and `M_2`).
    pub fn total(&self) -> Wrench {
        let w = self.left.in_frame() + self.right.in_frame();
        Wrench::new(w.force, w.moment + self.extra_moment)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::com::rot_y;

    #[test]
    fn moving_the_reference_point_keeps_the_moment_of_a_pure_force_at_its_line() {
        // A 10 N upward force at x = 0.2 has moment -2 N m about y at the origin.
        let w = Wrench::new(Vec3::new(0.0, 0.0, 10.0), Vec3::zeros());
        let o = w.about_origin_from(&Vec3::new(0.2, 0.0, 0.0));
        assert!((o.moment.y + 2.0).abs() < 1e-12);
        let s = SensorReading {
            position: Vec3::new(0.2, 0.0, 0.0),
            rotation: rot_y(0.3),
            wrench: w,
        };
        // The Jacobian is the linear map in_frame applies.
        let j = s.jacobian();
        let v = j * nalgebra::SVector::<f64, 6>::from_row_slice(&w.as_array());
        let direct = s.in_frame().as_array();
        for k in 0..6 {
            assert!((v[k] - direct[k]).abs() < 1e-12);
        }
    }

    #[test]
    fn eq7_sums_joint_moments_by_axis_and_rejects_nan() {
        let c = [
            MotorCurrent {
                axis: JointAxis::Roll,
                torque_constant_nm_per_a: 2.0,
                current_a: 1.5,
            },
            MotorCurrent {
                axis: JointAxis::Roll,
                torque_constant_nm_per_a: 1.0,
                current_a: -1.0,
            },
            MotorCurrent {
                axis: JointAxis::Yaw,
                torque_constant_nm_per_a: 3.0,
                current_a: 0.5,
            },
        ];
        let m = joint_moments(&c).unwrap();
        assert_eq!(m, Vec3::new(2.0, 0.0, 1.5));
        let mut bad = c;
        bad[1].current_a = f64::NAN;
        assert!(joint_moments(&bad)
            .unwrap_err()
            .to_string()
            .contains("motor 1"));
    }
}
