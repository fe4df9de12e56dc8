//! The law that ties the time-domain plant to its frequency response: driven by a sine, the
//! stepper's steady state has the first harmonic `G(j omega)` (magnitude within 0.5 %, phase
//! within 0.5 degrees), on all four channels, for random stable linear models.
//!
//! How the stepper is driven, and why the comparison is fair:
//!
//! - The plant is first-order hold: between two calls its input moves linearly, and its
//!   discretisation is exact for such piecewise-linear inputs. We evaluate the sine at every
//!   internal step, so the plant sees the polyline through the samples, not the sine itself.
//! - The internal step `h` is chosen per case so that `omega <= pi/(20 h)`: the excitation lies
//!   inside the Nyquist band of a data rate 20 times below the internal rate, as a recorded
//!   campaign would (data at 50 Hz, plant at 1 kHz).
//! - The polyline differs from the sine by `O((omega h)^2)`: its first harmonic is scaled by
//!   `sinc^2(omega h / 2)` and it carries images at `omega + m 2 pi/h`, which the sampled output
//!   folds back onto `omega`. For a block `F` with feedthrough the resulting relative error is
//!   about `(omega h)^2/12 * |F(j(omega + m 2pi/h)) - F(j omega)| / |F(j omega)|`, which is large
//!   when `F(j omega)` is small next to the feedthrough (the pendulum's `-b omega_n^2` at low
//!   frequency). Each first-order-hold stage (servo + pendulum, each channel effect, each sensor
//!   effect) adds such a term, and a fractional time delay adds `(omega h)^2/8`. We shrink `h`
//!   below `pi/(20 omega)` until the sum of these predicted errors is under 0.1 %, a fifth of the
//!   tolerance, so a failure means a bug and not discretisation.
//! - The transient is gone after `(10 + ln(1 + R)) * plant.slowest_time_constant()` plus the
//!   delay, `R` the largest feedthrough-to-response ratio: the start-up transient can be `R` times
//!   the steady response. The first harmonic is fitted over whole periods after that.
//! - The parameter ranges keep `G_ij(j omega)` away from cancellations (a relative tolerance means
//!   nothing at a zero of `G`): the off-diagonal `a_ij` and `b_ij` share their sign (negative
//!   coupling included), and the uncertainty has `|W Delta| <= 0.8` so `|1 + W Delta| >= 0.2`.

// Index loops read as the matrix algebra they check.
#![allow(clippy::needless_range_loop)]

use num_complex::Complex64;
use proptest::prelude::*;
use std::f64::consts::PI;
use zmp_models::effects::{sensor_lowpass, structural_mode, uncertainty};
use zmp_models::harmonic::first_harmonic;
use zmp_models::model_file::fmt_float;
use zmp_models::EffectKind;
use zmp_models::{Axis, ModelSpec, Plant};

const TOL_MAG: f64 = 0.005;
const TOL_PHASE_DEG: f64 = 0.5;
/// Budget for the predicted discretisation error, relative.
const DISCRETISATION_BUDGET: f64 = 1e-3;
const AMPLITUDE: f64 = 0.01;

#[derive(Debug, Clone, Copy)]
struct Unc {
    k: f64,
    z: f64,
    p: f64,
    delta: f64,
    seed: u64,
}

impl Unc {
    fn values(&self) -> [f64; 5] {
        [self.k, self.z, self.p, self.delta, self.seed as f64]
    }
}

#[derive(Debug, Clone)]
struct Case {
    a: [[f64; 2]; 2],
    b: [[f64; 2]; 2],
    /// Per input axis `(omega_n, zeta)`.
    lowpass: [(f64, f64); 2],
    /// Per output axis cutoff.
    sensor_lowpass: Option<[f64; 2]>,
    /// Per output axis `(omega_n, zeta)`.
    structural_mode: Option<[(f64, f64); 2]>,
    /// Per input axis delay, s.
    delay: Option<[f64; 2]>,
    uncertainty: Option<[[Unc; 2]; 2]>,
    /// `(da_dx, da_dy, db_dx, db_dy)` and the operating point.
    operating_point: Option<([f64; 4], [f64; 2])>,
    omega: f64,
}

const AX: [&str; 2] = ["x", "y"];
const CH: [[&str; 2]; 2] = [["G11", "G12"], ["G21", "G22"]];

impl Case {
    fn to_toml(&self) -> String {
        let f = |v: f64| fmt_float(v);
        let mut s =
            String::from("format = \"zmp-model/1\"\nname = \"proptest case\"\n[pendulum]\n");
        for i in 0..2 {
            for j in 0..2 {
                s += &format!("a{}{} = {}\n", i + 1, j + 1, f(self.a[i][j]));
                s += &format!("b{}{} = {}\n", i + 1, j + 1, f(self.b[i][j]));
            }
        }
        for (j, (wn, zeta)) in self.lowpass.iter().enumerate() {
            s += &format!(
                "[tracking_lowpass.{}]\nomega_n = {}\nzeta = {}\n",
                AX[j],
                f(*wn),
                f(*zeta)
            );
        }
        if let Some(c) = self.sensor_lowpass {
            for i in 0..2 {
                s += &format!("[sensor_lowpass.{}]\ncutoff = {}\n", AX[i], f(c[i]));
            }
        }
        if let Some(m) = self.structural_mode {
            for i in 0..2 {
                s += &format!(
                    "[structural_mode.{}]\nomega_n = {}\nzeta = {}\n",
                    AX[i],
                    f(m[i].0),
                    f(m[i].1)
                );
            }
        }
        if let Some(d) = self.delay {
            for j in 0..2 {
                s += &format!("[time_delay.{}]\ndelay = {}\n", AX[j], f(d[j]));
            }
        }
        if let Some(u) = self.uncertainty {
            for i in 0..2 {
                for j in 0..2 {
                    let w = u[i][j];
                    s += &format!(
                        "[uncertainty.{}]\nk = {}\nz = {}\np = {}\ndelta = {}\ndelta_seed = {}\n",
                        CH[i][j],
                        f(w.k),
                        f(w.z),
                        f(w.p),
                        f(w.delta),
                        w.seed
                    );
                }
            }
        }
        if let Some((d, _)) = self.operating_point {
            s += &format!(
                "[operating_point_dependence]\nda_dx = {}\nda_dy = {}\ndb_dx = {}\ndb_dy = {}\n",
                f(d[0]),
                f(d[1]),
                f(d[2]),
                f(d[3])
            );
        }
        s
    }

    fn op(&self) -> [f64; 2] {
        self.operating_point.map(|(_, op)| op).unwrap_or([0.0; 2])
    }

    /// The first-order-hold stages of channel `ij`, as frequency-response closures of a real
    /// frequency (negative frequencies allowed: `s = j nu`).
    fn stages(&self, i: usize, j: usize) -> Vec<Box<dyn Fn(f64) -> Complex64 + '_>> {
        let (sa, sb) = match self.operating_point {
            Some((d, op)) => (
                1.0 + d[0] * op[0] + d[1] * op[1],
                1.0 + d[2] * op[0] + d[3] * op[1],
            ),
            None => (1.0, 1.0),
        };
        let (a, b) = (self.a[i][j] * sa, self.b[i][j] * sb);
        let (wn, zeta) = self.lowpass[j];
        let mut v: Vec<Box<dyn Fn(f64) -> Complex64 + '_>> = vec![Box::new(move |nu: f64| {
            let s = Complex64::new(0.0, nu);
            (a - b * s * s) * wn * wn / (s * s + 2.0 * zeta * wn * s + wn * wn)
        })];
        if let Some(u) = self.uncertainty {
            let tf = uncertainty::channel_factor(&u[i][j].values());
            v.push(Box::new(move |nu| tf.freq(nu)));
        }
        if let Some(c) = self.sensor_lowpass {
            let tf = sensor_lowpass::tf(c[i]);
            v.push(Box::new(move |nu| tf.freq(nu)));
        }
        if let Some(m) = self.structural_mode {
            let tf = structural_mode::tf(m[i].0, m[i].1);
            v.push(Box::new(move |nu| tf.freq(nu)));
        }
        v
    }

    /// Predicted relative error of the stepper at step `h` (module docs), over all channels.
    fn predicted_error(&self, h: f64) -> f64 {
        let w = self.omega;
        let ws = 2.0 * PI / h;
        let mut worst: f64 = 0.0;
        for i in 0..2 {
            for j in 0..2 {
                let mut e = if self.delay.is_some() {
                    (w * h).powi(2) / 8.0
                } else {
                    0.0
                };
                for stage in self.stages(i, j) {
                    let f0 = stage(w);
                    let r = (1..=8)
                        .flat_map(|m| [m as f64, -(m as f64)])
                        .map(|m| (stage(w + m * ws) - f0).norm() / f0.norm())
                        .fold(0.0, f64::max);
                    e += (w * h).powi(2) / 12.0 * r;
                }
                worst = worst.max(e);
            }
        }
        worst
    }

    /// Largest ratio of feedthrough (or any image) to the response, for the settling time.
    fn transient_ratio(&self) -> f64 {
        let mut r: f64 = 1.0;
        for i in 0..2 {
            for j in 0..2 {
                let g: Complex64 = self.stages(i, j).iter().map(|s| s(self.omega)).product();
                let g_inf: Complex64 = self.stages(i, j).iter().map(|s| s(1e7)).product();
                r = r.max(g_inf.norm() / g.norm());
            }
        }
        r
    }
}

fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (0.0..=1.0f64).prop_map(move |u| lo * (hi / lo).powf(u))
}

fn sign() -> impl Strategy<Value = f64> {
    prop_oneof![Just(1.0), Just(-1.0)]
}

fn unc() -> impl Strategy<Value = Unc> {
    (
        log_uniform(0.1, 20.0),
        log_uniform(0.1, 50.0),
        0.0..0.8f64,
        0.1..=1.0f64,
        sign(),
        prop_oneof![Just(0u64), 1u64..100_000],
    )
        .prop_map(|(z, p, peak, mag, sgn, seed)| Unc {
            // |W| <= k max(1, z/p), |Delta| <= |delta|: so |W Delta| <= peak.
            k: peak / (mag * (z / p).max(1.0)),
            z,
            p,
            delta: sgn * mag,
            seed,
        })
}

fn case() -> impl Strategy<Value = Case> {
    let pendulum = (
        [0.3..2.0f64, 0.3..2.0f64],
        [0.01..0.5f64, 0.01..0.5f64],
        [0.02..0.3f64, 0.02..0.3f64],
        [0.0..0.12f64, 0.0..0.12f64],
        [sign(), sign()],
    )
        .prop_map(|(ad, bd, ao, bo, sg)| {
            (
                [[ad[0], sg[0] * ao[0]], [sg[1] * ao[1], ad[1]]],
                [[bd[0], sg[0] * bo[0]], [sg[1] * bo[1], bd[1]]],
            )
        });
    let lowpass = [
        (log_uniform(5.0, 100.0), 0.2..=2.0f64),
        (log_uniform(5.0, 100.0), 0.2..=2.0f64),
    ];
    let sensor = proptest::option::of([log_uniform(10.0, 500.0), log_uniform(10.0, 500.0)]);
    let mode = proptest::option::of([
        (log_uniform(20.0, 300.0), 0.05..0.5f64),
        (log_uniform(20.0, 300.0), 0.05..0.5f64),
    ]);
    let delay = proptest::option::of([0.0..0.05f64, 0.0..0.05f64]);
    let unc = proptest::option::of([[unc(), unc()], [unc(), unc()]]);
    let op = proptest::option::of((
        [-2.0..2.0f64, -2.0..2.0f64, -2.0..2.0f64, -2.0..2.0f64],
        [-0.1..0.1f64, -0.1..0.1f64],
    ));
    (
        pendulum,
        lowpass,
        sensor,
        mode,
        delay,
        unc,
        op,
        log_uniform(0.05, 100.0),
    )
        .prop_map(
            |((a, b), lowpass, sensor_lowpass, structural_mode, delay, uncertainty, op, omega)| {
                Case {
                    a,
                    b,
                    lowpass,
                    sensor_lowpass,
                    structural_mode,
                    delay,
                    uncertainty,
                    operating_point: op,
                    omega,
                }
            },
        )
}

/// Simulates a sine of `AMPLITUDE` at `omega` on `excited` around `op` and returns the first
/// harmonics of both ZMP outputs over the input's: `[G_0j, G_1j]`. `h` holds a whole number
/// of steps per period.
fn measure(
    plant: &mut Plant,
    op: [f64; 2],
    excited: Axis,
    omega: f64,
    settle: f64,
) -> [Complex64; 2] {
    let h = plant.step_size();
    let per = (2.0 * PI / omega / h).round() as usize;
    let n_settle = (settle / h).ceil() as usize;
    let n_keep = 2 * per;
    plant.reset(op);
    let mut z = [Vec::with_capacity(n_keep), Vec::with_capacity(n_keep)];
    for k in 1..=n_settle + n_keep {
        let t = k as f64 * h;
        let mut r = op;
        r[excited.index()] += AMPLITUDE * (omega * t).sin();
        let out = plant.step(r);
        if k > n_settle {
            z[0].push(out.zmp[0]);
            z[1].push(out.zmp[1]);
        }
    }
    let t0 = (n_settle + 1) as f64 * h;
    [
        first_harmonic(&z[0], omega, h, t0) / AMPLITUDE,
        first_harmonic(&z[1], omega, h, t0) / AMPLITUDE,
    ]
}

/// Checks all four channels of `plant` at `omega`; `Err` names the first failure.
fn check(plant: &mut Plant, op: [f64; 2], omega: f64, settle: f64) -> Result<(), String> {
    plant.set_operating_point(op);
    let g = plant.frequency_response(omega);
    // Where the pendulum's coefficients move with the CoM, the small-signal gain is the
    // static one plus a slope term, and the two can cancel: the stepper's discretisation error
    // is relative to the terms, not to their difference (exactly 1 without that effect).
    let (a_static, b) = plant.pendulum_at_operating_point();
    let (a_lin, _) = plant.pendulum_gain_at_operating_point();
    let w2 = omega * omega;
    let cancel = |i: usize, j: usize| {
        let slope = a_lin[i][j] - a_static[i][j];
        if slope == 0.0 {
            return 1.0;
        }
        ((a_static[i][j] + b[i][j] * w2).abs() + slope.abs()) / (a_lin[i][j] + b[i][j] * w2).abs()
    };
    for excited in Axis::BOTH {
        let sim = measure(plant, op, excited, omega, settle);
        let j = excited.index();
        for i in 0..2 {
            let ratio = sim[i] / g[i][j];
            let mag_err = ratio.norm() - 1.0;
            let phase_err = ratio.arg().to_degrees();
            let c = cancel(i, j);
            if mag_err.abs() > TOL_MAG * c || phase_err.abs() > TOL_PHASE_DEG * c {
                return Err(format!(
                    "G{}{} at {omega} rad/s, h = {} s: simulated {} vs frequency response {} \
                     (magnitude error {:.3e}, phase error {:.4} deg)",
                    i + 1,
                    j + 1,
                    plant.step_size(),
                    sim[i],
                    g[i][j],
                    mag_err,
                    phase_err
                ));
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 48,
        failure_persistence: None,
        max_shrink_iters: 64,
        ..ProptestConfig::default()
    })]

    #[test]
    fn steady_state_of_the_stepper_is_the_frequency_response(case in case()) {
        let omega = case.omega;
        // Largest step: omega inside the Nyquist band of a data rate 20x below the plant's.
        let mut h = (PI / (20.0 * omega)).min(0.01);
        while case.predicted_error(h) > DISCRETISATION_BUDGET && h > 1e-5 {
            h /= 1.5;
        }
        // A whole number of steps per period.
        let per = (2.0 * PI / (omega * h)).ceil();
        let h = 2.0 * PI / (omega * per);
        prop_assume!(case.predicted_error(h) <= DISCRETISATION_BUDGET, "step below 10 us");
        prop_assert!(omega <= PI / (20.0 * h) * (1.0 + 1e-12));

        let text = case.to_toml();
        let spec = ModelSpec::parse(&text, "case.toml").map_err(|e| {
            TestCaseError::fail(format!("{e}\n{text}"))
        })?;
        let mut plant = Plant::new(&spec, h).unwrap();
        let delay = case.delay.map(|d| d[0].max(d[1])).unwrap_or(0.0);
        let settle = plant.slowest_time_constant() * (10.0 + (1.0 + case.transient_ratio()).ln())
            + delay;
        check(&mut plant, case.op(), omega, settle).map_err(TestCaseError::fail)?;
    }
}

const PAPER: &str = include_str!("../params/silo2-paper.toml");

/// The seed's model at h = 1 ms over 0.1..60 rad/s: nominal, with the constant `Delta = 1`,
/// and with a random `Delta` realisation.
#[test]
fn seed_model_at_one_millisecond() {
    let nominal = ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap();
    let mut unit = nominal.clone();
    let mut random = nominal.clone();
    for (n, ch) in zmp_models::Channel::ALL.iter().enumerate() {
        let b = zmp_models::Binding::Channel(*ch);
        assert!(unit.set_value(EffectKind::Uncertainty, b, "delta", 1.0));
        assert!(random.set_value(EffectKind::Uncertainty, b, "delta", -0.8));
        assert!(random.set_value(EffectKind::Uncertainty, b, "delta_seed", 11.0 + n as f64));
    }
    for spec in [nominal, unit, random] {
        let mut plant = Plant::new(&spec, 1e-3).unwrap();
        let settle = 10.0 * plant.slowest_time_constant();
        for k in 0..16 {
            let omega = 0.1 * 600f64.powf(k as f64 / 15.0);
            if let Err(e) = check(&mut plant, [0.0; 2], omega, settle) {
                panic!("{e}");
            }
        }
    }
}
