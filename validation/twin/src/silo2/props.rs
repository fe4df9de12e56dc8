//! What the twin's mass properties predict for the seed's ZMP model, from the model file alone
//! (kinematics and inertias, no simulation of the dynamics).
//!
//! Three predictions of `ZMP = a x_cr - b x_cr''` per operating point, from the crudest to the
//! most complete:
//!
//! 1. **seed** (eqs. 6-15): the robot is a point mass at its CoM, which follows the reference:
//!    `a = 1`, `b = (z_c - ZMP_z)/g`, no coupling, and statically `ZMP = x_c` (eq. 10).
//! 2. **multibody**: the same Newton-Euler balance (eqs. 1-5) applied to the bodies that move.
//!    Only the trunk moves, so `a` is the CoM's actual displacement per unit of the eq. 26
//!    reference (`cos` of the tilt) and `b` is set by the trunk's rate of angular momentum
//!    about the floor: `b = (z_axis + I_axis/(m_t l_t))/g` upright, the height of the trunk's
//!    centre of percussion, not the whole robot's CoM.
//! 3. **servo**: (2) seen through the trunk servos. Gravity on the raised trunk softens the
//!    position servo (`kp - m g l_t cos(theta)`), so the trunk tilts more than commanded: `a` and
//!    `b` grow by `kp/(kp - m g l)` (a 2×2 matrix with the coupling), and the servo's closed loop
//!    is `omega_n = sqrt((kp - m g l)/M_ii)`, `zeta = kv/(2 sqrt(M_ii (kp - m g l)))`.
//!
//! The ZMP of (2) and (3) linearised about the static posture: with `L_O` the angular momentum
//! about the floor origin and `F_z = M (g + a_z)`,
//! `p_x F_z = M g x_c - dL_O,y/dt`, `p_y F_z = M g y_c + dL_O,x/dt`, so per unit trunk angular
//! acceleration `dp_x = -(dL_y + p_x M da_z)/(M g)`, `dp_y = (dL_x - p_y M da_z)/(M g)`.

use super::{Data, Silo2};
use crate::mj::TwinError;
use crate::zmp::GRAVITY;
use mujoco_rs::prelude::*;
use serde::Serialize;

/// The twin's mass properties that the seed's equations use.
#[derive(Debug, Clone, Serialize)]
pub struct MassProperties {
    /// Total mass `m_r`, kg.
    pub total_mass: f64,
    /// Mass moved by the trunk joints `m_t`, kg.
    pub trunk_mass: f64,
    /// `m_t/m_r`.
    pub trunk_mass_ratio: f64,
    /// Distance from the tilt axes to the trunk's CoM `l_t` (seed eq. 26), m.
    pub trunk_lever: f64,
    /// Height of the tilt axes above the floor, m.
    pub axis_height: f64,
    /// CoM of the whole robot standing upright, m.
    pub com_upright: [f64; 3],
    /// Diagonal joint-space inertia of the trunk joints `M_ii` (armature included), kg m².
    pub joint_inertia: [f64; 2],
    /// Trunk servo gains: stiffness, N m/rad, and damping, N m s/rad.
    pub kp: [f64; 2],
    /// Trunk servo damping, N m s/rad.
    pub kv: [f64; 2],
    /// `kp/M_ii`, `kv/M_ii`: the servo alone, (rad/s)², 1/s (the seed's 900 and 60).
    pub servo_omega_n2: [f64; 2],
    /// `kv/M_ii`: the servo's `2 zeta omega_n`, 1/s (the seed's 60).
    pub servo_2zeta_omega_n: [f64; 2],
    /// Support polygon of double support `[x_min, x_max, y_min, y_max]`, m.
    pub support: [f64; 4],
}

impl MassProperties {
    /// CoM displacement per radian of trunk reference, seed eq. 26: `(m_t/m_r) l_t`, m/rad.
    pub fn reference_gain(&self) -> f64 {
        self.trunk_mass_ratio * self.trunk_lever
    }
}

/// `a` and `b` of one prediction (rows: zmp_x, zmp_y; columns: x_cr, y_cr).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Pendulum {
    /// Static gains from CoM reference to ZMP, dimensionless.
    pub a: [[f64; 2]; 2],
    /// s².
    pub b: [[f64; 2]; 2],
}

/// The three predictions at one operating point.
#[derive(Debug, Clone, Serialize)]
pub struct OperatingPoint {
    /// The CoM reference of the campaign (eq. 26), m.
    pub com_ref: [f64; 2],
    /// Trunk references and the static angles the servos settle at, rad.
    pub theta_ref: [f64; 2],
    /// The static angles the servos settle at, rad.
    pub theta: [f64; 2],
    /// Whole-robot CoM at that posture, m.
    pub com: [f64; 3],
    /// The seed's point-mass prediction (eqs. 6-15).
    pub seed: Pendulum,
    /// The rigid multibody prediction.
    pub multibody: Pendulum,
    /// The multibody prediction through the servos.
    pub servo: Pendulum,
    /// Servo closed loop per trunk joint with gravity: rad/s and 1.
    pub omega_n: [f64; 2],
    /// Damping ratio of each trunk joint's servo loop.
    pub zeta: [f64; 2],
    /// `dZMP_i/dtheta_j` (static, m/rad) and `dZMP_i/dtheta_j''` (m s²/rad) of the rigid robot.
    pub zmp_per_angle: [[f64; 2]; 2],
    /// `dZMP_i/dtheta_j''` of the rigid robot, m s²/rad.
    pub zmp_per_angular_acceleration: [[f64; 2]; 2],
    /// Static trunk angle per unit reference, `(Kp - K_g)^-1 Kp`.
    pub servo_static_gain: [[f64; 2]; 2],
}

fn model_err(t: &Silo2, message: String) -> TwinError {
    TwinError::Model {
        path: t.path.clone(),
        message,
    }
}

/// Reads the mass properties (at the standing keyframe, trunk upright).
pub fn mass_properties(t: &Silo2) -> Result<MassProperties, TwinError> {
    let m = &t.model;
    let mut d = t.stand()?;
    d.forward();
    let total_mass = m.body_subtreemass()[t.root_body];
    let trunk_mass = m.body_subtreemass()[t.trunk_body];
    let anchor = d.xanchor()[t.trunk_joint[0]];
    let tc = d.subtree_com()[t.trunk_body];
    let lever =
        ((tc[0] - anchor[0]).powi(2) + (tc[1] - anchor[1]).powi(2) + (tc[2] - anchor[2]).powi(2))
            .sqrt();
    let nv = m.nv() as usize;
    let mut full = vec![0.0; nv * nv];
    d.full_m(&mut full)
        .map_err(|e| model_err(t, format!("mass matrix: {e}")))?;
    let mut joint_inertia = [0.0; 2];
    let mut kp = [0.0; 2];
    let mut kv = [0.0; 2];
    for k in 0..2 {
        let i = t.trunk_dof[k];
        joint_inertia[k] = full[i * nv + i];
        let a = t.trunk_actuator[k];
        // Position actuator: gain kp, bias [0, -kp, -kv].
        kp[k] = m.actuator_gainprm()[a][0];
        kv[k] = -m.actuator_biasprm()[a][2];
        if kp[k].is_nan()
            || kp[k] <= 0.0
            || (m.actuator_biasprm()[a][1] + kp[k]).abs() > 1e-9 * kp[k]
        {
            return Err(model_err(
                t,
                format!(
                    "actuator '{}' is not a position servo (gain kp > 0, bias -kp, -kv)",
                    super::TRUNK_JOINTS[k]
                ),
            ));
        }
    }
    let sites = d.site_xpos();
    let mut support = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for name in super::CELLS {
        let s = m
            .name_to_id(MjtObjBase::mjOBJ_SITE, name)
            .ok_or_else(|| model_err(t, format!("no site named '{name}'")))?;
        support[0] = support[0].min(sites[s][0]);
        support[1] = support[1].max(sites[s][0]);
        support[2] = support[2].min(sites[s][1]);
        support[3] = support[3].max(sites[s][1]);
    }
    Ok(MassProperties {
        total_mass,
        trunk_mass,
        trunk_mass_ratio: trunk_mass / total_mass,
        trunk_lever: lever,
        axis_height: anchor[2],
        com_upright: d.subtree_com()[t.root_body],
        joint_inertia,
        kp,
        kv,
        servo_omega_n2: [kp[0] / joint_inertia[0], kp[1] / joint_inertia[1]],
        servo_2zeta_omega_n: [kv[0] / joint_inertia[0], kv[1] / joint_inertia[1]],
        support,
    })
}

/// Puts the trunk at `theta` (everything else at the keyframe), at rest, and runs the
/// position-dependent computations.
fn pose(t: &Silo2, d: &mut Data<'_>, theta: [f64; 2]) {
    let key = t.model.key_qpos()[t.stand_key * t.model.nq() as usize..].to_vec();
    let nq = t.model.nq() as usize;
    d.qpos_mut().copy_from_slice(&key[..nq]);
    d.qpos_mut()[t.trunk_qpos[0]] = theta[0];
    d.qpos_mut()[t.trunk_qpos[1]] = theta[1];
    d.qvel_mut().fill(0.0);
    d.forward();
}

/// Generalised gravity force on the trunk joints at `theta` (`-qfrc_bias` at rest), N m.
fn gravity_torque(t: &Silo2, d: &mut Data<'_>, theta: [f64; 2]) -> [f64; 2] {
    pose(t, d, theta);
    let b = d.qfrc_bias();
    [-b[t.trunk_dof[0]], -b[t.trunk_dof[1]]]
}

fn solve2(m: [[f64; 2]; 2], r: [f64; 2]) -> [f64; 2] {
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    [
        (m[1][1] * r[0] - m[0][1] * r[1]) / det,
        (-m[1][0] * r[0] + m[0][0] * r[1]) / det,
    ]
}

fn mul2(a: [[f64; 2]; 2], b: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
    let mut c = [[0.0; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
        }
    }
    c
}

fn inv2(m: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    [
        [m[1][1] / det, -m[0][1] / det],
        [-m[1][0] / det, m[0][0] / det],
    ]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Central-difference step of the trunk angles, rad.
const DIFF_STEP: f64 = 1e-5;

/// The three predictions at the operating point whose CoM reference (eq. 26) is `com_ref`.
pub fn predict(
    t: &Silo2,
    props: &MassProperties,
    com_ref: [f64; 2],
) -> Result<OperatingPoint, TwinError> {
    let kr = props.reference_gain();
    let theta_ref = [
        (com_ref[0] - props.com_upright[0]) / kr,
        (com_ref[1] - props.com_upright[1]) / kr,
    ];
    let mut d = t.stand()?;
    let theta = static_posture(t, &mut d, props, theta_ref)?;
    let kg = gravity_stiffness(t, &mut d, theta);
    let j_static = zmp_per_angle(t, &mut d, theta);
    pose(t, &mut d, theta);
    let com = t.com(&d);
    let j_acc = zmp_per_angular_acceleration(t, &d, props.total_mass, com);

    // Servo: (Kp - Kg) dtheta = Kp dtheta_ref.
    let s0 = mul2(
        inv2([
            [props.kp[0] - kg[0][0], -kg[0][1]],
            [-kg[1][0], props.kp[1] - kg[1][1]],
        ]),
        [[props.kp[0], 0.0], [0.0, props.kp[1]]],
    );
    let scale = |m: [[f64; 2]; 2], s: f64| m.map(|row| row.map(|v| v * s));
    let multibody = Pendulum {
        a: scale(j_static, 1.0 / kr),
        b: scale(j_acc, -1.0 / kr),
    };
    let servo = Pendulum {
        a: scale(mul2(j_static, s0), 1.0 / kr),
        b: scale(mul2(j_acc, s0), -1.0 / kr),
    };
    let bz = com[2] / GRAVITY;
    let seed = Pendulum {
        a: [[1.0, 0.0], [0.0, 1.0]],
        b: [[bz, 0.0], [0.0, bz]],
    };
    let (omega_n, zeta) = servo_loop(t, &mut d, props, kg)?;
    Ok(OperatingPoint {
        com_ref,
        theta_ref,
        theta,
        com,
        seed,
        multibody,
        servo,
        omega_n,
        zeta,
        zmp_per_angle: j_static,
        zmp_per_angular_acceleration: j_acc,
        servo_static_gain: s0,
    })
}

/// `dG/dtheta` (N m/rad) of the gravity torques on the trunk joints at `th`, by central
/// differences.
fn gravity_stiffness(t: &Silo2, d: &mut Data<'_>, th: [f64; 2]) -> [[f64; 2]; 2] {
    let h = DIFF_STEP;
    let mut k = [[0.0; 2]; 2];
    for j in 0..2 {
        let mut p = th;
        let mut q = th;
        p[j] += h;
        q[j] -= h;
        let gp = gravity_torque(t, d, p);
        let gq = gravity_torque(t, d, q);
        for i in 0..2 {
            k[i][j] = (gp[i] - gq[i]) / (2.0 * h);
        }
    }
    k
}

/// The trunk angles (rad) the servos settle at for the reference `theta_ref`: the static
/// equilibrium `kp (theta_ref - theta) + G(theta) = 0`, by Newton.
fn static_posture(
    t: &Silo2,
    d: &mut Data<'_>,
    props: &MassProperties,
    theta_ref: [f64; 2],
) -> Result<[f64; 2], TwinError> {
    let mut theta = theta_ref;
    for _ in 0..20 {
        let g = gravity_torque(t, d, theta);
        let f = [
            props.kp[0] * (theta_ref[0] - theta[0]) + g[0],
            props.kp[1] * (theta_ref[1] - theta[1]) + g[1],
        ];
        let k = gravity_stiffness(t, d, theta);
        let jac = [
            [-props.kp[0] + k[0][0], k[0][1]],
            [k[1][0], -props.kp[1] + k[1][1]],
        ];
        let step = solve2(jac, f);
        theta = [theta[0] - step[0], theta[1] - step[1]];
        if step[0].abs().max(step[1].abs()) < 1e-13 {
            break;
        }
    }
    if !(theta[0].is_finite() && theta[1].is_finite()) {
        return Err(model_err(
            t,
            format!("no static posture for the trunk reference {theta_ref:?} rad"),
        ));
    }
    Ok(theta)
}

/// Static `dZMP_i/dtheta_j` (m/rad) at `theta`: statically the ZMP is the CoM's projection
/// (eq. 10), so it is `dCoM/dtheta`, by central differences.
fn zmp_per_angle(t: &Silo2, d: &mut Data<'_>, theta: [f64; 2]) -> [[f64; 2]; 2] {
    let h = DIFF_STEP;
    let mut j_static = [[0.0; 2]; 2];
    for j in 0..2 {
        let mut p = theta;
        let mut q = theta;
        p[j] += h;
        q[j] -= h;
        pose(t, d, p);
        let cp = t.com(d);
        pose(t, d, q);
        let cq = t.com(d);
        for i in 0..2 {
            j_static[i][j] = (cp[i] - cq[i]) / (2.0 * h);
        }
    }
    j_static
}

/// Dynamic `dZMP_i/dtheta_j''` (m s²/rad) of the rigid robot of `mass` (kg) posed in `d`
/// with its CoM at `com` (m): from the rate of angular momentum about the floor origin of the
/// bodies the trunk joints move.
fn zmp_per_angular_acceleration(
    t: &Silo2,
    d: &Data<'_>,
    mass: f64,
    com: [f64; 3],
) -> [[f64; 2]; 2] {
    let m = &t.model;
    let moved: Vec<usize> = (0..m.nbody() as usize)
        .filter(|&b| {
            let mut x = b;
            loop {
                if x == t.trunk_body {
                    return true;
                }
                if x == 0 {
                    return false;
                }
                x = m.body_parentid()[x] as usize;
            }
        })
        .collect();
    let mut j_acc = [[0.0; 2]; 2];
    for j in 0..2 {
        let axis = d.xaxis()[t.trunk_joint[j]];
        let anchor = d.xanchor()[t.trunk_joint[j]];
        let mut ldot = [0.0; 3];
        let mut fz = 0.0;
        for &b in &moved {
            let mb = m.body_mass()[b];
            let c = d.xipos()[b];
            let v = cross(axis, [c[0] - anchor[0], c[1] - anchor[1], c[2] - anchor[2]]);
            let lin = cross(c, v);
            // World inertia R diag(I) R^T applied to the axis.
            let r = d.ximat()[b];
            let inert = m.body_inertia()[b];
            let local = [
                r[0] * axis[0] + r[3] * axis[1] + r[6] * axis[2],
                r[1] * axis[0] + r[4] * axis[1] + r[7] * axis[2],
                r[2] * axis[0] + r[5] * axis[1] + r[8] * axis[2],
            ];
            let scaled = [
                inert[0] * local[0],
                inert[1] * local[1],
                inert[2] * local[2],
            ];
            let rot = [
                r[0] * scaled[0] + r[1] * scaled[1] + r[2] * scaled[2],
                r[3] * scaled[0] + r[4] * scaled[1] + r[5] * scaled[2],
                r[6] * scaled[0] + r[7] * scaled[1] + r[8] * scaled[2],
            ];
            for i in 0..3 {
                ldot[i] += mb * lin[i] + rot[i];
            }
            fz += mb * v[2];
        }
        j_acc[0][j] = -(ldot[1] + com[0] * fz) / (mass * GRAVITY);
        j_acc[1][j] = (ldot[0] - com[1] * fz) / (mass * GRAVITY);
    }
    j_acc
}

/// Natural frequency (rad/s) and damping ratio of each trunk joint's servo loop with gravity
/// (stiffness `kp - dG/dtheta` from `kg`) on the joint's inertia from the mass matrix of `d`.
fn servo_loop(
    t: &Silo2,
    d: &mut Data<'_>,
    props: &MassProperties,
    kg: [[f64; 2]; 2],
) -> Result<([f64; 2], [f64; 2]), TwinError> {
    let m = &t.model;
    let nv = m.nv() as usize;
    let mut full = vec![0.0; nv * nv];
    d.full_m(&mut full)
        .map_err(|e| model_err(t, format!("mass matrix: {e}")))?;
    let mut omega_n = [0.0; 2];
    let mut zeta = [0.0; 2];
    for k in 0..2 {
        let i = t.trunk_dof[k];
        let inertia = full[i * nv + i];
        let stiff = props.kp[k] - kg[k][k];
        omega_n[k] = (stiff / inertia).sqrt();
        zeta[k] = props.kv[k] / (2.0 * (inertia * stiff).sqrt());
    }
    Ok((omega_n, zeta))
}
