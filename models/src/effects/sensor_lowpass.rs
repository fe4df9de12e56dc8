//! First-order low-pass of the ZMP measurement (force-sensor electronics, filtering):
//! `wc/(s + wc)` per output axis.

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use crate::lti::{Poly, TransferFunction};
use crate::lti_effect::LtiEffect;

pub static PARAMS: [ParamSpec; 1] = [ParamSpec::required(
    "cutoff",
    "rad/s",
    0.1,
    1e4,
    "corner frequency of the ZMP sensor filter",
)];

pub static INFO: EffectInfo = EffectInfo {
    kind: crate::EffectKind::SensorLowpass,
    title: "ZMP sensor low-pass",
    doc: "ZMP_measured = wc/(s+wc) ZMP, per output axis.",
    site: Site::Sensor,
    core: false,
    linear: true,
    params: &PARAMS,
    validate: None,
    build,
};

pub fn tf(cutoff: f64) -> TransferFunction {
    TransferFunction::new(Poly::new(&[cutoff]), Poly::new(&[cutoff, 1.0]))
}

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    Box::new(LtiEffect::new(&INFO, tf(v[0]), ctx.h))
}
