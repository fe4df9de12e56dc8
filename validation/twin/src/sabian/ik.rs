//! Whole-body inverse kinematics of the twin by damped least squares on MuJoCo's Jacobians: both
//! soles at their targets and level, the pelvis at a given pose, or (for walking) the pelvis
//! sliding horizontally so that the whole robot's CoM is over a given point.

use super::robot::{mat3, vec3, Sabian, SHANK_YAW};
use crate::mj::TwinError;
use nalgebra::{DMatrix, DVector, Rotation3, UnitQuaternion};
use zmp_models::com::{Mat3, Vec3};

/// What the posture must satisfy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkTarget {
    /// Each sole's bottom centre (left, right) (m); soles level, facing +x.
    pub feet: [Vec3; 2],
    /// Pelvis origin (m); with `com_xy` only its height is kept.
    pub pelvis_position: Vec3,
    /// Pelvis orientation (pelvis -> world).
    pub pelvis_rotation: Mat3,
    /// If set, the whole robot's CoM x, y (m), reached by moving the pelvis horizontally.
    pub com_xy: Option<[f64; 2]>,
    /// Waist yaw and roll (rad).
    pub waist: [f64; 2],
}

/// Solves for the joint angles in place (warm-started from the current ones). Returns the
/// number of iterations, or an error if the targets are out of reach.
pub fn solve(robot: &mut Sabian, t: &IkTarget) -> Result<usize, TwinError> {
    let idx = robot.idx.clone();
    {
        let q = robot.data.qpos_mut();
        q[0] = t.pelvis_position.x;
        q[1] = t.pelvis_position.y;
        q[2] = t.pelvis_position.z;
        let uq = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
            t.pelvis_rotation,
        ));
        q[3] = uq.w;
        q[4] = uq.i;
        q[5] = uq.j;
        q[6] = uq.k;
        for s in 0..2 {
            q[idx.leg_qpos[s][SHANK_YAW]] = 0.0;
        }
        // A straight knee is singular and the solver could bend it backwards: start bent.
        for s in 0..2 {
            if q[idx.leg_qpos[s][3]] < 0.2 {
                q[idx.leg_qpos[s][2]] = -0.4;
                q[idx.leg_qpos[s][3]] = 0.8;
                q[idx.leg_qpos[s][5]] = -0.4;
            }
        }
        q[idx.waist_qpos[0]] = t.waist[0];
        q[idx.waist_qpos[1]] = t.waist[1];
    }
    // Free dofs (dof address, qpos address): the leg joints but the shank yaw, and the pelvis's
    // x, y when the CoM is targeted.
    let mut cols: Vec<usize> = Vec::new();
    let mut qadr: Vec<usize> = Vec::new();
    for s in 0..2 {
        for k in 0..7 {
            if k != SHANK_YAW {
                cols.push(idx.leg_dof[s][k]);
                qadr.push(idx.leg_qpos[s][k]);
            }
        }
    }
    if t.com_xy.is_some() {
        cols.extend([0, 1]);
        qadr.extend([0, 1]);
    }
    let rows = if t.com_xy.is_some() { 14 } else { 12 };
    // Levenberg-Marquardt on the task error: a step that does not reduce the error is undone
    // and the damping raised.
    let mut lambda2 = 1e-6;
    let mut worst = f64::INFINITY;
    let (mut e, mut j) = task(robot, t, &cols, rows);
    for it in 0..200 {
        worst = e.amax();
        if worst < 1e-10 {
            // The data may hold a rejected trial's kinematics: recompute at the solution.
            robot.kinematics();
            return Ok(it);
        }
        let jjt = &j * j.transpose() + DMatrix::identity(rows, rows) * lambda2;
        let Some(sol) = jjt.cholesky() else { break };
        let dq = j.transpose() * sol.solve(&e);
        let saved: Vec<f64> = qadr.iter().map(|&a| robot.data.qpos()[a]).collect();
        {
            let q = robot.data.qpos_mut();
            for (ci, &adr) in qadr.iter().enumerate() {
                q[adr] += dq[ci].clamp(-0.2, 0.2);
            }
            for s in 0..2 {
                let knee = &mut q[idx.leg_qpos[s][3]];
                *knee = knee.max(0.05);
            }
        }
        let (e2, j2) = task(robot, t, &cols, rows);
        if e2.norm() < e.norm() {
            e = e2;
            j = j2;
            lambda2 = (lambda2 / 10.0).max(1e-12);
        } else {
            let q = robot.data.qpos_mut();
            for (ci, &adr) in qadr.iter().enumerate() {
                q[adr] = saved[ci];
            }
            lambda2 *= 10.0;
            if lambda2 > 1e6 {
                break;
            }
        }
    }
    Err(TwinError::Model {
        path: robot.name.clone(),
        message: format!("inverse kinematics did not converge (largest error {worst:.3e})"),
    })
}

/// The task error (feet position and orientation, CoM) and its Jacobian over `cols`.
fn task(
    robot: &mut Sabian,
    t: &IkTarget,
    cols: &[usize],
    rows: usize,
) -> (DVector<f64>, DMatrix<f64>) {
    let idx = &robot.idx;
    let soles = idx.sole_bottom_site;
    let pelvis = idx.pelvis;
    let nv = robot.model().ffi().nv as usize;
    robot.kinematics();
    let mut e = DVector::<f64>::zeros(rows);
    let mut j = DMatrix::<f64>::zeros(rows, cols.len());
    for s in 0..2 {
        let site = soles[s];
        let p = vec3(&robot.data.site_xpos()[site]);
        let r = mat3(&robot.data.site_xmat()[site]);
        let ep = t.feet[s] - p;
        let mut er = Vec3::zeros();
        for c in 0..3 {
            er += r.column(c).cross(&Mat3::identity().column(c));
        }
        er *= 0.5;
        for k in 0..3 {
            e[6 * s + k] = ep[k];
            e[6 * s + 3 + k] = er[k];
        }
        let (jp, jr) = robot.data.jac_site(true, true, site);
        for (ci, &dof) in cols.iter().enumerate() {
            for k in 0..3 {
                j[(6 * s + k, ci)] = jp[k * nv + dof];
                j[(6 * s + 3 + k, ci)] = jr[k * nv + dof];
            }
        }
    }
    if let Some(c) = t.com_xy {
        let com = robot.com();
        e[12] = c[0] - com.x;
        e[13] = c[1] - com.y;
        let jc = robot.data.jac_subtree_com(pelvis);
        for (ci, &dof) in cols.iter().enumerate() {
            j[(12, ci)] = jc[dof];
            j[(13, ci)] = jc[nv + dof];
        }
    }
    (e, j)
}
