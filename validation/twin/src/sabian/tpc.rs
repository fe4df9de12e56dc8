//! Torso Position Control on the twin: the law is `zmp_models::walking::torso`; here is how a
//! torso shift becomes servo targets. The pelvis is moved horizontally by `d` with both soles
//! where the plan puts them and the pelvis's orientation kept: for each leg, the six joints (the
//! shank yaw stays at zero) change by `dq = -J^-1 (d, 0)`, `J` the 6x6 Jacobian of the sole's
//! position and orientation over those joints (the free joint's translation moves the sole by
//! `d`, the legs must take it back). The map is computed from the plan's postures every plan
//! sample (10 ms) and interpolated like the joint targets, so the correction is applied at the
//! servos' 1 kHz.

use super::robot::Sabian;
use crate::mj::TwinError;
use nalgebra::{Matrix6, Matrix6x2};

/// The legs' joints the shift moves: qpos and dof addresses, left leg then right.
const LEG_MOVING: [usize; 6] = [0, 1, 2, 3, 5, 6];

/// The per-sample map from a torso shift (x, y) to the leg joints' angles.
#[derive(Debug, Clone, Default)]
pub struct TorsoMap {
    /// qpos addresses of the 12 joints the shift moves.
    pub qpos: Vec<usize>,
    /// Per plan sample, per joint: d(angle)/d(shift x), d(angle)/d(shift y) (rad/m).
    pub per_sample: Vec<Vec<[f64; 2]>>,
    /// The whole robot's CoM shift per unit torso shift, x and y, at the first sample (the
    /// planning model's kinematics).
    pub com_per_shift: [f64; 2],
}

impl TorsoMap {
    /// Computes the map at each of `qpos` on `robot` (its kinematics; masses only enter
    /// `com_per_shift`).
    pub fn of(robot: &mut Sabian, qpos: &[Vec<f64>]) -> Result<TorsoMap, TwinError> {
        let idx = robot.idx.clone();
        let nv = robot.model().ffi().nv as usize;
        let mut cols = Vec::new();
        let mut qadr = Vec::new();
        for s in 0..2 {
            for &k in &LEG_MOVING {
                cols.push(idx.leg_dof[s][k]);
                qadr.push(idx.leg_qpos[s][k]);
            }
        }
        let mut per_sample = Vec::with_capacity(qpos.len());
        let mut com_per_shift = [0.0; 2];
        for (k, q) in qpos.iter().enumerate() {
            robot.data.qpos_mut().copy_from_slice(q);
            robot.kinematics();
            let mut row = vec![[0.0; 2]; 12];
            for s in 0..2 {
                let (jp, jr) = robot.data.jac_site(true, true, idx.sole_bottom_site[s]);
                let j = Matrix6::from_fn(|r, c| {
                    let dof = cols[6 * s + c];
                    if r < 3 {
                        jp[r * nv + dof]
                    } else {
                        jr[(r - 3) * nv + dof]
                    }
                });
                let rhs = Matrix6x2::from_fn(|r, c| if r == c { -1.0 } else { 0.0 });
                let x = j.lu().solve(&rhs).ok_or_else(|| TwinError::Model {
                    path: robot.name.clone(),
                    message: format!("leg {s}'s Jacobian is singular at plan sample {k}"),
                })?;
                for i in 0..6 {
                    row[6 * s + i] = [x[(i, 0)], x[(i, 1)]];
                }
            }
            if k == 0 {
                let jc = robot.data.jac_subtree_com(idx.pelvis);
                for (c, out) in com_per_shift.iter_mut().enumerate() {
                    *out = jc[c * nv + c]
                        + cols
                            .iter()
                            .zip(&row)
                            .map(|(&dof, d)| jc[c * nv + dof] * d[c])
                            .sum::<f64>();
                }
            }
            per_sample.push(row);
        }
        Ok(TorsoMap {
            qpos: qadr,
            per_sample,
            com_per_shift,
        })
    }

    /// Adds the joint changes (rad) of a torso `shift` (m) at plan position `k + a` (`a` in
    /// [0, 1)) to `targets`, one entry per joint of [`TorsoMap::qpos`].
    pub fn apply(&self, k: usize, a: f64, shift: [f64; 2], targets: &mut [f64]) {
        let last = self.per_sample.len() - 1;
        let (m0, m1) = (
            &self.per_sample[k.min(last)],
            &self.per_sample[(k + 1).min(last)],
        );
        for (i, t) in targets.iter_mut().enumerate() {
            let d: [f64; 2] = std::array::from_fn(|c| m0[i][c] + (m1[i][c] - m0[i][c]) * a);
            *t += d[0] * shift[0] + d[1] * shift[1];
        }
    }
}
