//! The calibration's static postures: tilts about the ankles, bent knees, one foot lifted; their
//! joint targets by IK on the CAD model, the kinematic quantities the calibration computes from
//! the encoders, and the support-polygon check.

use super::calibrate::{ANKLE_HEIGHT, FOOT_SPACING, PELVIS_HEIGHT, SOLE_CENTRE_X};
use super::ik::{solve, IkTarget};
use super::robot::Sabian;
use crate::mj::TwinError;
use zmp_models::com::{self, rot_x, rot_y, Vec3};

/// Half length and half width of a sole (m).
pub const SOLE_HALF: (f64, f64) = (0.11, 0.06);

/// A static posture: the body tilted about the ankles' midpoint, the knees bent by lowering the
/// pelvis, optionally one foot lifted (the CoM then over the other foot).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PostureSpec {
    /// Tilt about y (deg), positive leans forward.
    pub pitch_deg: f64,
    /// Tilt about x (deg), positive leans right.
    pub roll_deg: f64,
    /// Pelvis lowered from the home posture (m).
    pub drop_m: f64,
    /// 0 lifts the left foot, 1 the right one.
    pub lifted: Option<usize>,
}

impl PostureSpec {
    /// Standing upright on both feet, pelvis at home height.
    pub fn upright() -> PostureSpec {
        PostureSpec {
            pitch_deg: 0.0,
            roll_deg: 0.0,
            drop_m: 0.0,
            lifted: None,
        }
    }

    /// A short label: the tilts (deg), the knee drop (mm) and which foot is up.
    pub fn label(&self) -> String {
        let mut s = format!("pitch {:+.1} roll {:+.1}", self.pitch_deg, self.roll_deg);
        if self.drop_m > 0.0 {
            s += &format!(" knees -{:.0} mm", self.drop_m * 1e3);
        }
        if let Some(l) = self.lifted {
            s += if l == 0 { " left up" } else { " right up" };
        }
        s
    }

    /// The joint targets of this posture, solved on `robot` (the CAD model: the controller does
    /// not know the error mass).
    pub fn pose(&self, robot: &mut Sabian, home_pelvis_x: f64) -> Result<(), TwinError> {
        let y = FOOT_SPACING / 2.0;
        let mut feet = [Vec3::new(0.0, y, 0.0), Vec3::new(0.0, -y, 0.0)];
        // The ankles' axes (x = 0): a pure pitch tilt keeps the legs' shape (the seed's rigid tilt).
        let pivot = Vec3::new(0.0, 0.0, ANKLE_HEIGHT);
        let rot = rot_y(self.pitch_deg.to_radians()) * rot_x(-self.roll_deg.to_radians());
        let home = Vec3::new(home_pelvis_x, 0.0, PELVIS_HEIGHT - self.drop_m);
        let pelvis = pivot + rot * (home - pivot);
        let com_xy = self.lifted.map(|l| {
            feet[l].z = 0.03;
            let stance = 1 - l;
            [SOLE_CENTRE_X, feet[stance].y]
        });
        solve(
            robot,
            &IkTarget {
                feet,
                pelvis_position: pelvis,
                pelvis_rotation: rot,
                com_xy,
                waist: [0.0, 0.0],
            },
        )?;
        Ok(())
    }
}

/// The home pelvis x that puts the CAD model's CoM over the soles' centres.
pub fn home_pelvis_x(cad: &mut Sabian) -> Result<f64, TwinError> {
    let y = FOOT_SPACING / 2.0;
    solve(
        cad,
        &IkTarget {
            feet: [Vec3::new(0.0, y, 0.0), Vec3::new(0.0, -y, 0.0)],
            pelvis_position: Vec3::new(0.0, 0.0, PELVIS_HEIGHT),
            pelvis_rotation: com::Mat3::identity(),
            com_xy: Some([SOLE_CENTRE_X, 0.0]),
            waist: [0.0, 0.0],
        },
    )?;
    Ok(cad.data.qpos()[0])
}

/// The candidate postures of the design (+/- 5 degrees of tilt, two knee bends, single support).
pub fn candidates() -> Vec<PostureSpec> {
    let mut v = vec![PostureSpec::upright()];
    for drop in [0.0, 0.06] {
        for pitch in [-5.0, -2.5, 0.0, 2.5, 5.0] {
            for roll in [-5.0, 0.0, 5.0] {
                let p = PostureSpec {
                    pitch_deg: pitch,
                    roll_deg: roll,
                    drop_m: drop,
                    lifted: None,
                };
                if p != PostureSpec::upright() {
                    v.push(p);
                }
            }
        }
    }
    for lifted in [0, 1] {
        for pitch in [-3.0, 0.0, 3.0] {
            v.push(PostureSpec {
                pitch_deg: pitch,
                roll_deg: 0.0,
                drop_m: 0.0,
                lifted: Some(lifted),
            });
        }
    }
    v
}

/// The seed's design: upright, and the body tilted 1 degree forward about the ankles.
pub fn seed_design() -> [PostureSpec; 2] {
    [
        PostureSpec::upright(),
        PostureSpec {
            pitch_deg: 1.0,
            ..PostureSpec::upright()
        },
    ]
}

/// The kinematic quantities the calibration computes from the encoders (CAD model), and the
/// support polygon check.
#[derive(Debug, Clone, Copy)]
pub struct Kinematics {
    /// Each ankle sensor's origin (m) and axes in the calibration frame, left then right.
    pub sensors: [(Vec3, com::Mat3); 2],
    /// The CAD model's mass of the body above the sensors (kg).
    pub cad_mass: f64,
    /// The CAD model's first moment of that body (kg m).
    pub cad_first_moment: Vec3,
    /// The trunk's origin (m) and axes.
    pub trunk: (Vec3, com::Mat3),
    /// The pelvis's origin (m) and axes.
    pub pelvis: (Vec3, com::Mat3),
    /// The CAD whole robot's CoM (m).
    pub cad_com: Vec3,
}

impl Kinematics {
    /// The kinematics of the twin's current posture.
    pub fn of(robot: &mut Sabian) -> Kinematics {
        robot.kinematics();
        let (cad_mass, cad_first_moment) = robot.body_first_moment();
        let p = robot.idx.pelvis;
        Kinematics {
            sensors: [robot.sensor_pose(0), robot.sensor_pose(1)],
            cad_mass,
            cad_first_moment,
            trunk: robot.trunk_pose(),
            pelvis: (
                super::robot::vec3(&robot.data.xpos()[p]),
                super::robot::mat3(&robot.data.xmat()[p]),
            ),
            cad_com: robot.com(),
        }
    }

    /// The same body seen rotated by `err` about `pivot` (the encoders' tilt error); the sensors
    /// of standing feet stay on the floor.
    pub fn tilted(&self, err: &com::Mat3, pivot: &Vec3, lifted: Option<usize>) -> Kinematics {
        let mv = |p: &Vec3| pivot + err * (p - pivot);
        let mut k = *self;
        k.cad_first_moment =
            pivot * self.cad_mass + err * (self.cad_first_moment - pivot * self.cad_mass);
        k.trunk = (mv(&self.trunk.0), err * self.trunk.1);
        k.pelvis = (mv(&self.pelvis.0), err * self.pelvis.1);
        k.cad_com = mv(&self.cad_com);
        if let Some(l) = lifted {
            k.sensors[l] = (mv(&self.sensors[l].0), err * self.sensors[l].1);
        }
        k
    }

    /// Whether the CAD CoM's ground projection is inside the support polygon with `margin` (m).
    pub fn supported(&self, lifted: Option<usize>, margin: f64) -> bool {
        let c = self.cad_com;
        let half = (SOLE_HALF.0 - margin, SOLE_HALF.1 - margin);
        let in_foot = |s: usize| {
            let o = self.sensors[s].0;
            (c.x - o.x - SOLE_CENTRE_X).abs() <= half.0 && (c.y - o.y).abs() <= half.1
        };
        match lifted {
            Some(l) => in_foot(1 - l),
            None => {
                let xs = self.sensors[0].0.x + SOLE_CENTRE_X;
                (c.x - xs).abs() <= half.0 && c.y.abs() <= FOOT_SPACING / 2.0 + half.1
            }
        }
    }
}
