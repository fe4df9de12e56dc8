//! The SILO2 twin (`models/mjcf/silo2.xml`): a 14-DOF biped after the first seed, in double
//! support, whose trunk (2 DOF) moves the centre of mass. The model file is the robot; this
//! module finds its parts by name, checks them, and drives it.
//!
//! - [`props`]: what the twin's mass properties predict for the seed's model (eqs. 6-15,
//!   and the same equations applied to the bodies that actually move);
//! - [`campaign`]: the stepped-sine campaign of seed section 6.1 on the twin (`zmp-campaign/1`);
//! - [`crosscheck`]: the corner-sensor ZMP against MuJoCo's contact centre of pressure and the
//!   momentum / cart-table ZMP, and the contact-softness error budget;
//! - [`closed_loop`]: the seed's section 6.6 experiment with the cascade controller;
//! - [`stance`]: the stance resonance swept on the model file, against the structural mode the
//!   diagnosis names;
//! - [`validate`]: all of it, the identification and the diagnosis, into one report
//!   ([`summary`]: what it found, [`report`]: the HTML page and the closed-loop figure).

pub mod campaign;
pub mod closed_loop;
pub mod crosscheck;
pub mod props;
pub mod readme;
pub mod report;
pub mod stance;
pub mod summary;
pub mod validate;

use crate::mj::{load_mjcf, TwinError};
use crate::zmp::{CellReading, LoadCells};
use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_model::traits::ModelType;
use std::path::{Path, PathBuf};

/// The twin's model file, relative to the repository root.
pub const MJCF_RELATIVE: &str = "models/mjcf/silo2.xml";

/// The model file in this checkout.
pub fn default_mjcf() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(MJCF_RELATIVE)
}

/// The physics step the twin is built for, s.
pub const STEP: f64 = 0.001;

/// The 8 sole-corner load cells (touch sensors), right foot then left.
pub const CELLS: [&str; 8] = [
    "cell_r_fr",
    "cell_r_fl",
    "cell_r_br",
    "cell_r_bl",
    "cell_l_fr",
    "cell_l_fl",
    "cell_l_br",
    "cell_l_bl",
];

/// Trunk joints and their position servos: `[lateral, sagittal]`. The lateral tilt moves the
/// CoM along x, the sagittal tilt along +y (seed eq. 26).
pub const TRUNK_JOINTS: [&str; 2] = ["trunk_lateral", "trunk_sagittal"];

/// Number of actuated joints (the seed's 14 DOF).
pub const DOF: usize = 14;

/// Ids of the parts of the SILO2 model the code uses.
#[derive(Debug)]
pub struct Silo2 {
    pub model: MjModel,
    /// Where the model came from (for messages).
    pub path: String,
    pub cells: LoadCells,
    pub floor_geom: usize,
    /// The free-floating root body (pelvis): its subtree is the whole robot.
    pub root_body: usize,
    pub trunk_body: usize,
    /// The body that receives the 4 kg load.
    pub load_body: usize,
    pub trunk_joint: [usize; 2],
    pub trunk_qpos: [usize; 2],
    pub trunk_dof: [usize; 2],
    pub trunk_actuator: [usize; 2],
    /// The standing keyframe (soles on the floor, zero penetration).
    pub stand_key: usize,
}

/// The data type the twin is stepped with.
pub type Data<'a> = MjData<&'a MjModel>;

impl Silo2 {
    /// Loads and checks the model file.
    pub fn load(path: &Path) -> Result<Silo2, TwinError> {
        let model = load_mjcf(path)?;
        Silo2::from_model(model, &path.display().to_string())
    }

    /// Checks a compiled model and finds its parts.
    pub fn from_model(model: MjModel, path: &str) -> Result<Silo2, TwinError> {
        let err = |message: String| TwinError::Model {
            path: path.into(),
            message,
        };
        let id = |kind: MjtObjBase, what: &str, name: &str| {
            model
                .name_to_id(kind, name)
                .ok_or_else(|| err(format!("no {what} named '{name}'")))
        };
        let floor_geom = id(MjtObjBase::mjOBJ_GEOM, "geom", "floor")?;
        let root_body = id(MjtObjBase::mjOBJ_BODY, "body", "pelvis")?;
        let trunk_body = id(MjtObjBase::mjOBJ_BODY, "body", "trunk")?;
        let load_body = id(MjtObjBase::mjOBJ_BODY, "body", "load")?;
        let stand_key = id(MjtObjBase::mjOBJ_KEY, "keyframe", "stand")?;
        if model.body_parentid()[root_body] != 0 || model.body_jntnum()[root_body] != 1 {
            return Err(err(
                "body 'pelvis' must be a child of the world with one (free) joint".into(),
            ));
        }
        let mut trunk_joint = [0; 2];
        let mut trunk_qpos = [0; 2];
        let mut trunk_dof = [0; 2];
        let mut trunk_actuator = [0; 2];
        for (k, name) in TRUNK_JOINTS.iter().enumerate() {
            let j = id(MjtObjBase::mjOBJ_JOINT, "joint", name)?;
            if model.jnt_type()[j] != MjtJoint::mjJNT_HINGE {
                return Err(err(format!("joint '{name}' must be a hinge")));
            }
            if usize::try_from(model.jnt_bodyid()[j]).ok() != Some(trunk_body) {
                return Err(err(format!("joint '{name}' must belong to body 'trunk'")));
            }
            trunk_joint[k] = j;
            trunk_qpos[k] = model.jnt_qposadr()[j] as usize;
            trunk_dof[k] = model.jnt_dofadr()[j] as usize;
            let a = id(MjtObjBase::mjOBJ_ACTUATOR, "actuator", name)?;
            if model.actuator_trnid()[a][0] != j as i32 {
                return Err(err(format!("actuator '{name}' must drive joint '{name}'")));
            }
            trunk_actuator[k] = a;
        }
        if model.nu() as usize != DOF {
            return Err(err(format!(
                "{} actuators; the SILO2 twin has {DOF} (one position servo per joint)",
                model.nu()
            )));
        }
        let ts = model.opt().timestep;
        if (ts - STEP).abs() > 1e-12 {
            return Err(err(format!(
                "timestep is {ts} s; the twin is built for {STEP} s"
            )));
        }
        let cells = LoadCells::find(&model, &CELLS, path)?;
        Ok(Silo2 {
            model,
            path: path.into(),
            cells,
            floor_geom,
            root_body,
            trunk_body,
            load_body,
            trunk_joint,
            trunk_qpos,
            trunk_dof,
            trunk_actuator,
            stand_key,
        })
    }

    /// Data at the standing keyframe, all servos holding zero (upright, legs straight).
    pub fn stand(&self) -> Result<Data<'_>, TwinError> {
        let mut d = self.model.try_make_data().map_err(|e| TwinError::Model {
            path: self.path.clone(),
            message: format!("cannot allocate the simulation data: {e}"),
        })?;
        d.reset_keyframe(self.stand_key)
            .map_err(|e| TwinError::Model {
                path: self.path.clone(),
                message: format!("keyframe 'stand': {e}"),
            })?;
        d.ctrl_mut().fill(0.0);
        d.forward();
        Ok(d)
    }

    /// Sets the trunk servos' references `[lateral, sagittal]`, rad.
    #[inline]
    pub fn set_trunk<M: ModelType>(&self, d: &mut MjData<M>, theta: [f64; 2]) {
        let c = d.ctrl_mut();
        c[self.trunk_actuator[0]] = theta[0];
        c[self.trunk_actuator[1]] = theta[1];
    }

    /// Measured trunk angles, rad.
    #[inline]
    pub fn trunk_angles<M: ModelType>(&self, d: &MjData<M>) -> [f64; 2] {
        let q = d.qpos();
        [q[self.trunk_qpos[0]], q[self.trunk_qpos[1]]]
    }

    /// The 8 load cells now.
    #[inline]
    pub fn cells<M: ModelType>(&self, d: &MjData<M>) -> CellReading<8> {
        self.cells.read::<8, M>(d)
    }

    /// The whole robot's CoM, m.
    #[inline]
    pub fn com<M: ModelType>(&self, d: &MjData<M>) -> [f64; 3] {
        d.subtree_com()[self.root_body]
    }

    /// Moves the trunk references from upright to `theta` along a half cosine over `ramp_s`,
    /// then holds them for `hold_s`; the robot ends at rest at that posture.
    pub fn settle<M: ModelType>(
        &self,
        d: &mut MjData<M>,
        theta: [f64; 2],
        ramp_s: f64,
        hold_s: f64,
    ) {
        let n_ramp = (ramp_s / STEP).round() as usize;
        let n_hold = (hold_s / STEP).round() as usize;
        for k in 0..n_ramp {
            let s = 0.5 - 0.5 * (std::f64::consts::PI * (k as f64 + 1.0) / n_ramp as f64).cos();
            self.set_trunk(d, [theta[0] * s, theta[1] * s]);
            d.step();
        }
        self.set_trunk(d, theta);
        for _ in 0..n_hold {
            d.step();
        }
    }

    /// Deepest penetration of any floor contact now, m (>= 0).
    pub fn penetration<M: ModelType>(&self, d: &MjData<M>) -> f64 {
        let ncon = usize::try_from(d.ncon()).unwrap_or(0);
        d.contact()
            .iter()
            .take(ncon)
            .map(|c| (-c.dist).max(0.0))
            .fold(0.0, f64::max)
    }

    /// A copy of the model with the contact softness `solref = [time constant, damping ratio]`
    /// on every geom (floor and feet).
    pub fn with_solref(&self, timeconst: f64, dampratio: f64) -> Result<Silo2, TwinError> {
        let mut m = self.model.clone();
        for s in m.geom_solref_mut() {
            *s = [timeconst, dampratio];
        }
        Silo2::from_model(m, &self.path)
    }
}

#[cfg(test)]
mod tests;
