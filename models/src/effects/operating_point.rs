//! Operating-point dependence: the pendulum coefficients change with posture. At the CoM
//! position `(x, y)` (m, absolute), `a_ij(x, y) = a_ij (1 + da_dx x + da_dy y)` and likewise
//! `b_ij` with `db_dx`, `db_dy`; the ZMP is `zmp_i = sum_j a_ij(x_c) x_cj - b_ij(x_c) x_cj''`
//! at the instantaneous CoM. The model's own `a_ij`, `b_ij` are the values at the origin.
//!
//! The plant linearises this law about the operating point `op` (the constant CoM reference a
//! record oscillates about), exactly for the first harmonic: the static ZMP stays
//! `a(op) op`, and a small motion `dx_j` moves it by the derivative of that static map,
//! `a_ij (1 + da.op) + da_j (a op)_i`, not by `a_ij(op)` alone (the scaled coefficients alone
//! would give a small-signal gain that disagrees with the slope of the static ZMP, and no
//! cross-axis term where the other axis's CoM sits away from the origin). `b` enters only
//! with the acceleration, which is zero at rest: its small-signal gain is `b_ij(op)`. What the
//! linearisation leaves out are the second harmonic and the mean shift of `da (dx)^2`, which
//! the first-harmonic fits do not see.

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
    kind: crate::EffectKind::OperatingPointDependence,
    title: "operating-point dependence",
    doc: "a_ij and b_ij scale linearly with the CoM position (zmp = a(x_c) x_c - b(x_c) x_c'').",
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
    fn pendulum_scale_gradient(&self, _op: [f64; 2]) -> [f64; 2] {
        self.da
    }
}

fn build(_ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    Box::new(OperatingPointDependence {
        da: [v[0], v[1]],
        db: [v[2], v[3]],
    })
}
