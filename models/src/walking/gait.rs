//! The second seed's gait: 128 still phases, 8 steps along x (first and last 20 cm, the others
//! 40 cm, right foot first), 128 still phases, 0.03 s per phase (0.96 s per step).
//!
//! "Step of 40 cm" is read as the stride of the moving foot: it lands 20 cm ahead of the other
//! one, so the feet advance 20 cm apart each step and both end side by side 1.4 m ahead. Each step
//! starts with a double-support phase in which the reference ZMP moves linearly from the old
//! stance foot to the new one; the swing foot then moves (quintic in x, a sine arch in z). The
//! final still stage starts with the ZMP moving back to the middle of the feet.

/// Left or right.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The left foot.
    Left,
    /// The right foot.
    Right,
}

/// A foot's sole position (centre of the sole's bottom, m); soles stay level and face +x.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FootPose {
    /// Forward position, m.
    pub x: f64,
    /// Lateral position, m.
    pub y: f64,
    /// Height, m.
    pub z: f64,
}

/// The gait's parameters (SI).
#[derive(Debug, Clone, PartialEq)]
pub struct Gait {
    /// Duration of one phase (s).
    pub phase_s: f64,
    /// Still phases before and after the steps.
    pub still_phases: usize,
    /// Phases per step.
    pub phases_per_step: usize,
    /// The moving foot's stride, step by step (m).
    pub strides_m: Vec<f64>,
    /// Which foot moves first.
    pub first_swing: Side,
    /// Lateral distance between the feet's centres (m).
    pub foot_spacing_m: f64,
    /// Fraction of each step in double support.
    pub double_support_fraction: f64,
    /// Swing foot clearance (m).
    pub lift_m: f64,
    /// Duration of the return of the ZMP to the middle at the end (s).
    pub final_shift_s: f64,
}

impl Gait {
    /// The seed's gait with the twin's foot spacing.
    pub fn seed(foot_spacing_m: f64) -> Gait {
        let mut strides = vec![0.4; 8];
        strides[0] = 0.2;
        strides[7] = 0.2;
        Gait {
            phase_s: 0.03,
            still_phases: 128,
            phases_per_step: 32,
            strides_m: strides,
            first_swing: Side::Right,
            foot_spacing_m,
            double_support_fraction: 0.2,
            lift_m: 0.04,
            final_shift_s: 0.6,
        }
    }

    /// Duration of one step, s.
    pub fn step_s(&self) -> f64 {
        self.phase_s * self.phases_per_step as f64
    }

    /// When the first step starts (after the still phases), s.
    pub fn start_s(&self) -> f64 {
        self.phase_s * self.still_phases as f64
    }

    /// Duration of the whole walk, still phases at both ends included, s.
    pub fn duration_s(&self) -> f64 {
        self.phase_s * (2 * self.still_phases + self.phases_per_step * self.strides_m.len()) as f64
    }

    /// Foot positions before step `k` (k = 0 .. steps), left then right.
    fn feet_before(&self, k: usize) -> [FootPose; 2] {
        let mut x = [0.0, 0.0];
        let mut side = self.first_swing;
        for s in &self.strides_m[..k] {
            let i = usize::from(side == Side::Right);
            x[i] += s;
            side = if side == Side::Left {
                Side::Right
            } else {
                Side::Left
            };
        }
        let y = self.foot_spacing_m / 2.0;
        [
            FootPose { x: x[0], y, z: 0.0 },
            FootPose {
                x: x[1],
                y: -y,
                z: 0.0,
            },
        ]
    }

    fn swing_side(&self, k: usize) -> Side {
        if k.is_multiple_of(2) == (self.first_swing == Side::Right) {
            Side::Right
        } else {
            Side::Left
        }
    }

    /// The plan at time `t` (s).
    pub fn sample(&self, t: f64) -> GaitSample {
        let steps = self.strides_m.len();
        let t_step = self.step_s();
        let t0 = self.start_s();
        let mid = |f: &[FootPose; 2]| ((f[0].x + f[1].x) / 2.0, (f[0].y + f[1].y) / 2.0);
        if t < t0 {
            let f = self.feet_before(0);
            let (x, y) = mid(&f);
            return GaitSample {
                feet: f,
                zmp_ref: [x, y],
                support: [true, true],
            };
        }
        let k = ((t - t0) / t_step).floor() as usize;
        if k >= steps {
            let f = self.feet_before(steps);
            let last_stance =
                self.feet_before(steps - 1)[usize::from(self.swing_side(steps - 1) == Side::Left)];
            let (mx, my) = mid(&f);
            let s = ((t - t0 - steps as f64 * t_step) / self.final_shift_s).clamp(0.0, 1.0);
            let s = smooth(s);
            return GaitSample {
                feet: f,
                zmp_ref: [
                    last_stance.x + (mx - last_stance.x) * s,
                    last_stance.y + (my - last_stance.y) * s,
                ],
                support: [true, true],
            };
        }
        let tau = (t - t0 - k as f64 * t_step) / t_step;
        let before = self.feet_before(k);
        let after = self.feet_before(k + 1);
        let swing = usize::from(self.swing_side(k) == Side::Right);
        let stance = 1 - swing;
        // ZMP: from the previous stance foot (the middle before the first step) to this one.
        let from = if k == 0 {
            let (x, y) = mid(&before);
            FootPose { x, y, z: 0.0 }
        } else {
            before[swing]
        };
        let to = before[stance];
        let ds = self.double_support_fraction;
        let mut feet = before;
        let (zmp, support) = if tau < ds {
            let s = tau / ds;
            (
                [from.x + (to.x - from.x) * s, from.y + (to.y - from.y) * s],
                [true, true],
            )
        } else {
            let s = (tau - ds) / (1.0 - ds);
            let e = quintic(s);
            feet[swing].x = before[swing].x + (after[swing].x - before[swing].x) * e;
            feet[swing].z = self.lift_m * (std::f64::consts::PI * s).sin();
            let mut sup = [true, true];
            sup[swing] = false;
            ([to.x, to.y], sup)
        };
        GaitSample {
            feet,
            zmp_ref: zmp,
            support,
        }
    }
}

fn quintic(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
}

fn smooth(s: f64) -> f64 {
    quintic(s)
}

/// The plan at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaitSample {
    /// Left, right sole.
    pub feet: [FootPose; 2],
    /// Reference ZMP (m).
    pub zmp_ref: [f64; 2],
    /// Whether each foot is on the ground.
    pub support: [bool; 2],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_seeds_gait_has_its_phases_and_distances() {
        let g = Gait::seed(0.16);
        assert!((g.step_s() - 0.96).abs() < 1e-12);
        assert!((g.duration_s() - 512.0 * 0.03).abs() < 1e-9);
        // Both feet end 1.4 m ahead, side by side, the ZMP between them.
        let end = g.sample(g.duration_s());
        assert!((end.feet[0].x - 1.4).abs() < 1e-12 && (end.feet[1].x - 1.4).abs() < 1e-12);
        assert!((end.zmp_ref[0] - 1.4).abs() < 1e-12 && end.zmp_ref[1].abs() < 1e-12);
        // The right foot moves first; mid-swing it is lifted and the ZMP sits on the left foot.
        let s = g.sample(g.start_s() + 0.6 * 0.96);
        assert_eq!(s.support, [true, false]);
        assert!(s.feet[1].z > 0.03 && s.feet[0].z == 0.0);
        assert_eq!(s.zmp_ref, [0.0, 0.08]);
        // Each step advances the stance by 20 cm.
        let s3 = g.sample(g.start_s() + 3.6 * 0.96);
        assert!((s3.zmp_ref[0] - 0.6).abs() < 1e-12, "{:?}", s3.zmp_ref);
        // The ZMP reference is continuous.
        let mut prev = g.sample(0.0).zmp_ref;
        let mut t = 0.0;
        while t < g.duration_s() {
            let z = g.sample(t).zmp_ref;
            assert!(
                (z[0] - prev[0]).abs() < 0.01 && (z[1] - prev[1]).abs() < 0.01,
                "{t}"
            );
            prev = z;
            t += 0.005;
        }
    }
}
