//! Shared by the plant's law tests: the seed's base plant with extra effects, and sines run
//! through it.

#![allow(dead_code)]

use std::f64::consts::PI;
use zmp_models::{Axis, Channel, ModelSpec, Plant, PlantOutput};

pub const H: f64 = 1e-3;
pub const G11: Channel = Channel::ALL[0];
pub const G21: Channel = Channel::ALL[2];

/// The seed's pendulum and tracking low-pass, nothing else.
pub const BASE: &str = r#"
format = "zmp-model/1"
name = "base"
[pendulum]
a11 = 0.8293
a12 = 0.07455
a21 = 0.1895
a22 = 1.245
b11 = 0.2767
b12 = 0.005428
b21 = 0.09979
b22 = 0.1012
[tracking_lowpass]
omega_n = 30.0
zeta = 1.0
"#;

pub fn spec(extra: &str) -> ModelSpec {
    let text = format!("{BASE}\n{extra}");
    ModelSpec::parse(&text, "law.toml").unwrap_or_else(|e| panic!("{e}\n{text}"))
}

pub fn plant(extra: &str) -> Plant {
    Plant::new(&spec(extra), H).unwrap()
}

/// The nearest frequency to `omega` with a whole number of steps per period, and that number.
pub fn whole_period(omega: f64) -> (f64, usize) {
    let n = (2.0 * PI / (omega * H)).round() as usize;
    (2.0 * PI / (n as f64 * H), n)
}

/// Runs a sine `op + amplitude sin(omega t)` on `excited` (other axis at `op`) from rest for
/// `settle` s, then records `periods` whole periods. `omega` must come from [`whole_period`].
pub fn record(
    plant: &mut Plant,
    op: [f64; 2],
    excited: Axis,
    omega: f64,
    amplitude: f64,
    settle: f64,
    periods: usize,
) -> (Vec<PlantOutput>, f64) {
    let (_, per) = whole_period(omega);
    let n_settle = (settle / H).ceil() as usize;
    plant.reset(op);
    let mut out = Vec::with_capacity(per * periods);
    for k in 1..=n_settle + per * periods {
        let t = k as f64 * H;
        let mut r = op;
        r[excited.index()] += amplitude * (omega * t).sin();
        let o = plant.step(r);
        if k > n_settle {
            out.push(o);
        }
    }
    (out, (n_settle + 1) as f64 * H)
}
