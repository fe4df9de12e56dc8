//! Operating-point dependence: the pendulum coefficients change with posture. Around the
//! operating point `(x, y)` (m, the constant CoM reference a record oscillates about),
//! `a_ij(op) = a_ij (1 + da_dx x + da_dy y)` and likewise `b_ij` with `db_dx`, `db_dy`.
//! The model's own `a_ij`, `b_ij` are the values at the origin.

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use num_complex::Complex64;

pub static PARAMS: [ParamSpec; 4] = [
    ParamSpec::optional(
        "da_dx",
        "1/m",
        -100.0,
        100.0,
        0.0,
        "relative change of a_ij per m of x",
    ),
    ParamSpec::optional(
        "da_dy",
        "1/m",
        -100.0,
        100.0,
        0.0,
        "relative change of a_ij per m of y",
    ),
    ParamSpec::optional(
        "db_dx",
        "1/m",
        -100.0,
        100.0,
        0.0,
        "relative change of b_ij per m of x",
    ),
    ParamSpec::optional(
        "db_dy",
        "1/m",
        -100.0,
        100.0,
        0.0,
        "relative change of b_ij per m of y",
    ),
];

pub static INFO: EffectInfo = EffectInfo {
    kind: "operating_point_dependence",
    title: "operating-point dependence",
    doc: "a_ij and b_ij scale linearly with the operating point.",
    site: Site::Pendulum,
    core: false,
    linear: true,
    params: &PARAMS,
    validate: None,
    build,
};

#[derive(Debug, Clone, Copy)]
pub struct OperatingPointDependence {
    pub da: [f64; 2],
    pub db: [f64; 2],
}

impl Effect for OperatingPointDependence {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn frequency_response(&self, _omega: f64, _amplitude: f64) -> Complex64 {
        Complex64::new(1.0, 0.0)
    }
    fn reset(&mut self, u: f64) -> f64 {
        u
    }
    fn pendulum_scale(&self, op: [f64; 2]) -> (f64, f64) {
        (
            1.0 + self.da[0] * op[0] + self.da[1] * op[1],
            1.0 + self.db[0] * op[0] + self.db[1] * op[1],
        )
    }
}

fn build(_ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    Box::new(OperatingPointDependence {
        da: [v[0], v[1]],
        db: [v[2], v[3]],
    })
}
