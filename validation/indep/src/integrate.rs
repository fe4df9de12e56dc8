//! Time integration: classical RK4 on a fixed grid with exact location of the stick-slip and
//! backlash switching instants, and sampling of the records.
//!
//! * The grid is `t_n = n h`, `h = 1 / (sample_rate · substeps)`, never accumulated; the
//!   samples fall on grid points. The step keeps `λ h ≤ 0.15` for an estimate λ of the
//!   robot's fastest rate (servo, links, contact, Stribeck slope, sensor filter) and is at most
//!   `1 / min_internal_rate_hz` (default 1 kHz): about 1 kHz for the clean robot, 4-7 kHz
//!   with a stiff backlash contact.
//! * The reference `op + A sin(ω (t − τ))` is evaluated exactly at every RK4 stage (the stage
//!   sines come from one `sin_cos` per step rotated by `ωh/2`, exact to rounding). Before the
//!   record starts the robot rests at the operating point, so a delayed command sees `op`
//!   until `t = τ`.
//! * Events: every switching surface of the equations is watched — the sliding velocity of a
//!   friction joint (`sign · v_J`, sliding ends when it crosses 0), the margin of a stuck
//!   joint (`static − |F_other|`, it breaks away when it crosses 0), the play of a
//!   transmission (`|q_D − q_J| − w/2`: the contact force jumps with the flank damper), the
//!   instant the flank damper would start to pull (the force is cut to 0 there: a kink), and
//!   the entry into and exit from the force and velocity limits (kinks). When a step crosses
//!   one, the crossing time is found by bisection on the step length (each trial a fresh RK4
//!   sub-step from the step start) to 1e-12 s, the switch is applied there and the step is
//!   finished from that instant (at most 16 switches per step). Between switches the
//!   right-hand side is smooth, so RK4 keeps its fourth order through saturation, play and
//!   stick-slip alike (the tests check the convergence).
//! * At a stop of a sliding joint the velocity is set to exactly 0 and the joint sticks if
//!   the other forces on it stay within the static level, else slides the other way.
//!
//! # The measurement
//!
//! Each ZMP sample is the **average of the force-sensor signal over the sample interval
//! centred on its time stamp** (an integrating acquisition, time-stamped at mid-interval),
//! computed exactly from a running integral carried by the integrator. It is the acquisition's
//! anti-aliasing: the flank impacts of a play and the jerks of stick-slip put ZMP content far
//! above the Nyquist frequency, which point sampling would fold into the band as a scatter of
//! the first harmonic from period to period (1-2 % in a backlash record at 200 Hz). It has no
//! phase; its gain `sin(ωΔ/2)/(ωΔ/2)` ([`crate::response::sample_average_gain`]) is
//! 1 − 2.3e-4 at 15 rad/s and 200 Hz. Then the drift `rate · t` (the record's own rate for a
//! sensor re-zeroed at every record, `Sensor::record_drift_rate`), the noise and the
//! quantisation are added. The references `x_cr`, `y_cr` are written as commanded, exactly.

use crate::design::{Design, RecordSpec};
use crate::mechanics::{ii, vi, FrictionMode, Plant, PlantOut, State, STATE_LEN};
use crate::noise::MeasurementNoise;
use crate::robot::Robot;

/// Bisection tolerance of a switching instant, s.
const EVENT_TIME_TOL: f64 = 1e-12;
/// Switches handled exactly within one integrator step; more are stepped over.
const MAX_EVENTS_PER_STEP: usize = 16;

/// The true quantities of a record, for tests and plots (never written to a campaign).
#[derive(Clone, Debug, Default)]
pub struct RecordTruth {
    /// CoM position `x_c`, `y_c` at the samples (absolute), m.
    pub com: [Vec<f64>; 2],
    /// CoM acceleration at the samples, m/s².
    pub com_acc: [Vec<f64>; 2],
    /// True ZMP at the samples (before the sensor), m.
    pub zmp: [Vec<f64>; 2],
    /// Sensor reading without random noise and quantisation (sample average, low-pass and
    /// drift in), m.
    pub zmp_noise_free: [Vec<f64>; 2],
    /// Largest |CoM acceleration| seen at any integrator step or sample, per axis, m/s².
    pub max_abs_com_acc: [f64; 2],
    /// Number of switching instants located (stick-slip, backlash contacts).
    pub events: usize,
    /// Integrator steps per sample used.
    pub substeps: usize,
}

/// One simulated record: its design entry, the campaign columns and the truth.
#[derive(Clone, Debug)]
pub struct RecordData {
    /// The design entry (file name, excitation, operating point, steady window).
    pub meta: RecordSpec,
    /// Time since the excitation started, s.
    pub t: Vec<f64>,
    /// CoM reference x (absolute, includes the operating point), m.
    pub x_cr: Vec<f64>,
    /// CoM reference y, m.
    pub y_cr: Vec<f64>,
    /// Measured ZMP x, m.
    pub zmp_x: Vec<f64>,
    /// Measured ZMP y, m.
    pub zmp_y: Vec<f64>,
    /// What the measurement hides.
    pub truth: RecordTruth,
}

/// Simulates every record of the design on the robot.
///
/// # Panics
/// If the robot or the design is invalid (`Robot::validate`, `Design::validate`); use
/// [`try_simulate`] to get the message instead.
pub fn simulate(robot: &Robot, design: &Design) -> Vec<RecordData> {
    try_simulate(robot, design).unwrap_or_else(|e| panic!("simulate: {e}"))
}

/// Simulates every record of the design on the robot; an invalid robot or design is an error
/// naming the field.
pub fn try_simulate(robot: &Robot, design: &Design) -> Result<Vec<RecordData>, String> {
    robot.validate().map_err(|e| format!("robot: {e}"))?;
    design.validate().map_err(|e| format!("design: {e}"))?;
    Ok(simulate_records(robot, design, &design.records()))
}

/// Simulates the given records (normally a subset of `design.records()`), without validation.
pub fn simulate_records(robot: &Robot, design: &Design, specs: &[RecordSpec]) -> Vec<RecordData> {
    let plant = Plant::new(robot);
    specs
        .iter()
        .map(|s| simulate_one(robot, &plant, design, s))
        .collect()
}

/// The stepping machinery of one record.
struct Stepper<'a> {
    plant: &'a Plant,
    op: [f64; 2],
    excited: usize,
    amplitude: f64,
    omega: f64,
    delay: [f64; 2],
    h: f64,
    half_rotation: (f64, f64),
    modes: [FrictionMode; 2],
    events: usize,
    max_acc: [f64; 2],
    scratch: State,
    /// The active branches at the current state, when known.
    branches_now: Option<u32>,
}

impl Stepper<'_> {
    /// The servo references at time `t` (delayed per axis).
    fn servo_ref(&self, t: f64) -> [f64; 2] {
        let mut r = self.op;
        let e = self.excited;
        let td = t - self.delay[e];
        if td > 0.0 {
            r[e] += self.amplitude * (self.omega * td).sin();
        }
        r
    }

    /// Servo references at the three RK4 stage times `t`, `t + dt/2`, `t + dt`.
    fn stage_refs(&self, t: f64, dt: f64) -> [[f64; 2]; 3] {
        let e = self.excited;
        let td0 = t - self.delay[e];
        if td0 < 0.0 {
            return [
                self.servo_ref(t),
                self.servo_ref(t + 0.5 * dt),
                self.servo_ref(t + dt),
            ];
        }
        let (s0, c0) = (self.omega * td0).sin_cos();
        let (sh, ch) = if dt == self.h {
            self.half_rotation
        } else {
            (0.5 * self.omega * dt).sin_cos()
        };
        let s1 = s0 * ch + c0 * sh;
        let c1 = c0 * ch - s0 * sh;
        let s2 = s1 * ch + c1 * sh;
        let mut out = [self.op; 3];
        out[0][e] += self.amplitude * s0;
        out[1][e] += self.amplitude * s1;
        out[2][e] += self.amplitude * s2;
        out
    }

    /// One RK4 step of length `dt` from `(t, x)` in the current modes; also returns the
    /// plant's outputs at the start and the servo references at the end.
    fn rk4(&mut self, t: f64, x: &State, dt: f64) -> (State, PlantOut, [f64; 2]) {
        let r = self.stage_refs(t, dt);
        let p = self.plant;
        let m = self.modes;
        let mut k1 = [0.0; STATE_LEN];
        let mut k2 = [0.0; STATE_LEN];
        let mut k3 = [0.0; STATE_LEN];
        let mut k4 = [0.0; STATE_LEN];
        let mut y = [0.0; STATE_LEN];
        let out0 = p.derivs(x, r[0], &m, &mut k1);
        let hh = 0.5 * dt;
        for i in 0..STATE_LEN {
            y[i] = x[i] + hh * k1[i];
        }
        p.derivs(&y, r[1], &m, &mut k2);
        for i in 0..STATE_LEN {
            y[i] = x[i] + hh * k2[i];
        }
        p.derivs(&y, r[1], &m, &mut k3);
        for i in 0..STATE_LEN {
            y[i] = x[i] + dt * k3[i];
        }
        p.derivs(&y, r[2], &m, &mut k4);
        let d6 = dt / 6.0;
        for i in 0..STATE_LEN {
            y[i] = x[i] + d6 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
        }
        (y, out0, r[2])
    }

    /// The plant's outputs at `(t, x)` in the current modes.
    fn outputs(&mut self, t: f64, x: &State) -> PlantOut {
        let r = self.servo_ref(t);
        self.outputs_with(x, r)
    }

    /// The plant's outputs at state `x` for servo references `r`, in the current modes.
    fn outputs_with(&mut self, x: &State, r: [f64; 2]) -> PlantOut {
        let mut d = self.scratch;
        let out = self.plant.derivs(x, r, &self.modes, &mut d);
        self.scratch = d;
        out
    }

    /// The active branches of both axes' piecewise laws at state `x` for servo references `r`
    /// (see `AxisModel::branches`).
    fn branches(&self, x: &State, r: [f64; 2]) -> u32 {
        let p = self.plant;
        p.axes[0].branches(x, 0, r[0]) | (p.axes[1].branches(x, 1, r[1]) << 8)
    }

    /// `None` if a switching surface lies between the step start (branches `b0`) and the
    /// state `x` (servo references `r`), else the branches at `x`.
    fn crossed(&mut self, x: &State, r: [f64; 2], b0: u32) -> Option<u32> {
        let b = self.branches(x, r);
        if b != b0 {
            return None;
        }
        let mut out = None;
        for a in 0..2 {
            let ax = &self.plant.axes[a];
            let Some(fr) = ax.friction else { continue };
            match self.modes[a] {
                FrictionMode::Slip(s) => {
                    if s * x[vi(a, ax.joint)] < 0.0 {
                        return None;
                    }
                }
                FrictionMode::Stick => {
                    let o = *out.get_or_insert_with(|| self.outputs_with(x, r));
                    if o.axis[a].f_other.abs() > fr.static_level {
                        return None;
                    }
                }
            }
        }
        Some(b)
    }

    /// Applies the friction switches due at `(t, x)`.
    fn switch(&mut self, t: f64, x: &mut State) {
        for a in 0..2 {
            let ax = &self.plant.axes[a];
            let Some(fr) = ax.friction else { continue };
            let j = vi(a, ax.joint);
            match self.modes[a] {
                FrictionMode::Slip(s) => {
                    if s * x[j] <= 0.0 {
                        x[j] = 0.0;
                        let f = self.outputs(t, x).axis[a].f_other;
                        self.modes[a] = if f.abs() <= fr.static_level {
                            FrictionMode::Stick
                        } else {
                            FrictionMode::Slip(f.signum())
                        };
                    }
                }
                FrictionMode::Stick => {
                    let f = self.outputs(t, x).axis[a].f_other;
                    if f.abs() > fr.static_level {
                        self.modes[a] = FrictionMode::Slip(f.signum());
                    }
                }
            }
        }
    }

    fn track(&mut self, out: &PlantOut) {
        for a in 0..2 {
            self.max_acc[a] = self.max_acc[a].max(out.axis[a].xc_dd.abs());
        }
    }

    /// Advances `x` from `t0` to `t1` (one grid step), locating switches.
    fn advance(&mut self, x: &mut State, t0: f64, t1: f64) {
        let mut t = t0;
        let mut switches = 0;
        loop {
            let dt = t1 - t;
            if dt <= 0.0 {
                return;
            }
            let (xn, out0, r_end) = self.rk4(t, x, dt);
            self.track(&out0);
            if switches < MAX_EVENTS_PER_STEP {
                let b0 = match self.branches_now {
                    Some(b) => b,
                    None => self.branches(x, self.servo_ref(t)),
                };
                match self.crossed(&xn, r_end, b0) {
                    Some(b_end) => self.branches_now = Some(b_end),
                    None => {
                        let (mut lo, mut hi) = (0.0, dt);
                        while hi - lo > EVENT_TIME_TOL {
                            let mid = 0.5 * (lo + hi);
                            let (xm, _, rm) = self.rk4(t, x, mid);
                            if self.crossed(&xm, rm, b0).is_none() {
                                hi = mid;
                            } else {
                                lo = mid;
                            }
                        }
                        let (xh, _, _) = self.rk4(t, x, hi);
                        *x = xh;
                        t += hi;
                        self.switch(t, x);
                        self.branches_now = None;
                        switches += 1;
                        self.events += 1;
                        continue;
                    }
                }
            } else {
                self.branches_now = None;
            }
            *x = xn;
            return;
        }
    }
}

fn simulate_one(robot: &Robot, plant: &Plant, design: &Design, spec: &RecordSpec) -> RecordData {
    let fs = design.sample_rate_hz;
    // An even number of steps per sample puts the half-sample instants on the grid.
    let sub = design
        .substeps_for(plant.fastest_rate(spec.amplitude, spec.omega))
        .div_ceil(2)
        * 2;
    let h = 1.0 / (fs * sub as f64);
    let e = spec.excited.index();
    let mut st = Stepper {
        plant,
        op: spec.operating_point,
        excited: e,
        amplitude: spec.amplitude,
        omega: spec.omega,
        delay: [plant.axes[0].delay, plant.axes[1].delay],
        h,
        half_rotation: (0.5 * spec.omega * h).sin_cos(),
        modes: [FrictionMode::Stick; 2],
        events: 0,
        max_acc: [0.0; 2],
        scratch: [0.0; STATE_LEN],
        branches_now: None,
    };
    for (a, m) in st.modes.iter_mut().enumerate() {
        if plant.axes[a].friction.is_none() {
            *m = FrictionMode::Slip(1.0); // unused without friction
        }
    }
    let noise_law = design.noise_for(&robot.sensor.noise);
    let mut noise = MeasurementNoise::new(
        &noise_law,
        design.quantisation,
        1.0 / fs,
        design.seed,
        spec.index,
    );
    let drift = robot.sensor.record_drift_rate(spec.index);
    let n = spec.n_samples;
    let mut rec = RecordData {
        meta: spec.clone(),
        t: Vec::with_capacity(n),
        x_cr: Vec::with_capacity(n),
        y_cr: Vec::with_capacity(n),
        zmp_x: Vec::with_capacity(n),
        zmp_y: Vec::with_capacity(n),
        truth: RecordTruth {
            substeps: sub,
            ..RecordTruth::default()
        },
    };
    let mut x = plant.rest_state(spec.operating_point);
    // Running integral of the sensor signal at the half-sample instants (k − 1/2) Δ; before
    // t = 0 the robot rests, so the first one is extrapolated from the rest value.
    let dt_sample = 1.0 / fs;
    let rest = plant.rest_zmp(spec.operating_point);
    let mut half_integrals = Vec::with_capacity(n + 1);
    half_integrals.push([-0.5 * dt_sample * rest[0], -0.5 * dt_sample * rest[1]]);
    let half = sub / 2;
    for k in 0..n {
        let t = k as f64 / fs;
        let out = st.outputs(t, &x);
        st.track(&out);
        let mut reference = spec.operating_point;
        reference[e] += spec.amplitude * (spec.omega * t).sin();
        let tr = &mut rec.truth;
        for i in 0..2 {
            tr.com[i].push(out.axis[i].xc);
            tr.com_acc[i].push(out.axis[i].xc_dd);
            tr.zmp[i].push(out.zmp[i]);
        }
        rec.t.push(t);
        rec.x_cr.push(reference[0]);
        rec.y_cr.push(reference[1]);
        // Advance to the next half-sample instant (and on to the next sample).
        for s in 0..sub {
            if k + 1 == n && s == half {
                break;
            }
            if s == half {
                half_integrals.push([x[ii(0)], x[ii(1)]]);
            }
            let step = (k * sub + s) as f64;
            st.advance(&mut x, step * h, (step + 1.0) * h);
        }
    }
    half_integrals.push([x[ii(0)], x[ii(1)]]);
    // Each sample is the average of the sensor signal over the sample interval centred on
    // its time stamp, plus the drift, the noise and the quantisation.
    for k in 0..n {
        let t = rec.t[k];
        let nz = noise.next();
        let mut measured = [0.0; 2];
        for i in 0..2 {
            let average = (half_integrals[k + 1][i] - half_integrals[k][i]) / dt_sample;
            let clean = average + drift[i] * t;
            rec.truth.zmp_noise_free[i].push(clean);
            measured[i] = noise.quantise(clean + nz[i]);
        }
        rec.zmp_x.push(measured[0]);
        rec.zmp_y.push(measured[1]);
    }
    rec.truth.max_abs_com_acc = st.max_acc;
    rec.truth.events = st.events;
    rec
}
