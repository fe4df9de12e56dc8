//! A structural mode in the ZMP path: the flexible structure between trunk and force sensors
//! rings at `omega_n` with light damping, `wn^2/(s^2 + 2 zeta wn s + wn^2)`; its peak gain is
//! about `1/(2 zeta)` at `omega_n`.

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use crate::lti::{Poly, TransferFunction};
use crate::lti_effect::LtiEffect;

pub static PARAMS: [ParamSpec; 2] = [
    ParamSpec::required("omega_n", "rad/s", 0.1, 2000.0, "mode frequency"),
    ParamSpec::required("zeta", "1", 1e-3, 1.0, "mode damping ratio"),
];

pub static INFO: EffectInfo = EffectInfo {
    kind: "structural_mode",
    title: "structural mode (lightly damped resonance)",
    doc: "ZMP_measured = wn^2/(s^2+2 zeta wn s+wn^2) ZMP, per output axis.",
    site: Site::Sensor,
    core: false,
    linear: true,
    params: &PARAMS,
    validate: None,
    build,
};

pub fn tf(omega_n: f64, zeta: f64) -> TransferFunction {
    let w2 = omega_n * omega_n;
    TransferFunction::new(
        Poly::new(&[w2]),
        Poly::new(&[w2, 2.0 * zeta * omega_n, 1.0]),
    )
}

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    Box::new(LtiEffect::new(&INFO, tf(v[0], v[1]), ctx.h))
}
