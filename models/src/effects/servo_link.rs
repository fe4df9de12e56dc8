//! A flexible trunk inside the servo: the two-body servo loop of
//! [`crate::effects::flexible_trunk`] stepped in time, so that the servo's force limit (and
//! friction) acts on the force that drives the joint and the link's reaction, not on a rigid
//! trunk's acceleration.
//!
//! Chosen in the model file by `in_servo = 1` (the flexible trunk's default, 0, is the
//! small-signal filter before the servo). In the linear range the loop is the flexible trunk's
//! filter of the CoM reference times the tracking low-pass (its frequency response is computed
//! so). Where a servo effect acts the
//! order matters: the motor's force limit clamps `wn^2 (r - x_J) - 2 zeta wn x_J'`, which
//! accelerates the joint (and the drive's inertia) against the link, while the CoM
//! `x_c = (1 - share) x_J + share x_U` rings. A filter followed by a clamped rigid servo (the
//! law before) clamps the CoM's own acceleration instead, which near the mode is a different
//! force: on independently simulated robots with a mode, the saturated records were up to 230
//! times their noise off with it, from the drawn robots' own parameters
//! (`validation/suites/tests/trunk_in_servo.rs`). The stepped loop is also exact (first-order hold of
//! the reference) where a filter before the servo holds its output as a ramp.
//!
//! Per unit of the axis's inertia: the link carries `u = share (1 - drive)` of it, the joint
//! node (with the drive) `1 - u`. With the link's relative force per unit link mass
//! `s = w_m^2 (x_J - x_U) + 2 zeta_m w_m (x_J' - x_U')`:
//! `x_U'' = s`, `x_J'' = (F - u s) / (1 - u)`.

use crate::lti::discretise_foh;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;

/// The flexible link of one axis's trunk (the parameters of
/// [`crate::effects::flexible_trunk`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrunkLink {
    /// Mode of the link, rad/s.
    pub omega_m: f64,
    /// Damping ratio of the link.
    pub zeta_m: f64,
    /// Part of the load's mass on the link (the CoM's weight of the link's part).
    pub share: f64,
    /// Part of the axis's inertia in the drive (moves with the joint, not in the CoM).
    pub drive: f64,
    /// Half the play of the link (0: none): no force while `|x_J - x_U|` is within it, and
    /// then the flanks push, never pull (a backlash inside the servo, `backlash.in_servo`).
    pub half_play: f64,
    /// Viscous drag of the link's part to the ground, 1/s (a bearing's drag, which lets a
    /// disengaged load settle in the play).
    pub drag: f64,
}

impl TrunkLink {
    /// A flexible link without play or drag.
    pub fn flexible(omega_m: f64, zeta_m: f64, share: f64, drive: f64) -> TrunkLink {
        TrunkLink {
            omega_m,
            zeta_m,
            share,
            drive,
            half_play: 0.0,
            drag: 0.0,
        }
    }
}

/// Smallest inertia fraction of the joint node: a link carrying the whole inertia (share 1,
/// no drive) would leave the servo driving a massless joint; the joint keeps at least this.
const MIN_JOINT_INERTIA: f64 = 1e-3;

/// Largest `h * rate` of an RK4 sub-step of the linked servo for the loop's own dynamics (a
/// bound on its eigenvalues): RK4 is stable to 2.8 and accurate to 1e-4 per step at 0.25.
const SUBSTEP_SPEED: f64 = 1.0;

/// Sub-step rate per unit of the loop's fastest eigenvalue for a link without play: `h |lambda|`
/// of 1/4 per RK4 sub-step ([`SUBSTEP_SPEED`] 1 divided by it).
const ACCURATE_RATE_FACTOR: f64 = 4.0;

/// The stepped two-body chain of one axis: parameters, exact discretisation of the linear
/// loop, and the link's state (the joint's is the servo's own `x`, `v`).
#[derive(Debug, Clone)]
pub struct Linked {
    /// The link's parameters.
    pub link: TrunkLink,
    /// Link's part of the axis's inertia.
    u: f64,
    /// `1 / (1 - u)`.
    inv_joint: f64,
    wm2: f64,
    cm: f64,
    half_play: f64,
    drag: f64,
    /// Exact first-order-hold step of `[x_J, v_J, x_U, v_U]` for the reference.
    phi: [[f64; 4]; 4],
    g0: [f64; 4],
    /// `gamma1 / h`.
    g1: [f64; 4],
    /// Bound on the loop's fastest rate, 1/s (for RK4 sub-steps).
    speed: f64,
    /// Exact step of the chain under a constant force (the limit clamping): `phi_free s +
    /// gamma_free F`.
    phi_free: [[f64; 4]; 4],
    gamma_free: [f64; 4],
    /// Exact steps of the link's part alone over a step and over half a step, the joint
    /// moving at a constant velocity (the stuck servo's creep).
    follow: [Follow; 2],
    /// Position of the link's part (above the link), m.
    pub xu: f64,
    /// Velocity of the link's part, m/s.
    pub vu: f64,
}

impl Linked {
    /// The chain of `link` on a servo of `wn2 = omega_n²` (1/s²) and `two_zeta_wn = 2 zeta omega_n` (1/s), stepped at `h` (s), at rest.
    pub fn new(link: TrunkLink, wn2: f64, two_zeta_wn: f64, h: f64) -> Linked {
        let u = (link.share * (1.0 - link.drive)).min(1.0 - MIN_JOINT_INERTIA);
        let inv_joint = 1.0 / (1.0 - u);
        let wm2 = link.omega_m * link.omega_m;
        let cm = 2.0 * link.zeta_m * link.omega_m;
        let (a, b) = system(u, wm2, cm, link.drag, wn2, two_zeta_wn);
        let (phi, g0, g1) = discretise_foh(&a, &b, h);
        let p = rows(&phi);
        // The chain without the servo's feedback, driven by a force per unit inertia.
        let (a_free, _) = system(u, wm2, cm, link.drag, 0.0, 0.0);
        let b_free = DVector::from_row_slice(&[0.0, inv_joint, 0.0, 0.0]);
        let (phi_f, g_f, _) = discretise_foh(&a_free, &b_free, h);
        // Gershgorin: every eigenvalue lies within the largest absolute row sum. But the row
        // sums mix positions and velocities: for a stiff link they overstate its rate by about
        // `omega_m` (a row sum of `2 omega_m^2` for eigenvalues of size `omega_m`). A play's
        // link is stiff (a gear's transmission): its eigenvalues themselves bound it (the loop
        // is engaged or the parts move apart, slower). Without play the sub-steps keep
        // `h |lambda| <= 1/4`, where RK4 is accurate to 1e-4 per step, and never exceed the
        // row sums' count: a fit that drives the link towards rigid (`omega_m` 2000 rad/s on
        // development seed 42) took 4096 sub-steps per step by the row sums, 20 by this.
        let row_sums = (0..4)
            .map(|i| (0..4).map(|j| a[(i, j)].abs()).sum::<f64>())
            .fold(0.0, f64::max);
        // Eigenvalues not found (an entry not finite, or no convergence): the row sums.
        let fastest = crate::lti::spectral_radius(&a).unwrap_or(row_sums);
        let speed = if link.half_play > 0.0 {
            fastest
        } else {
            row_sums.min(ACCURATE_RATE_FACTOR * fastest)
        };
        Linked {
            link,
            u,
            inv_joint,
            wm2,
            cm,
            half_play: link.half_play,
            drag: link.drag,
            phi: p,
            g0: [g0[0], g0[1], g0[2], g0[3]],
            g1: [g1[0] / h, g1[1] / h, g1[2] / h, g1[3] / h],
            speed,
            phi_free: rows(&phi_f),
            gamma_free: [g_f[0], g_f[1], g_f[2], g_f[3]],
            follow: [
                Follow::new(wm2, cm, link.drag, h),
                Follow::new(wm2, cm, link.drag, 0.5 * h),
            ],
            xu: 0.0,
            vu: 0.0,
        }
    }

    /// The exact linear step of `s` with the reference moving linearly from `r0` to `r0 + dr`.
    #[inline]
    pub fn linear(&self, s: &[f64; 4], r0: f64, dr: f64) -> [f64; 4] {
        let mut out = [0.0; 4];
        for (i, o) in out.iter_mut().enumerate() {
            let p = &self.phi[i];
            *o = p[0] * s[0]
                + p[1] * s[1]
                + p[2] * s[2]
                + p[3] * s[3]
                + self.g0[i] * r0
                + self.g1[i] * dr;
        }
        out
    }

    /// The exact step of `s` under the constant force `force`.
    #[inline]
    pub fn free(&self, s: &[f64; 4], force: f64) -> [f64; 4] {
        let mut out = [0.0; 4];
        for (i, o) in out.iter_mut().enumerate() {
            let p = &self.phi_free[i];
            *o = p[0] * s[0] + p[1] * s[1] + p[2] * s[2] + p[3] * s[3] + self.gamma_free[i] * force;
        }
        out
    }

    /// Whether the link has play (then its steps are never the linear loop's).
    #[inline]
    pub fn has_play(&self) -> bool {
        self.half_play > 0.0
    }

    /// Where the loop is the linear one: the shift of the link's part's position that makes
    /// the loop engaged on one flank (contact pushing) the linear loop, `+-half_play`; `None`
    /// in the gap or where the flanks part. `Some(0.0)` without play (always linear).
    #[inline]
    pub fn flank(&self, s: &[f64; 4]) -> Option<f64> {
        let hp = self.half_play;
        if hp <= 0.0 {
            return Some(0.0);
        }
        let d = s[0] - s[2];
        let (e, shift) = if d > hp {
            (d - hp, hp)
        } else if d < -hp {
            (d + hp, -hp)
        } else {
            return None;
        };
        let f = self.wm2 * e + self.cm * (s[1] - s[3]);
        (f * e > 0.0).then_some(shift)
    }

    /// The link's force per unit link mass. With play: none in the gap, and beyond it the
    /// spring and damper on the deflection past the flank, cut to zero where the damper would
    /// pull the flanks together (contact pushes only).
    #[inline]
    fn spring(&self, s: &[f64; 4]) -> f64 {
        let d = s[0] - s[2];
        if self.half_play > 0.0 {
            let hp = self.half_play;
            let e = if d > hp {
                d - hp
            } else if d < -hp {
                d + hp
            } else {
                return 0.0;
            };
            let f = self.wm2 * e + self.cm * (s[1] - s[3]);
            return if f * e > 0.0 { f } else { 0.0 };
        }
        self.wm2 * d + self.cm * (s[1] - s[3])
    }

    /// Accelerations `(x_J'', x_U'')` under the servo force `force` (per unit inertia).
    #[inline]
    pub fn accelerations(&self, s: &[f64; 4], force: f64) -> (f64, f64) {
        let sp = self.spring(s);
        let au = if self.drag > 0.0 {
            sp - self.drag * s[3]
        } else {
            sp
        };
        ((force - self.u * sp) * self.inv_joint, au)
    }

    /// CoM position, velocity and acceleration of state `s` under `force`.
    #[inline]
    pub fn com(&self, s: &[f64; 4], force: f64) -> (f64, f64, f64) {
        let w = self.link.share;
        let (aj, au) = self.accelerations(s, force);
        (
            (1.0 - w) * s[0] + w * s[2],
            (1.0 - w) * s[1] + w * s[3],
            (1.0 - w) * aj + w * au,
        )
    }

    /// The link's pull on the joint, `u s` of [`Linked::accelerations`], as `c0 + c1 v_J`
    /// at the joint velocity `v_J` (the other parts of the state `s` held): `None` with play
    /// (there the pull is not linear in it).
    #[inline]
    pub fn pull(&self, s: &[f64; 4]) -> Option<(f64, f64)> {
        (self.half_play <= 0.0).then(|| {
            (
                self.u * (self.wm2 * (s[0] - s[2]) - self.cm * s[3]),
                self.u * self.cm,
            )
        })
    }

    /// `1 / (1 - u)`: the joint's acceleration per unit of net force.
    #[inline]
    pub fn inv_joint(&self) -> f64 {
        self.inv_joint
    }

    /// The link's part `(x_U, v_U)` after a step (`half`: half a step) in which the joint moves
    /// from `x_j` at the constant velocity `v_j`: exact (the link is linear in the joint's
    /// motion, which is then a ramp).
    #[inline]
    pub fn follow(&self, half: bool, (xu, vu): (f64, f64), x_j: f64, v_j: f64) -> (f64, f64) {
        self.follow[usize::from(half)].step(
            (xu, vu),
            self.wm2 * x_j + self.cm * v_j,
            self.wm2 * v_j,
        )
    }

    /// RK4 sub-steps of a step `h` whose servo effects have stiffness `k` (1/s, against the
    /// joint's velocity, per unit of the axis's inertia).
    pub fn substeps(&self, h: f64, k: f64) -> usize {
        let n = (h * self.speed / SUBSTEP_SPEED)
            .max(h * k * self.inv_joint / super::servo::SUBSTEP_STIFFNESS)
            .ceil();
        if n.is_finite() {
            (n as usize).clamp(4, super::servo::MAX_SUBSTEPS)
        } else {
            super::servo::MAX_SUBSTEPS
        }
    }
}

impl Linked {
    /// The linear loop's continuous state matrix and reference input (for its periodic orbit).
    pub fn system(&self, wn2: f64, two_zeta_wn: f64) -> (DMatrix<f64>, DVector<f64>) {
        system(self.u, self.wm2, self.cm, self.drag, wn2, two_zeta_wn)
    }
}

/// Exact first-order-hold step of the link's part `[x_U, v_U]` driven by the joint,
/// `x_U'' = w_m^2 (x_J - x_U) + c_m (v_J - v_U) - drag v_U`, the drive `w_m^2 x_J + c_m v_J`
/// a ramp.
#[derive(Debug, Clone)]
struct Follow {
    t: f64,
    phi: [[f64; 2]; 2],
    g0: [f64; 2],
    /// `gamma1 / t`.
    g1: [f64; 2],
}

impl Follow {
    fn new(wm2: f64, cm: f64, drag: f64, t: f64) -> Follow {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -wm2, -cm - drag]);
        let b = DVector::from_row_slice(&[0.0, 1.0]);
        let (phi, g0, g1) = discretise_foh(&a, &b, t);
        Follow {
            t,
            phi: [[phi[(0, 0)], phi[(0, 1)]], [phi[(1, 0)], phi[(1, 1)]]],
            g0: [g0[0], g0[1]],
            g1: [g1[0] / t, g1[1] / t],
        }
    }

    /// The state after the step, the drive starting at `w0` and rising at `rate` per second.
    #[inline]
    fn step(&self, (x, v): (f64, f64), w0: f64, rate: f64) -> (f64, f64) {
        let dw = rate * self.t;
        (
            self.phi[0][0] * x + self.phi[0][1] * v + self.g0[0] * w0 + self.g1[0] * dw,
            self.phi[1][0] * x + self.phi[1][1] * v + self.g0[1] * w0 + self.g1[1] * dw,
        )
    }
}

fn rows(m: &DMatrix<f64>) -> [[f64; 4]; 4] {
    let mut p = [[0.0; 4]; 4];
    for (i, row) in p.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = m[(i, j)];
        }
    }
    p
}

/// `x' = A x + B r` of the linear loop (engaged, if the link has play), state
/// `[x_J, v_J, x_U, v_U]`; `drag` brakes the link's part.
fn system(
    u: f64,
    wm2: f64,
    cm: f64,
    drag: f64,
    wn2: f64,
    two_zeta_wn: f64,
) -> (DMatrix<f64>, DVector<f64>) {
    let ij = 1.0 / (1.0 - u);
    #[rustfmt::skip]
    let a = DMatrix::from_row_slice(4, 4, &[
        0.0, 1.0, 0.0, 0.0,
        -(wn2 + u * wm2) * ij, -(two_zeta_wn + u * cm) * ij, u * wm2 * ij, u * cm * ij,
        0.0, 0.0, 0.0, 1.0,
        wm2, cm, -wm2, -cm - drag,
    ]);
    (a, DVector::from_row_slice(&[0.0, wn2 * ij, 0.0, 0.0]))
}

/// The linear loop's joint response `X_J / R` at `omega` for the servo `(wn, zeta)` and an
/// optional link (without one: the tracking low-pass `H`).
pub fn joint_response(link: Option<TrunkLink>, wn: f64, zeta: f64, omega: f64) -> Complex64 {
    let s = Complex64::new(0.0, omega);
    // The link's part pulls the joint with `u (x_U'' + drag x_U')`, `x_U = M x_J`.
    let load = link.map_or(s * s, |l| {
        let u = (l.share * (1.0 - l.drive)).min(1.0 - MIN_JOINT_INERTIA);
        let m = link_transfer(&l, s);
        s * s * ((1.0 - u) + u * m) + u * l.drag * s * m
    });
    wn * wn / (load + 2.0 * zeta * wn * s + wn * wn)
}

/// `X_U / X_J` of the link (engaged, if it has play).
fn link_transfer(l: &TrunkLink, s: Complex64) -> Complex64 {
    let (wm2, cm) = (l.omega_m * l.omega_m, 2.0 * l.zeta_m * l.omega_m);
    (cm * s + wm2) / (s * s + (cm + l.drag) * s + wm2)
}

/// The linear loop's CoM response `X_c / R` at `omega` (engaged, if the link has play).
pub fn com_response(link: TrunkLink, wn: f64, zeta: f64, omega: f64) -> Complex64 {
    let s = Complex64::new(0.0, omega);
    let q = (1.0 - link.share) + link.share * link_transfer(&link, s);
    q * joint_response(Some(link), wn, zeta, omega)
}

#[cfg(test)]
mod tests {
    use super::{Linked, TrunkLink};

    /// The sub-steps follow the loop's eigenvalues, not the row sums that overstate a stiff
    /// link's rate by about `omega_m`: the near-rigid link a fit reached on development seed 42
    /// (2000 rad/s, critically damped, a tiny share) at the describing functions' longest step
    /// takes 20 sub-steps (`h |lambda| <= 1/4`), where the row sums asked for the 4096 cap; a
    /// soft link keeps the minimum; the accuracy is tested against the two-body equations in
    /// `tests/trunk_servo_law.rs`.
    #[test]
    fn sub_steps_follow_the_eigenvalues() {
        let (wn, zeta) = (25.0, 0.9);
        let h = 2.5e-3;
        let stiff = Linked::new(
            TrunkLink::flexible(2000.0, 1.0, 3.8e-4, 0.0),
            wn * wn,
            2.0 * zeta * wn,
            h,
        );
        let n = stiff.substeps(h, 0.0);
        assert!((20..=24).contains(&n), "stiff link: {n} sub-steps");
        let soft = Linked::new(
            TrunkLink::flexible(14.0, 0.08, 0.35, 0.29),
            wn * wn,
            2.0 * zeta * wn,
            1e-3,
        );
        assert_eq!(soft.substeps(1e-3, 0.0), 4);
        // Friction's stiffness still adds its own (20000 / s over the joint's inertia).
        assert_eq!(soft.substeps(1e-3, 20000.0), 14);
    }
}
