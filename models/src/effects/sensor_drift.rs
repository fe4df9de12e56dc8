//! Offset and drift of the ZMP measurement: `zmp + offset + r t`, t from the last reset (the
//! start of a record: the sensor is re-zeroed there, so its drift starts again from `offset`).
//! It leaves the first harmonic alone; it shows as a trend in the residual.
//!
//! The rate `r` of a record is `rate` plus, with `rate_spread > 0`, a part that changes from
//! record to record (a sensor re-zeroed at every record whose thermal drift differs each time):
//! record `k` (see [`crate::Plant::set_record`]) drifts at `r_k = rate + rate_spread z_k`, with
//! `z_k` a standard normal number, the first drawn from the ChaCha8 generator seeded with
//! `rate_seed` on stream `2 k + a` (`a` = 0 for the x output, 1 for y): reproducible record by
//! record and independent between records and axes. `rate_spread = 0` is one rate for every
//! record (the law of model files written before the spread existed). A diagnosis treats the
//! record-to-record part as a nuisance: each record's trend its own parameter.

use crate::effect::{Binding, BuildContext, Effect, EffectInfo, ParamSpec, Site};
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// The parameters of the sensor drift, in model-file order.
pub static PARAMS: [ParamSpec; 4] = [
    ParamSpec::optional("offset", "m", -1.0, 1.0, 0.0, "constant ZMP sensor offset"),
    ParamSpec::optional(
        "rate",
        "m/s",
        -0.1,
        0.1,
        0.0,
        "ZMP sensor drift rate (the mean over records)",
    ),
    ParamSpec::optional(
        "rate_spread",
        "m/s",
        0.0,
        0.1,
        0.0,
        "standard deviation of the drift rate from record to record (0: one rate)",
    ),
    ParamSpec::optional(
        "rate_seed",
        "1",
        0.0,
        4294967295.0,
        0.0,
        "seed of the records' drift rates",
    )
    .whole(),
];

/// The sensor drift's entry in the effect registry.
pub static INFO: EffectInfo = EffectInfo {
    kind: crate::EffectKind::SensorDrift,
    title: "ZMP sensor offset and drift",
    doc: "ZMP_measured = ZMP + offset + rate*t, per output axis.",
    site: Site::Sensor,
    core: false,
    linear: true,
    params: &PARAMS,
    validate: None,
    build,
};

/// The drift rate of record `record` on output axis `axis` (0 x, 1 y): `rate` plus
/// `rate_spread` times the record's standard normal draw (module docs).
pub fn record_rate(rate: f64, spread: f64, seed: u64, axis: usize, record: u64) -> f64 {
    if spread == 0.0 {
        return rate;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(record.wrapping_mul(2).wrapping_add(axis as u64));
    let z: f64 = StandardNormal.sample(&mut rng);
    rate + spread * z
}

/// An offset and a linear drift added to the measured ZMP, its rate drawn per record.
#[derive(Debug, Clone)]
pub struct SensorDrift {
    /// Constant offset of the measured ZMP, m.
    pub offset: f64,
    /// Drift rate of the measured ZMP in the current record, m/s.
    pub rate: f64,
    mean: f64,
    spread: f64,
    seed: u64,
    axis: usize,
    h: f64,
    steps: u64,
}

impl Effect for SensorDrift {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn frequency_response(&self, _omega: f64, _amplitude: f64) -> Complex64 {
        Complex64::new(1.0, 0.0)
    }
    fn reset(&mut self, u: f64) -> f64 {
        self.steps = 0;
        u + self.offset
    }
    fn begin_record(&mut self, record: u64) {
        self.rate = record_rate(self.mean, self.spread, self.seed, self.axis, record);
    }
    #[inline]
    fn jump(&mut self, u: f64) -> f64 {
        u + self.offset + self.rate * (self.steps as f64 * self.h)
    }
    #[inline]
    fn step(&mut self, u: f64) -> f64 {
        self.steps += 1;
        // Time as n*h, never accumulated.
        u + self.offset + self.rate * (self.steps as f64 * self.h)
    }
}

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    let axis = match ctx.binding {
        Binding::Axis(a) => a.index(),
        _ => 0,
    };
    let (spread, seed) = (
        v.get(2).copied().unwrap_or(0.0),
        v.get(3).copied().unwrap_or(0.0),
    );
    let mut e = SensorDrift {
        offset: v[0],
        rate: v[1],
        mean: v[1],
        spread,
        seed: seed as u64,
        axis,
        h: ctx.h,
        steps: 0,
    };
    e.begin_record(0);
    Box::new(e)
}
