//! The SABIAN twin's model: loading (with an error mass inserted in the trunk), the index tables
//! of its joints, servos and sensors, and the readings in the CoM calculation's convention.

use crate::mj::{load_mjcf_str, TwinError};
use mujoco_rs::prelude::*;
use std::path::{Path, PathBuf};
use zmp_models::com::{JointAxis, Mat3, Vec3, Wrench};

/// The leg joints in chain order; index [`SHANK_YAW`] is SABIAN's seventh (redundant) leg joint,
/// held at zero.
pub const LEG_JOINTS: [&str; 7] = [
    "hip_yaw",
    "hip_roll",
    "hip_pitch",
    "knee",
    "shank_yaw",
    "ankle_pitch",
    "ankle_roll",
];
/// Index of the shank yaw joint in [`LEG_JOINTS`].
pub const SHANK_YAW: usize = 4;
/// The servoed joints (legs 7 x 2, waist 2).
pub const MOTORS: usize = 16;
/// Feet, in the order the CoM code uses (left, right).
pub const SIDES: [&str; 2] = ["l", "r"];
/// The error mass's marker in the MJCF's trunk body.
const ERROR_MASS_MARKER: &str = "<!-- error mass -->";

/// The CAD model file (repository path).
pub fn cad_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/mjcf/sabian.xml")
}

/// A point mass fixed to the trunk (kg; m in the trunk frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointMass {
    pub mass_kg: f64,
    pub position: Vec3,
}

/// What varies between the twins built from the CAD file: the extra masses on the trunk and the
/// floor's friction.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Variant {
    pub trunk_masses: Vec<PointMass>,
    /// Multiplies the soles' and floor's sliding friction (1 if `None`).
    pub friction_scale: Option<f64>,
    /// Multiplies the servos' kp (1 if `None`).
    pub servo_gain_scale: Option<f64>,
}

/// The MJCF text of a variant.
pub fn variant_xml(cad: &str, v: &Variant) -> Result<String, TwinError> {
    if !cad.contains(ERROR_MASS_MARKER) {
        return Err(TwinError::Model {
            path: cad_path().display().to_string(),
            message: format!("the trunk body has no '{ERROR_MASS_MARKER}' marker"),
        });
    }
    let mut bodies = String::new();
    for (k, m) in v.trunk_masses.iter().enumerate() {
        // A small solid sphere (radius 2 cm) so the inertia is positive.
        let i = 0.4 * m.mass_kg * 0.02f64.powi(2);
        bodies.push_str(&format!(
            "<body name=\"extra_mass_{k}\" pos=\"{} {} {}\"><inertial pos=\"0 0 0\" mass=\"{}\" \
             diaginertia=\"{i} {i} {i}\"/></body>",
            m.position.x, m.position.y, m.position.z, m.mass_kg
        ));
    }
    let mut xml = cad.replace(ERROR_MASS_MARKER, &bodies);
    if let Some(f) = v.friction_scale {
        xml = xml.replace(
            "friction=\"1.0 0.005 0.0001\"",
            &format!("friction=\"{} 0.005 0.0001\"", f),
        );
    }
    if let Some(s) = v.servo_gain_scale {
        xml = xml.replace("kp=\"20000\"", &format!("kp=\"{}\"", 20000.0 * s));
    }
    Ok(xml)
}

/// Index tables of the model.
#[derive(Debug, Clone)]
pub struct Indices {
    /// qpos address of each leg joint, [side][joint].
    pub leg_qpos: [[usize; 7]; 2],
    /// dof address of each leg joint.
    pub leg_dof: [[usize; 7]; 2],
    pub waist_qpos: [usize; 2],
    /// (actuator, qpos address of its joint).
    pub servo: Vec<(usize, usize)>,
    /// The axis of each actuator's joint, for the seed's eq. 7 sums (roll, pitch or yaw, from
    /// the joint's name: the knee is a pitch joint).
    pub servo_axis: Vec<JointAxis>,
    pub pelvis: usize,
    pub trunk: usize,
    pub soles: [usize; 2],
    pub ft_site: [usize; 2],
    pub sole_bottom_site: [usize; 2],
    /// sensordata address of each foot's force and torque.
    pub ft_force: [usize; 2],
    pub ft_torque: [usize; 2],
}

fn id(model: &MjModel, kind: MjtObjBase, name: &str) -> Result<usize, TwinError> {
    model
        .name_to_id(kind, name)
        .ok_or_else(|| TwinError::Model {
            path: "sabian.xml".into(),
            message: format!("no {kind:?} named '{name}'"),
        })
}

impl Indices {
    pub fn new(model: &MjModel) -> Result<Indices, TwinError> {
        let jq = |n: &str| -> Result<(usize, usize), TwinError> {
            let j = id(model, MjtObjBase::mjOBJ_JOINT, n)?;
            Ok((
                model.jnt_qposadr()[j] as usize,
                model.jnt_dofadr()[j] as usize,
            ))
        };
        let mut leg_qpos = [[0; 7]; 2];
        let mut leg_dof = [[0; 7]; 2];
        for (s, side) in SIDES.iter().enumerate() {
            for (k, j) in LEG_JOINTS.iter().enumerate() {
                let (q, d) = jq(&format!("{side}_{j}"))?;
                leg_qpos[s][k] = q;
                leg_dof[s][k] = d;
            }
        }
        let waist_qpos = [jq("waist_yaw")?.0, jq("waist_roll")?.0];
        let mut servo = Vec::new();
        let mut servo_axis = Vec::new();
        for a in 0..model.ffi().nu as usize {
            let j = model.actuator_trnid()[a][0] as usize;
            servo.push((a, model.jnt_qposadr()[j] as usize));
            let name = model.id_to_name(MjtObjBase::mjOBJ_JOINT, j).unwrap_or("");
            servo_axis.push(if name.ends_with("roll") {
                JointAxis::Roll
            } else if name.ends_with("yaw") {
                JointAxis::Yaw
            } else {
                JointAxis::Pitch
            });
        }
        if servo.len() != MOTORS {
            return Err(TwinError::Model {
                path: "sabian.xml".into(),
                message: format!("{} servos, the twin has {MOTORS}", servo.len()),
            });
        }
        let sensor = |n: &str| -> Result<usize, TwinError> {
            let s = id(model, MjtObjBase::mjOBJ_SENSOR, n)?;
            Ok(model.sensor_adr()[s] as usize)
        };
        Ok(Indices {
            leg_qpos,
            leg_dof,
            waist_qpos,
            servo,
            servo_axis,
            pelvis: id(model, MjtObjBase::mjOBJ_BODY, "pelvis")?,
            trunk: id(model, MjtObjBase::mjOBJ_BODY, "trunk")?,
            soles: [
                id(model, MjtObjBase::mjOBJ_BODY, "l_sole")?,
                id(model, MjtObjBase::mjOBJ_BODY, "r_sole")?,
            ],
            ft_site: [
                id(model, MjtObjBase::mjOBJ_SITE, "l_ft")?,
                id(model, MjtObjBase::mjOBJ_SITE, "r_ft")?,
            ],
            sole_bottom_site: [
                id(model, MjtObjBase::mjOBJ_SITE, "l_sole_bottom")?,
                id(model, MjtObjBase::mjOBJ_SITE, "r_sole_bottom")?,
            ],
            ft_force: [sensor("l_ft_force")?, sensor("r_ft_force")?],
            ft_torque: [sensor("l_ft_torque")?, sensor("r_ft_torque")?],
        })
    }
}

/// A loaded twin: model, data and indices.
pub struct Sabian {
    pub data: MjData<Box<MjModel>>,
    pub idx: Indices,
    pub name: String,
}

pub fn mat3(m: &[f64; 9]) -> Mat3 {
    Mat3::from_row_slice(m)
}

pub fn vec3(v: &[f64; 3]) -> Vec3 {
    Vec3::new(v[0], v[1], v[2])
}

impl Sabian {
    /// Loads the CAD file with a variant's changes.
    pub fn load(v: &Variant, name: &str) -> Result<Sabian, TwinError> {
        let path = cad_path();
        let cad = std::fs::read_to_string(&path).map_err(|source| TwinError::Read {
            path: path.clone(),
            source,
        })?;
        let xml = variant_xml(&cad, v)?;
        let model = load_mjcf_str(&xml, &format!("{} ({name})", path.display()))?;
        let idx = Indices::new(&model)?;
        let data = MjData::new(Box::new(model));
        Ok(Sabian {
            data,
            idx,
            name: name.to_string(),
        })
    }

    pub fn model(&self) -> &MjModel {
        self.data.model()
    }

    /// Positions, frames and centres of mass for the current qpos (no dynamics).
    pub fn kinematics(&mut self) {
        self.data.kinematics();
        self.data.com_pos();
    }

    /// Total mass (kg).
    pub fn mass(&self) -> f64 {
        self.model().body_subtreemass()[self.idx.pelvis]
    }

    /// The whole robot's CoM (m) after [`Sabian::kinematics`] or a step.
    pub fn com(&self) -> Vec3 {
        vec3(&self.data.subtree_com()[self.idx.pelvis])
    }

    /// Mass (kg) and first moment (kg m) of the body above the sensors (all but the soles).
    pub fn body_first_moment(&self) -> (f64, Vec3) {
        let m = self.model();
        let mut mass = 0.0;
        let mut first = Vec3::zeros();
        for b in 1..m.ffi().nbody as usize {
            if self.idx.soles.contains(&b) {
                continue;
            }
            let mb = m.body_mass()[b];
            mass += mb;
            first += vec3(&self.data.xipos()[b]) * mb;
        }
        (mass, first)
    }

    /// Mass (kg) and CoM of each sole in its sensor's frame (the CAD's, fixed).
    pub fn sole_cad(&self, side: usize) -> (f64, Vec3) {
        let b = self.idx.soles[side];
        (
            self.model().body_mass()[b],
            vec3(&self.model().body_ipos()[b]),
        )
    }

    /// A sensor's pose (origin, rotation sensor -> world).
    pub fn sensor_pose(&self, side: usize) -> (Vec3, Mat3) {
        let s = self.idx.ft_site[side];
        (
            vec3(&self.data.site_xpos()[s]),
            mat3(&self.data.site_xmat()[s]),
        )
    }

    /// The trunk's pose (origin, rotation trunk -> world).
    pub fn trunk_pose(&self) -> (Vec3, Mat3) {
        let b = self.idx.trunk;
        (vec3(&self.data.xpos()[b]), mat3(&self.data.xmat()[b]))
    }

    /// The true reading of a sensor in the CoM code's convention: the wrench the sole exerts on
    /// the body, in the sensor frame, about the sensor's origin. (MuJoCo's force and torque
    /// sensors give the parent's action on the child, the sole: the opposite sign.)
    pub fn ft_reading(&self, side: usize) -> Wrench {
        let d = self.data.sensordata();
        let f = self.idx.ft_force[side];
        let t = self.idx.ft_torque[side];
        Wrench::new(
            -Vec3::new(d[f], d[f + 1], d[f + 2]),
            -Vec3::new(d[t], d[t + 1], d[t + 2]),
        )
    }

    /// Each servo's torque on its joint (N m): what its motor current gives through eq. 7.
    pub fn motor_torques(&self) -> [f64; MOTORS] {
        let f = self.data.actuator_force();
        std::array::from_fn(|k| f[self.idx.servo[k].0])
    }

    /// Sets every servo's target to the joint's current position.
    pub fn hold_current_posture(&mut self) {
        let targets: Vec<(usize, f64)> = self
            .idx
            .servo
            .iter()
            .map(|&(a, q)| (a, self.data.qpos()[q]))
            .collect();
        let ctrl = self.data.ctrl_mut();
        for (a, v) in targets {
            ctrl[a] = v;
        }
    }
}
