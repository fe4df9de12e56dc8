//! Equivalent inverted pendulum `G_invp_ij(s) = a_ij - b_ij s^2` (first seed, eq. 22–24).
//!
//! `a_ij` is the static gain from CoM to ZMP; `b_ij` (s²) plays the role of `z_c/g`, the
//! pendulum height over gravity, so that the ZMP moves against the CoM acceleration. The plant
//! reads the coefficients directly; as a SISO effect the pendulum is the identity.

use crate::axis::Channel;
use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use num_complex::Complex64;

const A_DOC: &str = "static gain from CoM reference to ZMP (m/m)";
const B_DOC: &str = "pendulum coefficient, ZMP = a x_c - b x_c'' (s^2)";

pub static PARAMS: [ParamSpec; 8] = [
    ParamSpec::required("a11", "1", -10.0, 10.0, A_DOC),
    ParamSpec::required("a12", "1", -10.0, 10.0, A_DOC),
    ParamSpec::required("a21", "1", -10.0, 10.0, A_DOC),
    ParamSpec::required("a22", "1", -10.0, 10.0, A_DOC),
    ParamSpec::required("b11", "s2", -10.0, 10.0, B_DOC),
    ParamSpec::required("b12", "s2", -10.0, 10.0, B_DOC),
    ParamSpec::required("b21", "s2", -10.0, 10.0, B_DOC),
    ParamSpec::required("b22", "s2", -10.0, 10.0, B_DOC),
];

pub static INFO: EffectInfo = EffectInfo {
    kind: crate::EffectKind::Pendulum,
    title: "equivalent inverted pendulum a - b s^2",
    doc: "Per channel G_ij, ZMP_i = a_ij x_cj - b_ij x_cj'' (first seed, eq. 24).",
    site: Site::Pendulum,
    core: true,
    linear: true,
    params: &PARAMS,
    validate: None,
    build,
};

/// The eight coefficients, `a[i][j]`, `b[i][j]` with `i` the output and `j` the input axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pendulum {
    pub a: [[f64; 2]; 2],
    pub b: [[f64; 2]; 2],
}

impl Pendulum {
    /// From the parameter values in [`PARAMS`] order.
    pub fn from_values(v: &[f64]) -> Pendulum {
        Pendulum {
            a: [[v[0], v[1]], [v[2], v[3]]],
            b: [[v[4], v[5]], [v[6], v[7]]],
        }
    }

    /// The values in [`PARAMS`] order (`a11 a12 a21 a22 b11 b12 b21 b22`).
    pub fn values(&self) -> [f64; 8] {
        let (a, b) = (self.a, self.b);
        [
            a[0][0], a[0][1], a[1][0], a[1][1], b[0][0], b[0][1], b[1][0], b[1][1],
        ]
    }

    /// Each coefficient with its model-file name (`a11` ... `b22`), in [`PARAMS`] order.
    pub fn named(&self) -> [(&'static str, f64); 8] {
        let v = self.values();
        std::array::from_fn(|k| (PARAMS[k].name, v[k]))
    }

    /// `a_ij - b_ij s^2` at `s = j omega`, i.e. `a_ij + b_ij omega^2`.
    pub fn response(&self, ch: Channel, omega: f64) -> Complex64 {
        let (i, j) = (ch.output.index(), ch.input.index());
        Complex64::new(self.a[i][j] + self.b[i][j] * omega * omega, 0.0)
    }
}

impl Effect for Pendulum {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn frequency_response(&self, _omega: f64, _amplitude: f64) -> Complex64 {
        Complex64::new(1.0, 0.0)
    }
    fn reset(&mut self, u: f64) -> f64 {
        u
    }
}

fn build(_ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    Box::new(Pendulum::from_values(v))
}
