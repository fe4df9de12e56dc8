//! Offset and drift of the ZMP measurement: `zmp + offset + rate t`, t from the last reset.
//! It leaves the first harmonic alone; it shows as a trend in the residual.

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use num_complex::Complex64;

pub static PARAMS: [ParamSpec; 2] = [
    ParamSpec::optional("offset", "m", -1.0, 1.0, 0.0, "constant ZMP sensor offset"),
    ParamSpec::optional("rate", "m/s", -0.1, 0.1, 0.0, "ZMP sensor drift rate"),
];

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

#[derive(Debug, Clone)]
pub struct SensorDrift {
    pub offset: f64,
    pub rate: f64,
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
    Box::new(SensorDrift {
        offset: v[0],
        rate: v[1],
        h: ctx.h,
        steps: 0,
    })
}
