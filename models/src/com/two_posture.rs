//! The seed's closed form: one line per posture (eq. 3), the two-posture intersection (eq. 5)
//! and the whole robot's CoM with the feet from the CAD model (eq. 6).
//!
//! Eq. 4 of the extracted text lists its unknowns garbled; what it does is relate the CoM of the
//! two postures through the CAD geometry of the part that rotates. Here the calibration frame is
//! attached to the body (everything above the sensors), so for a rigid tilt the CoM is one fixed
//! point in that frame and the two lines meet there: eq. 5 is that intersection, and eq. 4 is
//! the statement `(X_2A, Z_2A) = (X_2B, Z_2B)` in the body frame. Postures that change the body's
//! shape are handled by [`super::regressor`] instead of by a fixed point.

use super::wrench::{ComError, PostureWrench, Wrench};
use super::{Vec3, G};

/// The seed's eq. 3 for one posture: the CoM lies on the line `X = alpha + beta Z`,
/// `Y = gamma + delta Z` (the line through the CoM along gravity, in the calibration frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PostureLines {
    /// (m)
    pub alpha: f64,
    /// (1) = F_x / F_z, the tangent of the tilt about y.
    pub beta: f64,
    /// (m)
    pub gamma: f64,
    /// (1) = F_y / F_z.
    pub delta: f64,
    /// The body's mass seen by the sensors, |F| / g (kg).
    pub mass_kg: f64,
}

impl PostureLines {
    /// From a total wrench on the body about the frame's origin.
    pub fn from_total(w: &Wrench) -> Result<PostureLines, ComError> {
        if !w.is_finite() {
            return Err(ComError::NonFinite {
                what: "the total wrench".into(),
            });
        }
        let fz = w.force.z;
        if fz <= 0.0 {
            return Err(ComError::NotPositive {
                what: "the total vertical force F_z0 + F_z1 (N)".into(),
                value: fz,
            });
        }
        Ok(PostureLines {
            alpha: -w.moment.y / fz,
            beta: w.force.x / fz,
            gamma: w.moment.x / fz,
            delta: w.force.y / fz,
            mass_kg: w.force.norm() / G,
        })
    }

    /// Eq. 3 from both feet's readings, after the input checks (finite, both feet loaded with at
    /// least `min_foot_load_n`).
    pub fn from_posture(p: &PostureWrench, min_foot_load_n: f64) -> Result<PostureLines, ComError> {
        p.check(min_foot_load_n)?;
        PostureLines::from_total(&p.total())
    }

    /// The point of the line at height `z`.
    pub fn at(&self, z: f64) -> Vec3 {
        Vec3::new(self.alpha + self.beta * z, self.gamma + self.delta * z, z)
    }
}

/// The seed's eq. 5: the CoM from two postures A and B (x and z from the two x-lines, y from A's
/// y-line). `min_slope_gap` is the least `|beta_A - beta_B|` accepted (1 degree of tilt
/// difference is 0.0175); closer postures cannot separate Z from the noise.
pub fn intersect(a: &PostureLines, b: &PostureLines, min_slope_gap: f64) -> Result<Vec3, ComError> {
    let gap = a.beta - b.beta;
    if !gap.is_finite() || gap.abs() < min_slope_gap {
        return Err(ComError::PosturesTooClose {
            a: 0,
            b: 1,
            gap: gap.abs(),
            min: min_slope_gap,
        });
    }
    let z = (b.alpha - a.alpha) / gap;
    let x = (a.beta * b.alpha - a.alpha * b.beta) / gap;
    let y = (a.gamma * gap + a.delta * (b.alpha - a.alpha)) / gap;
    Ok(Vec3::new(x, y, z))
}

/// A mass and its centre (kg, m) from the CAD model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CadCom {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Centre of mass in the calibration frame, m.
    pub com: Vec3,
}

/// The seed's eq. 6: the feet's mass centre from the CAD model with (`with_feet`, the seed's
/// `m_V, X_V..`) and without feet (`without_feet`, `m_C, X_C..`), and the whole robot's CoM
/// `(X_R, Y_R, Z_R)` from the measured body `(m_2, c_2)`. Returns the whole robot's mass and CoM.
pub fn total_com_with_feet(
    body_mass_kg: f64,
    body_com: &Vec3,
    with_feet: &CadCom,
    without_feet: &CadCom,
) -> Result<CadCom, ComError> {
    let feet_mass = with_feet.mass_kg - without_feet.mass_kg;
    if feet_mass <= 0.0 || !feet_mass.is_finite() {
        return Err(ComError::NotPositive {
            what: "the CAD feet mass m_V - m_C (kg)".into(),
            value: feet_mass,
        });
    }
    if body_mass_kg <= 0.0 || !body_mass_kg.is_finite() {
        return Err(ComError::NotPositive {
            what: "the body mass m_2 (kg)".into(),
            value: body_mass_kg,
        });
    }
    let feet_com =
        (with_feet.com * with_feet.mass_kg - without_feet.com * without_feet.mass_kg) / feet_mass;
    let total = body_mass_kg + feet_mass;
    Ok(CadCom {
        mass_kg: total,
        com: (body_com * body_mass_kg + feet_com * feet_mass) / total,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::com::wrench::SensorReading;
    use crate::com::{rot_x, rot_y, Mat3};

    /// Exact readings of a rigid body of mass `m` and CoM `c` (body frame) standing on two
    /// sensors at `pl`, `pr` (body frame, sensor axes along the body's), tilted so that gravity
    /// in the body frame is `rot^T (0,0,-g)`. The load split between the feet (statically
    /// indeterminate) is set by `share` and a free internal moment.
    pub(crate) fn synthetic(m: f64, c: Vec3, rot: Mat3, share: f64) -> PostureWrench {
        let pl = Vec3::new(0.01, 0.1, -0.6);
        let pr = Vec3::new(-0.02, -0.1, -0.6);
        let g_body = rot.transpose() * Vec3::new(0.0, 0.0, -G);
        let f_total = -m * g_body;
        let tau_total = c.cross(&f_total);
        // Left takes `share` of the force; its moment about its origin is chosen freely, the
        // right's moment closes the balance.
        let fl = f_total * share;
        let fr = f_total - fl;
        let ml = Vec3::new(0.3, -0.2, 0.05);
        let mr = tau_total - pl.cross(&fl) - pr.cross(&fr) - ml;
        PostureWrench::new(
            SensorReading {
                position: pl,
                rotation: Mat3::identity(),
                wrench: Wrench::new(fl, ml),
            },
            SensorReading {
                position: pr,
                rotation: Mat3::identity(),
                wrench: Wrench::new(fr, mr),
            },
        )
    }

    #[test]
    fn two_postures_return_the_com_of_a_rigid_body() {
        let c = Vec3::new(0.031, -0.012, 0.187);
        let a = synthetic(37.0, c, Mat3::identity(), 0.45);
        let b = synthetic(
            37.0,
            c,
            rot_y(1f64.to_radians()) * rot_x(0.3f64.to_radians()),
            0.55,
        );
        let la = PostureLines::from_posture(&a, 1.0).unwrap();
        let lb = PostureLines::from_posture(&b, 1.0).unwrap();
        let est = intersect(&la, &lb, 1e-3).unwrap();
        assert!((est - c).norm() < 1e-9, "{est} vs {c}");
        assert!((la.mass_kg - 37.0).abs() < 1e-9);
        // Both lines pass through the CoM.
        assert!((la.at(c.z) - c).norm() < 1e-9 && (lb.at(c.z) - c).norm() < 1e-9);
    }

    #[test]
    fn bad_inputs_are_named_errors() {
        let c = Vec3::new(0.0, 0.0, 0.2);
        let a = synthetic(37.0, c, Mat3::identity(), 0.5);
        let b = synthetic(37.0, c, rot_y(1e-5), 0.5);
        let la = PostureLines::from_posture(&a, 1.0).unwrap();
        let lb = PostureLines::from_posture(&b, 1.0).unwrap();
        let e = intersect(&la, &lb, 1e-3).unwrap_err();
        assert!(matches!(e, ComError::PosturesTooClose { .. }), "{e}");
        assert!(e.to_string().contains("too close to separate Z"));
        // A foot with no load.
        let lifted = synthetic(37.0, c, Mat3::identity(), 0.0);
        let e = PostureLines::from_posture(&lifted, 1.0).unwrap_err();
        assert!(e.to_string().contains("left foot carries"), "{e}");
        // A NaN wrench.
        let mut nan = a;
        nan.right.wrench.moment.y = f64::NAN;
        let e = PostureLines::from_posture(&nan, 1.0).unwrap_err();
        assert!(
            e.to_string()
                .contains("right foot's wrench is not a finite"),
            "{e}"
        );
    }

    #[test]
    fn eq6_adds_the_feet_from_the_cad_model() {
        // CAD: body 30 kg at (0,0,0.6), feet 2 kg at (0,0,0.03) -> with feet 32 kg.
        let without = CadCom {
            mass_kg: 30.0,
            com: Vec3::new(0.0, 0.0, 0.6),
        };
        let with = CadCom {
            mass_kg: 32.0,
            com: (Vec3::new(0.0, 0.0, 0.6) * 30.0 + Vec3::new(0.0, 0.0, 0.03) * 2.0) / 32.0,
        };
        let real = total_com_with_feet(33.0, &Vec3::new(0.01, 0.0, 0.62), &with, &without).unwrap();
        assert!((real.mass_kg - 35.0).abs() < 1e-12);
        let expect = (Vec3::new(0.01, 0.0, 0.62) * 33.0 + Vec3::new(0.0, 0.0, 0.03) * 2.0) / 35.0;
        assert!((real.com - expect).norm() < 1e-12);
    }

    #[test]
    fn the_seeds_extra_joint_moment_shifts_the_line() {
        // M_2 enters the moment sum: a 1 N m roll moment on a 37 kg body moves gamma by
        // 1/(37 g) = 2.76 mm. For a free body the joint moments are internal (see PostureWrench),
        // so feeding them in is an error of exactly this size.
        let c = Vec3::new(0.0, 0.0, 0.2);
        let mut a = synthetic(37.0, c, Mat3::identity(), 0.5);
        let l0 = PostureLines::from_posture(&a, 1.0).unwrap();
        a.extra_moment = Vec3::new(1.0, 0.0, 0.0);
        let l1 = PostureLines::from_posture(&a, 1.0).unwrap();
        assert!((l1.gamma - l0.gamma - 1.0 / (37.0 * G)).abs() < 1e-12);
    }
}
