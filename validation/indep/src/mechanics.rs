//! The equations of motion: each axis a chain of lumped bodies, the ZMP map, the sensor filter.
//!
//! # The chain of one axis (signal path)
//!
//! ```text
//!  r(t − τ) ─► servo ─F─► [D] drive ══ transmission ══ [J] trunk joint ── link 1 ── [U1] ── link 2 ── [U2]
//!  (command     (P position,        (play w, stiffness,      │ friction          (flexible trunk:
//!   latency)     P velocity,          hardening)             │ inertial          structural modes)
//!                force limit)                                 ▼ coupling
//! ```
//!
//! * **D** is the drive: the motor's rotor inertia reflected through the gear. Its encoder is
//!   the servo's feedback (collocated control, so every chain below is passive and stable).
//!   It does not move the CoM (a rotor spins in place; its reaction torque, `1/N` of its
//!   reflected inertia's, is neglected).
//! * **J** is the trunk at its joint, where the joint's bearing friction acts.
//! * **U1**, **U2** are parts of the trunk carried on flexible links (spring + damper).
//!
//! An element that is absent is rigid: the bodies it would separate are merged into one node
//! (so the clean robot has one node of unit inertia and `x_c = p` follows the seed's
//! `ωn²/(s²+2ζωn s+ωn²)` exactly). Masses are fractions of the axis's total inertia: drive
//! `μ_D`, load `L = 1 − μ_D`, J `L(1−μ1)`, U1 `L μ1 (1−μ2)`, U2 `L μ1 μ2`. The CoM coordinate is
//! the load-weighted position `x_c = (m_J q_J + m_U1 q_U1 + m_U2 q_U2) / L`.
//!
//! Gravity about the trunk joint is assumed compensated (the servo's feedforward, or a
//! balanced trunk): the trunk floats neutrally in the play. Positions are absolute (they start
//! at the operating point), so the ZMP map sees the absolute CoM.
//!
//! # The ZMP map (seed eqs. 6-15, 22-24)
//!
//! `zmp_i = Σ_j a_ij(x_c) x_cj − b_ij(x_c) x_cj''` with the actual (possibly saturated, stuck,
//! ringing) CoM acceleration of the chain. With `operating_point_dependence`,
//! `a_ij(x_c) = a_ij (1 + α·x_c)`, `b_ij(x_c) = b_ij (1 + β·x_c)` at the instantaneous CoM.
//! With `sensor_lowpass` the force-sensor ZMP passes `ωc/(s+ωc)` (a state of the integrator).

use crate::robot::{CrossCoupling, Robot};

/// Maximum bodies per axis.
pub(crate) const MAX_NODES: usize = 4;
/// Length of the integrator state: per axis 4 positions and 4 velocities, then 2 filter
/// states, then the 2 running integrals of the sensor signal (for the sample averages).
pub(crate) const STATE_LEN: usize = 20;
/// The integrator state.
pub(crate) type State = [f64; STATE_LEN];

/// Index of node `n`'s position on axis `a`.
#[inline]
pub(crate) fn qi(a: usize, n: usize) -> usize {
    a * 8 + n
}
/// Index of node `n`'s velocity on axis `a`.
#[inline]
pub(crate) fn vi(a: usize, n: usize) -> usize {
    a * 8 + 4 + n
}
/// Index of output `i`'s sensor filter state.
#[inline]
pub(crate) fn yi(i: usize) -> usize {
    16 + i
}
/// Index of the running integral of output `i`'s sensor signal.
#[inline]
pub(crate) fn ii(i: usize) -> usize {
    18 + i
}

/// The discrete state of the joint friction of one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum FrictionMode {
    /// The joint holds: `v_J = 0`, friction balances the other forces.
    Stick,
    /// The joint slides in direction `+1` or `−1`.
    Slip(f64),
}

/// A connection between two neighbouring nodes: force on the outer node
/// `F = k e (1 + e² / d_h²) + c ė`, with `e` the deflection beyond the half play.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Link {
    k: f64,
    c: f64,
    half_play: f64,
    inv_hardening_sq: f64,
}

impl Link {
    /// Force pushing the outer node forward, for relative position `d = q_inner − q_outer`.
    ///
    /// With play, no force in the gap and a unilateral contact in it (the flanks push, never
    /// pull: a damper force that would pull is cut to zero).
    #[inline]
    fn force(&self, d: f64, dv: f64) -> f64 {
        let hp = self.half_play;
        let e = if hp == 0.0 {
            d
        } else if d > hp {
            d - hp
        } else if d < -hp {
            d + hp
        } else {
            return 0.0;
        };
        let f = self.k * e * (1.0 + e * e * self.inv_hardening_sq) + self.c * dv;
        if hp == 0.0 {
            f
        } else if e > 0.0 {
            f.max(0.0)
        } else {
            f.min(0.0)
        }
    }
}

/// Friction law: level `kinetic + (static − kinetic) exp(−v²/v_s²)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FrictionLaw {
    pub kinetic: f64,
    pub static_level: f64,
    inv_vs_sq: f64,
}

impl FrictionLaw {
    #[inline]
    fn level(&self, v: f64) -> f64 {
        if self.inv_vs_sq == 0.0 {
            self.kinetic
        } else {
            self.kinetic + (self.static_level - self.kinetic) * (-(v * v) * self.inv_vs_sq).exp()
        }
    }
}

/// The chain of one axis, built from its `AxisMechanics`.
#[derive(Clone, Debug)]
pub(crate) struct AxisModel {
    pub n: usize,
    pub inv_mass: [f64; MAX_NODES],
    pub mass: [f64; MAX_NODES],
    pub com_weight: [f64; MAX_NODES],
    links: [Link; MAX_NODES - 1],
    /// Spring and damper of each link for the small-signal response: `(k, c)`.
    pub link_kc: [(f64, f64); MAX_NODES - 1],
    /// The node of the trunk joint (friction, drag and inertial coupling act there).
    pub joint: usize,
    /// Viscous drag on the joint node, specific force per velocity, 1/s.
    pub joint_drag: f64,
    pub kp: f64,
    pub kv: f64,
    pub accel_limit: f64,
    velocity_limit: f64,
    pub delay: f64,
    pub friction: Option<FrictionLaw>,
    /// Half the play of the drive-joint transmission (0: none).
    pub half_play: f64,
    /// Whether the small-signal response describes this axis (no play, no friction).
    pub is_smooth: bool,
    omega_n: f64,
}

/// What one evaluation of an axis gives besides the accelerations.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct AxisOut {
    /// Sum of the non-friction forces on the joint node (specific force, m/s²).
    pub f_other: f64,
    /// CoM position, m.
    pub xc: f64,
    /// CoM acceleration, m/s².
    pub xc_dd: f64,
}

impl AxisModel {
    pub fn new(m: &crate::robot::AxisMechanics) -> Self {
        let mu_d = m.drive_mass_fraction;
        let load = 1.0 - mu_d;
        let mu1 = m.modes.first().map_or(0.0, |f| f.mass_fraction);
        let mu2 = m.modes.get(1).map_or(0.0, |f| f.mass_fraction);
        // Physical bodies: D, J, U1, U2.
        let body_mass = [
            mu_d,
            load * (1.0 - mu1),
            load * mu1 * (1.0 - mu2),
            load * mu1 * mu2,
        ];
        let body_com = [
            0.0,
            body_mass[1] / load,
            body_mass[2] / load,
            body_mass[3] / load,
        ];
        // Nodes: D alone only with a transmission; U1, U2 only with their flexible links.
        let mut mass = [0.0; MAX_NODES];
        let mut com_weight = [0.0; MAX_NODES];
        let mut links = [Link::default(); MAX_NODES - 1];
        let mut link_kc = [(0.0, 0.0); MAX_NODES - 1];
        let mut n = 0;
        let mut half_play = 0.0;
        let mut joint_drag = 0.0;
        if let Some(t) = &m.transmission {
            joint_drag = t.load_drag_time.map_or(0.0, |tau| body_mass[1] / tau);
            mass[0] = body_mass[0];
            n = 1;
            let k = t.omega * t.omega * load;
            let c = 2.0 * t.zeta * t.omega * load;
            half_play = 0.5 * t.play;
            let inv_h = t.hardening_deflection.map_or(0.0, |d| 1.0 / (d * d));
            links[0] = Link {
                k,
                c,
                half_play,
                inv_hardening_sq: inv_h,
            };
            link_kc[0] = (k, c);
            mass[1] = body_mass[1];
            com_weight[1] = body_com[1];
        } else {
            mass[0] = body_mass[0] + body_mass[1];
            com_weight[0] = body_com[1];
        }
        let joint = n;
        n += 1;
        let outboard = [body_mass[2] + body_mass[3], body_mass[3]];
        for (l, mode) in m.modes.iter().enumerate() {
            let k = mode.omega * mode.omega * outboard[l];
            let c = 2.0 * mode.zeta * mode.omega * outboard[l];
            links[n - 1] = Link {
                k,
                c,
                half_play: 0.0,
                inv_hardening_sq: 0.0,
            };
            link_kc[n - 1] = (k, c);
            mass[n] = body_mass[2 + l];
            com_weight[n] = body_com[2 + l];
            n += 1;
        }
        // The last flexible body carries what lies beyond it (U1 holds U2 when there is one
        // link only: body_mass[3] is then 0 because mu2 = 0).
        let mut inv_mass = [0.0; MAX_NODES];
        for k in 0..n {
            inv_mass[k] = 1.0 / mass[k];
        }
        let s = &m.servo;
        AxisModel {
            omega_n: s.omega_n,
            n,
            inv_mass,
            mass,
            com_weight,
            links,
            link_kc,
            joint,
            joint_drag,
            kp: s.omega_n / (2.0 * s.zeta),
            kv: 2.0 * s.zeta * s.omega_n,
            accel_limit: s.accel_limit,
            velocity_limit: s.velocity_limit.unwrap_or(f64::INFINITY),
            delay: m.command_delay,
            friction: m.friction.as_ref().map(|f| FrictionLaw {
                kinetic: f.kinetic,
                static_level: f.static_level,
                inv_vs_sq: f.stribeck_velocity.map_or(0.0, |v| 1.0 / (v * v)),
            }),
            half_play,
            is_smooth: half_play == 0.0 && m.friction.is_none(),
        }
    }

    /// Accelerations of axis `a` for the state `x`, servo reference `r`, external force `ext`
    /// on the joint node and friction mode `mode`.
    #[inline(always)]
    pub fn eval(
        &self,
        x: &State,
        a: usize,
        r: f64,
        ext: f64,
        mode: FrictionMode,
        acc: &mut [f64; MAX_NODES],
    ) -> AxisOut {
        let base = a * 8;
        let q: &[f64; MAX_NODES] = x[base..base + 4].try_into().expect("4 positions");
        let v: &[f64; MAX_NODES] = x[base + 4..base + 8].try_into().expect("4 velocities");
        let mut f = [0.0; MAX_NODES];
        // Servo: P position loop -> (rate limit) -> P velocity loop -> force limit.
        let v_ref = (self.kp * (r - q[0])).clamp(-self.velocity_limit, self.velocity_limit);
        f[0] = (self.kv * (v_ref - v[0])).clamp(-self.accel_limit, self.accel_limit);
        for l in 0..self.n - 1 {
            let fl = self.links[l].force(q[l] - q[l + 1], v[l] - v[l + 1]);
            f[l] -= fl;
            f[l + 1] += fl;
        }
        let j = self.joint;
        f[j] += ext - self.joint_drag * v[j];
        let f_other = f[j];
        let mut stuck = false;
        if let Some(fr) = &self.friction {
            match mode {
                FrictionMode::Stick => stuck = true,
                FrictionMode::Slip(s) => f[j] -= s * fr.level(v[j]),
            }
        }
        let mut xc = 0.0;
        let mut xc_dd = 0.0;
        let n = self.n;
        for (k, a) in acc.iter_mut().enumerate().take(n) {
            *a = f[k] * self.inv_mass[k];
            xc += self.com_weight[k] * q[k];
        }
        if stuck {
            acc[j] = 0.0;
        }
        for (w, a) in self.com_weight.iter().zip(acc.iter()).take(n) {
            xc_dd += w * a;
        }
        AxisOut { f_other, xc, xc_dd }
    }

    /// An estimate of the fastest rate of this axis's equations, 1/s, when the forces in its
    /// links stay below `force_bound` (specific force, m/s²): the largest of the two-body
    /// rates of the servo on the drive node and of each link between its two nodes. A pair
    /// with stiffness rate `ω² = k (1/m_i + 1/m_j)` and damping rate `γ = c (1/m_i + 1/m_j)`
    /// has roots of modulus `ω` when underdamped and at most `γ` when overdamped. A hardening
    /// spring counts with its tangent stiffness at the deflection `force_bound / k`; Stribeck
    /// friction adds its steepest falling slope on the joint.
    pub fn fastest_rate(&self, force_bound: f64) -> f64 {
        let pair = |k: f64, c: f64, inv_m: f64| {
            let (w2, g) = (k * inv_m, c * inv_m);
            if g < 2.0 * w2.sqrt() {
                w2.sqrt()
            } else {
                g
            }
        };
        let mut worst = pair(self.kp * self.kv, self.kv, self.inv_mass[0]);
        for l in 0..self.n - 1 {
            let link = &self.links[l];
            let deflection = force_bound / link.k.max(1e-300);
            let k = link.k * (1.0 + 3.0 * deflection * deflection * link.inv_hardening_sq);
            worst = worst.max(pair(k, link.c, self.inv_mass[l] + self.inv_mass[l + 1]));
        }
        worst = worst.max(self.joint_drag * self.inv_mass[self.joint]);
        if let Some(f) = &self.friction {
            if f.inv_vs_sq > 0.0 {
                // max |d/dv (Fs - Fc) exp(-v²/vs²)| = (Fs - Fc) sqrt(2/e) / vs
                let slope = (f.static_level - f.kinetic) * 0.8578 * f.inv_vs_sq.sqrt();
                worst = worst.max(slope * self.inv_mass[self.joint]);
            }
        }
        worst
    }

    /// A bound of the link forces a stepped sine of amplitude `a` at `omega` can cause: the
    /// force limit, or the steady acceleration (`1.2 a ω²`, the servo's resonance included)
    /// plus the start transient (`0.5 a ω ωn`, the response to the initial velocity step).
    pub fn force_bound(&self, a: f64, omega: f64) -> f64 {
        self.accel_limit
            .min(a * omega * (1.2 * omega + 0.5 * self.omega_n))
    }

    /// How much a force on the joint node moves the CoM acceleration directly: the joint's
    /// CoM weight over its mass, 0 while the joint sticks.
    #[inline]
    pub fn direct_gain(&self, mode: FrictionMode) -> f64 {
        match (&self.friction, mode) {
            (Some(_), FrictionMode::Stick) => 0.0,
            _ => self.com_weight[self.joint] * self.inv_mass[self.joint],
        }
    }

    /// Which branch of each piecewise law of this axis is active at `x` for the servo
    /// reference `r`: bits 0-1 the force limit (none, +, −), bits 2-3 the velocity limit, bits
    /// 4-5 the play (gap, flanks pushing, flanks separating with the damper force cut to 0).
    /// The right-hand side is smooth while this stays the same, so a change marks an event.
    #[inline]
    pub fn branches(&self, x: &State, a: usize, r: f64) -> u32 {
        let q0 = x[qi(a, 0)];
        let v0 = x[vi(a, 0)];
        let v_raw = self.kp * (r - q0);
        let mut bits = 0;
        let v_ref = if v_raw > self.velocity_limit {
            bits |= 4;
            self.velocity_limit
        } else if v_raw < -self.velocity_limit {
            bits |= 8;
            -self.velocity_limit
        } else {
            v_raw
        };
        let f = self.kv * (v_ref - v0);
        if f > self.accel_limit {
            bits |= 1;
        } else if f < -self.accel_limit {
            bits |= 2;
        }
        if self.half_play > 0.0 {
            let d = q0 - x[qi(a, 1)];
            let dv = v0 - x[vi(a, 1)];
            let hp = self.half_play;
            let e = if d > hp {
                d - hp
            } else if d < -hp {
                d + hp
            } else {
                return bits;
            };
            let link = &self.links[0];
            let f = link.k * e * (1.0 + e * e * link.inv_hardening_sq) + link.c * dv;
            bits |= if f * e > 0.0 { 16 } else { 32 };
        }
        bits
    }
}

/// The whole robot as equations: two chains, the ZMP map and the sensor filter.
#[derive(Clone, Debug)]
pub(crate) struct Plant {
    pub axes: [AxisModel; 2],
    /// Effective pendulum `a[i][j]`, `b[i][j]` (base plus pendulum-form coupling).
    pub a: [[f64; 2]; 2],
    pub b: [[f64; 2]; 2],
    /// `(a_slope, b_slope)` of the operating-point dependence.
    pub op_dep: Option<([f64; 2], [f64; 2])>,
    /// `(a_slope, b_slope)[i][j]` of the operating-point dependence per channel.
    pub op_channel: Option<ChannelSlopes>,
    /// Inertial coupling `[kappa_xy, kappa_yx]`.
    pub kappa: Option<[f64; 2]>,
    /// Sensor low-pass cutoffs, rad/s.
    pub lowpass: Option<[f64; 2]>,
}

/// Slopes per channel `[i][j]` along x and y: of `a`, of `b`.
pub(crate) type ChannelSlopes = ([[[f64; 2]; 2]; 2], [[[f64; 2]; 2]; 2]);

/// Everything an evaluation of the plant gives besides the derivative.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PlantOut {
    pub axis: [AxisOut; 2],
    /// The true ZMP (before the sensor), m.
    pub zmp: [f64; 2],
}

impl Plant {
    pub fn new(robot: &Robot) -> Self {
        let p = robot.effective_pendulum();
        let axes = [
            AxisModel::new(&robot.axes[0]),
            AxisModel::new(&robot.axes[1]),
        ];
        Plant {
            axes,
            a: p.a,
            b: p.b,
            op_dep: robot.op_dependence.as_ref().map(|o| (o.a_slope, o.b_slope)),
            op_channel: robot
                .op_per_channel
                .as_ref()
                .map(|o| (o.a_slope, o.b_slope)),
            kappa: match robot.cross_coupling {
                Some(CrossCoupling::Inertial { kappa_xy, kappa_yx }) => Some([kappa_xy, kappa_yx]),
                _ => None,
            },
            lowpass: robot.sensor.lowpass_cutoff,
        }
    }

    /// The ZMP of CoM positions `xc` (absolute, m) and accelerations `xdd` (m/s²).
    #[inline]
    pub fn zmp(&self, xc: [f64; 2], xdd: [f64; 2]) -> [f64; 2] {
        let (ga, gb) = match &self.op_dep {
            None => (1.0, 1.0),
            Some((sa, sb)) => (
                1.0 + sa[0] * xc[0] + sa[1] * xc[1],
                1.0 + sb[0] * xc[0] + sb[1] * xc[1],
            ),
        };
        let mut z = [0.0; 2];
        let Some((pa, pb)) = &self.op_channel else {
            for (i, zi) in z.iter_mut().enumerate() {
                *zi = ga * (self.a[i][0] * xc[0] + self.a[i][1] * xc[1])
                    - gb * (self.b[i][0] * xdd[0] + self.b[i][1] * xdd[1]);
            }
            return z;
        };
        // Each channel's own factor on top of the common one.
        let own = |s: &[f64; 2]| 1.0 + s[0] * xc[0] + s[1] * xc[1];
        for (i, zi) in z.iter_mut().enumerate() {
            for j in 0..2 {
                *zi += ga * own(&pa[i][j]) * self.a[i][j] * xc[j]
                    - gb * own(&pb[i][j]) * self.b[i][j] * xdd[j];
            }
        }
        z
    }

    /// The derivative `dx` of the state `x` for servo references `r` and friction `modes`.
    /// `dx` must come zeroed (or from an earlier call): the entries of unused nodes are not
    /// written.
    #[inline]
    pub fn derivs(
        &self,
        x: &State,
        r: [f64; 2],
        modes: &[FrictionMode; 2],
        dx: &mut State,
    ) -> PlantOut {
        let mut acc = [[0.0; MAX_NODES]; 2];
        let mut ext = [0.0; 2];
        if let Some(k) = self.kappa {
            // Inertial coupling, solved exactly: each joint is loaded by the other axis's
            // actual CoM acceleration, which itself depends on the load on its own joint
            // (`x_c'' = α + β·ext`, β = the joint's CoM weight over its mass, 0 when stuck).
            let o0 = self.axes[0].eval(x, 0, r[0], 0.0, modes[0], &mut acc[0]);
            let o1 = self.axes[1].eval(x, 1, r[1], 0.0, modes[1], &mut acc[1]);
            let (a0, a1) = (o0.xc_dd, o1.xc_dd);
            let (b0, b1) = (
                self.axes[0].direct_gain(modes[0]),
                self.axes[1].direct_gain(modes[1]),
            );
            let det = 1.0 - k[0] * k[1] * b0 * b1;
            ext = [
                (-k[0] * a1 + k[0] * k[1] * b1 * a0) / det,
                (-k[1] * a0 + k[1] * k[0] * b0 * a1) / det,
            ];
        }
        let mut out = PlantOut::default();
        for a in 0..2 {
            let ax = &self.axes[a];
            out.axis[a] = ax.eval(x, a, r[a], ext[a], modes[a], &mut acc[a]);
            // Nodes beyond `n` never move: their derivatives stay as the caller zeroed them.
            for k in 0..ax.n.min(MAX_NODES) {
                dx[qi(a, k)] = x[vi(a, k)];
                dx[vi(a, k)] = acc[a][k];
            }
            if let (Some(_), FrictionMode::Stick) = (&ax.friction, modes[a]) {
                dx[qi(a, ax.joint)] = 0.0;
            }
        }
        let xc = [out.axis[0].xc, out.axis[1].xc];
        let xdd = [out.axis[0].xc_dd, out.axis[1].xc_dd];
        out.zmp = self.zmp(xc, xdd);
        match self.lowpass {
            Some(wc) => {
                dx[yi(0)] = wc[0] * (out.zmp[0] - x[yi(0)]);
                dx[yi(1)] = wc[1] * (out.zmp[1] - x[yi(1)]);
                dx[ii(0)] = x[yi(0)];
                dx[ii(1)] = x[yi(1)];
            }
            None => {
                dx[yi(0)] = 0.0;
                dx[yi(1)] = 0.0;
                dx[ii(0)] = out.zmp[0];
                dx[ii(1)] = out.zmp[1];
            }
        }
        out
    }

    /// An estimate of the fastest rate of the equations, 1/s, for a stepped sine of
    /// amplitude `a` at `omega` (both axes bounded alike: the coupling is weak).
    pub fn fastest_rate(&self, a: f64, omega: f64) -> f64 {
        let lowpass = self.lowpass.map_or(0.0, |c| c[0].max(c[1]));
        let axes = self
            .axes
            .iter()
            .map(|ax| ax.fastest_rate(ax.force_bound(a, omega)));
        axes.fold(lowpass, f64::max)
    }

    /// The sensor signal at rest at `op` (the static map).
    pub fn rest_zmp(&self, op: [f64; 2]) -> [f64; 2] {
        self.zmp(op, [0.0; 2])
    }

    /// The state at rest at the operating point `op`: every body at `op`, filter settled,
    /// running integrals at 0.
    pub fn rest_state(&self, op: [f64; 2]) -> State {
        let mut x = [0.0; STATE_LEN];
        for a in 0..2 {
            for k in 0..MAX_NODES {
                x[qi(a, k)] = op[a];
            }
        }
        let z = self.zmp(op, [0.0; 2]);
        x[yi(0)] = z[0];
        x[yi(1)] = z[1];
        x
    }
}
