//! The 2×2 ZMP plant composed from a model file: inputs the CoM references `x_cr, y_cr`,
//! outputs the ZMP `zmp_x, zmp_y` and the CoM `x_c, y_c`.
//!
//! The plant acts on absolute values: at rest, `zmp_i = sum_j a_ij x_cj` (plus sensor offsets);
//! its small-signal model around any operating point is the seed's `G_ZMP`. One call of
//! [`Plant::step`] advances one fixed internal step `h`, the inputs moving linearly from the
//! previous call's values (first-order hold); [`Plant::step_from`] also lets them jump at the
//! step's start, and [`Plant::advance`] holds them constant (zero-order hold, what a digital
//! controller's output or an FMI communication step gives). None of them allocates.
//!
//! Exactness: the servo (tracking low-pass) and the pendulum are discretised exactly for any
//! input that ramps between steps and jumps at them, so the seed's nominal `G_ZMP` is stepped
//! exactly under both holds. Blocks after the pendulum (uncertainty, sensor filters) see their
//! input as a ramp between steps, the jump of the pendulum's output included, which is exact to
//! second order in the step.

use crate::axis::{Axis, Channel};
use crate::effect::{Binding, BuildContext, Effect, Site};
use crate::effects::pendulum::Pendulum;
use crate::effects::servo::Servo;
use crate::effects::servo_link::TrunkLink;
use crate::effects::tracking_lowpass::TrackingLowpass;
use crate::harmonic::steady_first_harmonics;
use crate::model_file::{ModelError, ModelSpec};
use crate::EffectKind;
use num_complex::Complex64;

mod response;

/// Default internal step of the plant, s.
pub const DEFAULT_STEP: f64 = 1e-3;

/// Longest wait for a periodic steady state in [`Plant::simulated_response`], in periods and
/// in steps, beyond the linear settling time.
pub const MAX_SETTLE_PERIODS: usize = 2000;
pub const MAX_SETTLE_STEPS: usize = 4_000_000;

/// What the plant gives after a step.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PlantOutput {
    /// Measured ZMP `[zmp_x, zmp_y]`, m.
    pub zmp: [f64; 2],
    /// CoM `[x_c, y_c]`, m.
    pub com: [f64; 2],
    /// CoM acceleration, m/s².
    pub com_acceleration: [f64; 2],
}

type Chain = Vec<Box<dyn Effect>>;

#[derive(Debug)]
pub struct Plant {
    h: f64,
    command: [Chain; 2],
    servo: [Servo; 2],
    servo_limits: [Chain; 2],
    /// A flexible trunk inside an axis's servo loop (`in_servo = 1`): the servo steps it, the
    /// chain only gives its linear frequency response.
    in_loop: [Chain; 2],
    lowpass: [TrackingLowpass; 2],
    pendulum: Pendulum,
    pendulum_mods: Chain,
    channel: [[Chain; 2]; 2],
    sensor: [Chain; 2],
    operating_point: [f64; 2],
    /// Static pendulum gains at the operating point: the ZMP at rest is `a op`.
    a: [[f64; 2]; 2],
    /// Small-signal pendulum gains at the operating point (the slope of the static ZMP, see
    /// [`Plant::set_operating_point`]); equal to `a` without a position-dependent modifier.
    a_lin: [[f64; 2]; 2],
    /// `(a - a_lin) op`: a channel's pendulum term is `a_lin x_c + a_off - b x_c''`.
    a_off: [[f64; 2]; 2],
    b: [[f64; 2]; 2],
    last: PlantOutput,
    /// The CoM reference at the end of the last step.
    last_ref: [f64; 2],
    /// Output of each channel chain at the end of the last step.
    channel_out: [[f64; 2]; 2],
}

/// One step of a chain whose input may jump at the step's start (see [`Effect::step_span`]).
#[inline]
fn run_chain(chain: &mut Chain, mut jump: Option<f64>, mut u: f64) -> (Option<f64>, f64) {
    for e in chain.iter_mut() {
        (jump, u) = e.step_span(jump, u);
    }
    (jump, u)
}

fn reset_chain(chain: &mut Chain, mut u: f64) -> f64 {
    for e in chain.iter_mut() {
        u = e.reset(u);
    }
    u
}

impl Plant {
    /// Builds the plant of `spec` with internal step `h` (s).
    pub fn new(spec: &ModelSpec, h: f64) -> Result<Plant, ModelError> {
        let file = spec.name.clone().unwrap_or_else(|| "model".into());
        spec.validate(&file)?;
        if !(h > 0.0 && h <= 0.1) {
            return Err(ModelError {
                file,
                key: "step".into(),
                message: format!("internal step {h} s must be in (0, 0.1]"),
            });
        }
        let pendulum = Pendulum::from_values(
            &spec
                .get(EffectKind::Pendulum, Binding::Global)
                .expect("validated")
                .values,
        );
        let lp = |a: Axis| {
            let v = &spec
                .get(EffectKind::TrackingLowpass, Binding::Axis(a))
                .expect("validated")
                .values;
            TrackingLowpass {
                omega_n: v[0],
                zeta: v[1],
            }
        };
        let lowpass = [lp(Axis::X), lp(Axis::Y)];
        // A flexible trunk with `in_servo = 1` is stepped inside its axis's servo loop (where a
        // force limit or friction acts on the force that drives the joint against the link);
        // otherwise it is the small-signal filter of the CoM reference before the servo.
        // A backlash with `in_servo = 1` is the play of such a link between drive and trunk.
        let trunk = Axis::BOTH.map(|a| {
            let v = &spec
                .get(EffectKind::FlexibleTrunk, Binding::Axis(a))?
                .values;
            let link = TrunkLink::flexible(
                v[0],
                v[1],
                v.get(2).copied().unwrap_or(0.5),
                v.get(3).copied().unwrap_or(0.0),
            );
            (v.get(4) == Some(&1.0) && link.share > 0.0).then_some(link)
        });
        let play = Axis::BOTH.map(|a| {
            crate::effects::backlash::servo_link(
                &spec.get(EffectKind::Backlash, Binding::Axis(a))?.values,
            )
        });
        let mut link = [None; 2];
        for a in Axis::BOTH {
            let k = a.index();
            link[k] = match (trunk[k], play[k]) {
                (Some(_), Some(_)) => {
                    return Err(ModelError {
                        file,
                        key: format!("backlash.{}.in_servo", a.name()),
                        message: "a servo drives one link: a backlash inside the servo and a \
                                  flexible trunk inside it on the same axis are not supported \
                                  (set one of them in_servo = 0)"
                            .into(),
                    })
                }
                (t, p) => t.or(p),
            };
        }
        let servo = |k: usize| {
            let s = Servo::new(lowpass[k].omega_n, lowpass[k].zeta, h);
            match link[k] {
                Some(l) => s.with_link(l),
                None => s,
            }
        };
        let mut plant = Plant {
            h,
            command: [Vec::new(), Vec::new()],
            servo: [servo(0), servo(1)],
            servo_limits: [Vec::new(), Vec::new()],
            in_loop: [Vec::new(), Vec::new()],
            lowpass,
            pendulum,
            pendulum_mods: Vec::new(),
            channel: [[Vec::new(), Vec::new()], [Vec::new(), Vec::new()]],
            sensor: [Vec::new(), Vec::new()],
            operating_point: [0.0; 2],
            a: pendulum.a,
            a_lin: pendulum.a,
            a_off: [[0.0; 2]; 2],
            b: pendulum.b,
            last: PlantOutput::default(),
            last_ref: [0.0; 2],
            channel_out: [[0.0; 2]; 2],
        };
        for inst in spec.effects.iter().filter(|e| !e.info.core) {
            if inst.info.kind == EffectKind::TimeDelay
                && inst.values[0] / h > crate::effects::time_delay::MAX_DELAY_STEPS
            {
                return Err(ModelError {
                    file,
                    key: format!("{}.delay", inst.key()),
                    message: format!(
                        "a delay of {} s at an internal step of {h} s needs {:.3e} stored \
                         steps; at most {:.0e} (use a longer step)",
                        inst.values[0],
                        inst.values[0] / h,
                        crate::effects::time_delay::MAX_DELAY_STEPS
                    ),
                });
            }
            let servo = match inst.binding {
                Binding::Axis(a) => Some((lowpass[a.index()].omega_n, lowpass[a.index()].zeta)),
                _ => None,
            };
            let in_loop = match inst.binding {
                Binding::Axis(a) => link[a.index()],
                _ => None,
            };
            let ctx = BuildContext {
                h,
                binding: inst.binding,
                servo,
                link: in_loop,
            };
            let effect = inst.build(&ctx);
            match (inst.info.site, inst.binding) {
                (Site::Command, Binding::Axis(a))
                    if (inst.info.kind == EffectKind::FlexibleTrunk
                        && trunk[a.index()].is_some())
                        || (inst.info.kind == EffectKind::Backlash
                            && play[a.index()].is_some()) =>
                {
                    plant.in_loop[a.index()].push(effect)
                }
                (Site::Command, Binding::Axis(a)) => plant.command[a.index()].push(effect),
                (Site::Servo, Binding::Axis(a)) => plant.servo_limits[a.index()].push(effect),
                (Site::Pendulum, _) => plant.pendulum_mods.push(effect),
                (Site::Channel, Binding::Channel(c)) => {
                    plant.channel[c.output.index()][c.input.index()].push(effect)
                }
                (Site::Sensor, Binding::Axis(a)) => plant.sensor[a.index()].push(effect),
                _ => {
                    return Err(ModelError {
                        file,
                        key: inst.key(),
                        message: "effect bound to a place its site does not have".into(),
                    })
                }
            }
        }
        for a in Axis::BOTH {
            let longest = crate::effects::servo::max_step(&plant.servo_limits[a.index()]);
            if h > longest {
                return Err(ModelError {
                    file,
                    key: format!("coulomb_friction.{}.v_s", a.name()),
                    message: format!(
                        "the friction's regularisation (level / v_s) is too stiff for the \
                         internal step {h} s: at most {longest:.3e} s, or a larger v_s"
                    ),
                });
            }
        }
        plant.set_operating_point([0.0, 0.0]);
        plant.reset([0.0, 0.0]);
        Ok(plant)
    }

    pub fn step_size(&self) -> f64 {
        self.h
    }

    pub fn pendulum(&self) -> &Pendulum {
        &self.pendulum
    }

    pub fn tracking_lowpass(&self, input: Axis) -> &TrackingLowpass {
        &self.lowpass[input.index()]
    }

    /// The operating point `[x, y]` (m) that operating-point-dependent effects see.
    ///
    /// Pendulum modifiers scale `a` by `s(x_c)` and `b` by `t(x_c)` at the CoM position; the
    /// plant linearises `zmp_i = s(x_c) sum_j a_ij x_cj` about `op`: at rest the ZMP is
    /// `s(op) a op`, and a motion `dx_j` moves it by the slope of that static map,
    /// `a_ij s(op) + ds/dx_j (a op)_i` (exact for the first harmonic: the rest of a square
    /// term is a mean shift and a second harmonic). `b` multiplies the acceleration, zero at
    /// rest, so its small-signal gain is `b_ij t(op)`.
    pub fn set_operating_point(&mut self, op: [f64; 2]) {
        self.operating_point = op;
        let (mut sa, mut sb) = (1.0, 1.0);
        let mut grad = [0.0; 2];
        for m in &self.pendulum_mods {
            let (a, b) = m.pendulum_scale(op);
            let g = m.pendulum_scale_gradient(op);
            // Product rule: d(sa a)/dx = g sa + a d(sa)/dx.
            for k in 0..2 {
                grad[k] = grad[k] * a + g[k] * sa;
            }
            sa *= a;
            sb *= b;
        }
        let a0 = self.pendulum.a;
        for i in 0..2 {
            let static_i = a0[i][0] * op[0] + a0[i][1] * op[1];
            for j in 0..2 {
                self.a[i][j] = a0[i][j] * sa;
                self.a_lin[i][j] = a0[i][j] * sa + grad[j] * static_i;
                self.a_off[i][j] = (self.a[i][j] - self.a_lin[i][j]) * op[j];
                self.b[i][j] = self.pendulum.b[i][j] * sb;
            }
        }
    }

    pub fn operating_point(&self) -> [f64; 2] {
        self.operating_point
    }

    /// The pendulum coefficients `(a, b)` at the operating point (rescaled by the pendulum
    /// modifiers): the static relation, the ZMP at rest is `a op`.
    pub fn pendulum_at_operating_point(&self) -> ([[f64; 2]; 2], [[f64; 2]; 2]) {
        (self.a, self.b)
    }

    /// The small-signal pendulum gains `(a, b)` at the operating point: what a small sine
    /// about it sees (`a` differs from the static one where the coefficients move with the
    /// CoM position; see [`Plant::set_operating_point`]).
    pub fn pendulum_gain_at_operating_point(&self) -> ([[f64; 2]; 2], [[f64; 2]; 2]) {
        (self.a_lin, self.b)
    }

    /// Puts the whole plant at rest for the constant CoM reference `com_ref`.
    pub fn reset(&mut self, com_ref: [f64; 2]) -> PlantOutput {
        let mut com = [0.0; 2];
        for j in 0..2 {
            let r = reset_chain(&mut self.command[j], com_ref[j]);
            self.servo[j].reset(r);
            for l in self.servo_limits[j].iter_mut() {
                l.reset(r);
            }
            com[j] = r;
        }
        let mut zmp = [0.0; 2];
        for i in 0..2 {
            let mut z = 0.0;
            for j in 0..2 {
                self.channel_out[i][j] = reset_chain(
                    &mut self.channel[i][j],
                    self.a_lin[i][j] * com[j] + self.a_off[i][j],
                );
                z += self.channel_out[i][j];
            }
            zmp[i] = reset_chain(&mut self.sensor[i], z);
        }
        self.last_ref = com_ref;
        self.last = PlantOutput {
            zmp,
            com,
            com_acceleration: [0.0; 2],
        };
        self.last
    }

    /// Advances one internal step; `com_ref` has moved linearly from the previous value
    /// (first-order hold).
    #[inline]
    pub fn step(&mut self, com_ref: [f64; 2]) -> PlantOutput {
        self.step_from(self.last_ref, com_ref)
    }

    /// Advances one internal step with the CoM reference moving linearly from `start` (its
    /// value just after the step's beginning: a jump where it differs from the previous step's
    /// end) to `end`. `step_from(u, u)` holds `u` over the step (zero-order hold).
    #[inline]
    pub fn step_from(&mut self, start: [f64; 2], end: [f64; 2]) -> PlantOutput {
        let mut com = [0.0; 2];
        let mut acc = [0.0; 2];
        // Pendulum output of an input axis just after a jump of its servo's acceleration.
        let mut acc_start = [None; 2];
        for j in 0..2 {
            let jump = (start[j] != self.last_ref[j]).then_some(start[j]);
            let (jump, r) = run_chain(&mut self.command[j], jump, end[j]);
            let (a0, s) = self.servo[j].step_span(jump, r, &mut self.servo_limits[j]);
            acc_start[j] = a0;
            com[j] = s.position;
            acc[j] = s.acceleration;
        }
        let com_start = self.last.com;
        let mut zmp = [0.0; 2];
        for i in 0..2 {
            let (mut z, mut z_start, mut jumped) = (0.0, 0.0, false);
            for j in 0..2 {
                let (a, a_off, b) = (self.a_lin[i][j], self.a_off[i][j], self.b[i][j]);
                let p = a * com[j] + a_off - b * acc[j];
                let p_start = acc_start[j].map(|a0| a * com_start[j] + a_off - b * a0);
                let (c_start, c) = run_chain(&mut self.channel[i][j], p_start, p);
                jumped |= c_start.is_some();
                z_start += c_start.unwrap_or(self.channel_out[i][j]);
                self.channel_out[i][j] = c;
                z += c;
            }
            zmp[i] = run_chain(&mut self.sensor[i], jumped.then_some(z_start), z).1;
        }
        self.last_ref = end;
        #[cfg(feature = "bench-planted-regression")]
        planted_regression();
        self.last = PlantOutput {
            zmp,
            com,
            com_acceleration: acc,
        };
        self.last
    }

    /// Advances `n` internal steps with the reference held at `com_ref` from the start
    /// (zero-order hold: a jump to `com_ref` now, constant after).
    pub fn advance(&mut self, com_ref: [f64; 2], n: usize) -> PlantOutput {
        for _ in 0..n {
            self.step_from(com_ref, com_ref);
        }
        self.last
    }

    /// The CoM reference at the end of the last step (or of the reset), m.
    pub fn last_reference(&self) -> [f64; 2] {
        self.last_ref
    }

    pub fn last_output(&self) -> PlantOutput {
        self.last
    }
}

/// Test-only extra work in [`Plant::step`] (feature `bench-planted-regression`): a chain of
/// additions that the optimiser cannot remove, about 6 % of the all-effects step's instructions,
/// for the test that the instruction-count gate of `cargo xtask bench` fails on it. Does not
/// touch the plant's state or output.
#[cfg(feature = "bench-planted-regression")]
#[inline(never)]
fn planted_regression() {
    let mut w = 0.0_f64;
    for k in 0..PLANTED_ADDITIONS {
        w = std::hint::black_box(w + k as f64);
    }
    std::hint::black_box(w);
}

/// Iterations of [`planted_regression`]'s loop (38: about 5 % of the all-effects step with
/// `flexible_trunk` in it; 22 gave 2.9 %, 30 gave 3.9 %, measured by `xtask/tests/bench_gate.rs`).
#[cfg(feature = "bench-planted-regression")]
const PLANTED_ADDITIONS: usize = 38;
