//! Torso Position Control: the online stabiliser the second seed's robot walks with ("legs and
//! waist motions are corrected by a walking stabilization control (Torso Position Control) that
//! is based on the ZMP position", Muscolo et al. section II.B, after the WABIAN-2 papers [9-12]).
//! The seed gives neither the law nor its gains; the form implemented here is ours, of the family
//! of WABIAN-2's ZMP-based waist and trunk corrections and of Kajita et al.'s CoM correction from
//! the ZMP error ("Biped walking stabilization based on linear inverted pendulum tracking",
//! IROS 2010), in its simplest form with gains derived from the cart-table model.
//!
//! **The law.** The torso (the pelvis, "waist" in WABIAN's words) is shifted horizontally by
//! `d = (d_x, d_y)` from the planned motion, with the feet where the plan puts them (the legs
//! absorb the shift). Per axis, every control step `dt`:
//!
//! ```text
//! e   = p_ref - p                       ZMP error: planned minus measured (m)
//! e_f = e_f + dt / tau_f (e - e_f)      first-order low-pass, time constant tau_f
//! d   = clamp(d + dt K e_f, +/- d_max)  integral action, K = 1 / (mu tau_c)
//! ```
//!
//! This is a ZMP-feedback torso position compliance in its integral form: the torso moves until
//! the measured ZMP is, on average, where the plan put it. In statics the ZMP is the CoM's ground
//! projection, so for a model whose CoM is off by `b` the torso settles at `d = b / mu`, with
//! `mu` the CoM's shift per unit torso shift (computed from the planning model's kinematics).
//!
//! **Gains from the physics.** On the cart-table model (ZMP `p = c - c''/w^2`, `w^2 = g/z_c`) a
//! torso shift moves the CoM by `mu d`, and the loop's characteristic equation is
//! `(tau_f - a/w^2) s^2 + s + a = 0` with `a = mu K = 1/tau_c`. Moving the torso quickly shifts
//! the ZMP the other way first (the `- c''/w^2` term), so the loop is stable only if
//! `tau_f > a/w^2`: the low-pass is what keeps the integral from chasing that reaction.
//! [`TorsoParams::design`] makes the loop critically damped, `tau_f - a/w^2 = tau_c/4`, so both
//! poles sit at `-2/tau_c`, and takes `tau_c = 1 s`: the poles at 2 rad/s are below the gait's
//! slowest motion (the lateral sway at half the step rate, 3.3 rad/s), so the control corrects
//! the quasi-static error of the model and leaves each step's sway to the pattern, and a static
//! error is removed to 0.4 % within the seed's 3.84 s still stage (`(1 + 2t/tau_c)
//! e^(-2t/tau_c)`). At SABIAN's 0.64 m CoM height `tau_f` = 0.32 s. `d_max = 5 cm`: within it
//! the legs' linear map of the shift (the twin's implementation) keeps the soles' places and
//! their height difference within 1 mm of the exact inverse kinematics; its second-order error
//! lowers the pelvis by up to 2.5 mm.

/// The controller's parameters (SI).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TorsoParams {
    /// Control period (s).
    pub step_s: f64,
    /// Closed-loop time constant of the integral action, `tau_c` (s).
    pub closed_loop_s: f64,
    /// Time constant of the ZMP error's low-pass, `tau_f` (s).
    pub filter_s: f64,
    /// Largest torso shift per axis (m).
    pub limit_m: f64,
    /// The CoM's shift per unit torso shift, x and y (the planning model's kinematics).
    pub com_per_shift: [f64; 2],
}

/// The closed-loop time constant [`TorsoParams::design`] uses (s).
pub const CLOSED_LOOP_S: f64 = 1.0;
/// The largest torso shift (m).
pub const LIMIT_M: f64 = 0.05;

impl TorsoParams {
    /// The gains of the module's documentation for a CoM height `com_height_m` (m), control
    /// period `step_s` (s) and the CoM's shift per torso shift `com_per_shift`.
    pub fn design(com_height_m: f64, com_per_shift: [f64; 2], step_s: f64) -> TorsoParams {
        let w2 = 9.81 / com_height_m;
        TorsoParams {
            step_s,
            closed_loop_s: CLOSED_LOOP_S,
            // Critical damping: q = tau_f - a/w^2 = tau_c/4.
            filter_s: CLOSED_LOOP_S / 4.0 + 1.0 / (CLOSED_LOOP_S * w2),
            limit_m: LIMIT_M,
            com_per_shift,
        }
    }

    /// The integral gain `K = 1/(mu tau_c)` of each axis (1/s).
    pub fn gain(&self) -> [f64; 2] {
        self.com_per_shift.map(|mu| 1.0 / (mu * self.closed_loop_s))
    }

    /// The stability condition of the cart-table loop, `tau_f > a/w^2`, at `com_height_m`.
    pub fn stable_at(&self, com_height_m: f64) -> bool {
        self.filter_s > com_height_m / (9.81 * self.closed_loop_s)
    }
}

/// The controller's state.
#[derive(Debug, Clone, PartialEq)]
pub struct TorsoControl {
    pub params: TorsoParams,
    filtered: [f64; 2],
    shift: [f64; 2],
    saturated: bool,
}

impl TorsoControl {
    pub fn new(params: TorsoParams) -> TorsoControl {
        TorsoControl {
            params,
            filtered: [0.0; 2],
            shift: [0.0; 2],
            saturated: false,
        }
    }

    /// One control step: the planned and the measured ZMP (m; `None` when the sensors carry no
    /// load, then the filtered error is held). Returns the torso shift (m).
    pub fn update(&mut self, zmp_ref: [f64; 2], zmp: Option<[f64; 2]>) -> [f64; 2] {
        let p = &self.params;
        let k = p.gain();
        let alpha = p.step_s / p.filter_s;
        self.saturated = false;
        for c in 0..2 {
            if let Some(z) = zmp {
                self.filtered[c] += alpha * ((zmp_ref[c] - z[c]) - self.filtered[c]);
            }
            let d = self.shift[c] + p.step_s * k[c] * self.filtered[c];
            self.shift[c] = d.clamp(-p.limit_m, p.limit_m);
            self.saturated |= self.shift[c] != d;
        }
        self.shift
    }

    /// The current torso shift (m).
    pub fn shift(&self) -> [f64; 2] {
        self.shift
    }

    /// Whether the last step hit the limit.
    pub fn saturated(&self) -> bool {
        self.saturated
    }
}

/// How much the control acted over a walk.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Effort {
    /// RMS of the torso shift, x, y and its magnitude (m).
    pub rms_m: [f64; 3],
    /// Largest magnitude of the shift (m).
    pub peak_m: f64,
    /// Integral of the squared magnitude over the walk (m^2 s).
    pub integral_sq_m2s: f64,
    /// Fraction of the steps at the limit.
    pub saturated_fraction: f64,
}

impl Effort {
    /// The mean of several walks' efforts, field by field.
    pub fn mean(efforts: &[Effort]) -> Effort {
        let n = efforts.len().max(1) as f64;
        let avg = |f: &dyn Fn(&Effort) -> f64| efforts.iter().map(f).sum::<f64>() / n;
        Effort {
            rms_m: std::array::from_fn(|k| avg(&|e| e.rms_m[k])),
            peak_m: avg(&|e| e.peak_m),
            integral_sq_m2s: avg(&|e| e.integral_sq_m2s),
            saturated_fraction: avg(&|e| e.saturated_fraction),
        }
    }
}

/// Accumulates a walk's [`Effort`] step by step.
#[derive(Debug, Clone, Default)]
pub struct EffortMeter {
    steps: usize,
    sum_sq: [f64; 2],
    peak: f64,
    saturated: usize,
    step_s: f64,
}

impl EffortMeter {
    pub fn new(step_s: f64) -> EffortMeter {
        EffortMeter {
            step_s,
            ..Default::default()
        }
    }

    pub fn push(&mut self, shift: [f64; 2], saturated: bool) {
        self.steps += 1;
        for c in 0..2 {
            self.sum_sq[c] += shift[c] * shift[c];
        }
        self.peak = self.peak.max(shift[0].hypot(shift[1]));
        self.saturated += saturated as usize;
    }

    pub fn effort(&self) -> Effort {
        let n = self.steps.max(1) as f64;
        let ms = [self.sum_sq[0] / n, self.sum_sq[1] / n];
        Effort {
            rms_m: [ms[0].sqrt(), ms[1].sqrt(), (ms[0] + ms[1]).sqrt()],
            peak_m: self.peak,
            integral_sq_m2s: (self.sum_sq[0] + self.sum_sq[1]) * self.step_s,
            saturated_fraction: self.saturated as f64 / n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cart-table loop of the module's documentation, simulated at the control period: the
    /// real CoM is `mu d - b` (a model off by `b`), its ZMP `c - c''/w^2` (second differences).
    fn simulate(p: &TorsoParams, z: f64, b: f64, seconds: f64) -> Vec<f64> {
        let mut ctl = TorsoControl::new(*p);
        let w2 = 9.81 / z;
        let mu = p.com_per_shift[0];
        let n = (seconds / p.step_s).round() as usize;
        let mut c = vec![-b, -b];
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            let k = c.len();
            let acc = if k < 3 {
                0.0
            } else {
                (c[k - 1] - 2.0 * c[k - 2] + c[k - 3]) / p.step_s.powi(2)
            };
            let zmp = c[k - 1] - acc / w2;
            let d = ctl.update([0.0, 0.0], Some([zmp, 0.0]));
            c.push(mu * d[0] - b);
            out.push(d[0]);
        }
        out
    }

    #[test]
    fn the_loop_is_critically_damped_and_settles_at_b_over_mu() {
        // Hand solution: (tau_f - a/w^2) y'' + y' + a y = a b, y = mu d, y(0) = y'(0) = 0; with
        // the designed filter a double root at -2a: y = b (1 - (1 + 2 a t) e^{-2 a t}).
        let (z, mu, b) = (0.64, 0.62, 0.015);
        let p = TorsoParams::design(z, [mu, mu], 0.001);
        assert!(p.stable_at(z));
        let a = 1.0 / p.closed_loop_s;
        let d = simulate(&p, z, b, 12.0);
        let mut worst: f64 = 0.0;
        for (k, v) in d.iter().enumerate() {
            let t = (k + 1) as f64 * p.step_s;
            let y = b * (1.0 - (1.0 + 2.0 * a * t) * (-2.0 * a * t).exp());
            worst = worst.max((v - y / mu).abs());
        }
        // 1 % of the final shift: the simulation's one-step lags at 1 ms against the
        // continuous-time solution.
        assert!(worst < 0.01 * b / mu, "largest deviation {worst} m");
        assert!((d.last().unwrap() - b / mu).abs() < 1e-6);
        // The seed's 3.84 s still stage removes all but 0.4 % of a static error.
        let at_still_end = d[3839] * mu / b;
        assert!((at_still_end - 0.996).abs() < 0.002, "{at_still_end}");
    }

    #[test]
    fn a_filter_faster_than_the_stability_limit_diverges() {
        let (z, mu, b) = (0.64, 0.62, 0.015);
        let mut p = TorsoParams::design(z, [mu, mu], 0.001);
        p.filter_s = 0.5 * z / (9.81 * p.closed_loop_s);
        p.limit_m = 10.0;
        assert!(!p.stable_at(z));
        let d = simulate(&p, z, b, 3.0);
        assert!(
            d.iter().any(|v| v.abs() > 1.0),
            "expected divergence, largest {}",
            d.iter().fold(0.0f64, |m, v| m.max(v.abs()))
        );
    }

    #[test]
    fn the_shift_is_limited_and_the_effort_accumulates() {
        let p = TorsoParams::design(0.64, [0.6, 0.6], 0.001);
        let mut ctl = TorsoControl::new(p);
        let mut m = EffortMeter::new(p.step_s);
        // A ZMP 1 m behind the plan for long: the shift runs to the limit and stays there.
        for _ in 0..20_000 {
            let d = ctl.update([0.0, 0.0], Some([-1.0, 0.0]));
            m.push(d, ctl.saturated());
        }
        assert_eq!(ctl.shift(), [p.limit_m, 0.0]);
        let e = m.effort();
        assert!(e.saturated_fraction > 0.5 && e.saturated_fraction < 1.0);
        assert_eq!(e.peak_m, p.limit_m);
        assert!(e.rms_m[1] == 0.0 && (e.rms_m[2] - e.rms_m[0]).abs() < 1e-15);
        // Constant shift 0.01 m for 2 s: integral of squares 2e-4 m^2 s, RMS 0.01.
        let mut c = EffortMeter::new(0.001);
        for _ in 0..2000 {
            c.push([0.006, 0.008], false);
        }
        let e = c.effort();
        assert!((e.integral_sq_m2s - 2e-4).abs() < 1e-12 && (e.rms_m[2] - 0.01).abs() < 1e-12);
        // No load: the filtered error is held, the shift keeps integrating it (the same
        // increment again).
        let mut h = TorsoControl::new(p);
        let d1 = h.update([0.01, 0.0], Some([0.0, 0.0]))[0];
        let d2 = h.update([0.0, 0.0], None)[0];
        assert!(d1 > 0.0 && (d2 - 2.0 * d1).abs() < 1e-18, "{d1} {d2}");
    }
}
