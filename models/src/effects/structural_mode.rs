//! A structural mode in the ZMP path: the flexible structure between trunk and force sensors
//! rings at `omega_n` with light damping, `wn^2/(s^2 + 2 zeta wn s + wn^2)`; its peak gain is
//! about `1/(2 zeta)` at `omega_n`. When only part of the moving mass sits on the flexible
//! structure (a flexible link carrying a `share` of the trunk, the rest rigid), the response
//! is `(1 - share) + share wn^2/(s^2 + 2 zeta wn s + wn^2)`: the resonance, then an
//! anti-resonance at `wn / sqrt(1 - share)` where the link moves against the rest, unit gain
//! at rest; `share = 1` (the default) is the whole path.

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use crate::lti::{Poly, TransferFunction};
use crate::lti_effect::LtiEffect;

pub static PARAMS: [ParamSpec; 3] = [
    ParamSpec::required("omega_n", "rad/s", 0.1, 2000.0, "mode frequency"),
    ParamSpec::required("zeta", "1", 1e-3, 1.0, "mode damping ratio"),
    ParamSpec::optional(
        "share",
        "1",
        0.0,
        1.0,
        1.0,
        "part of the response that passes through the mode (the rest is rigid)",
    ),
];

pub static INFO: EffectInfo = EffectInfo {
    kind: crate::EffectKind::StructuralMode,
    title: "structural mode (lightly damped resonance)",
    doc: "ZMP_measured = ((1-share) + share wn^2/(s^2+2 zeta wn s+wn^2)) ZMP, per output axis.",
    site: Site::Sensor,
    core: false,
    linear: true,
    params: &PARAMS,
    validate: None,
    build,
};

pub fn tf(omega_n: f64, zeta: f64) -> TransferFunction {
    tf_shared(omega_n, zeta, 1.0)
}

/// `(1 - share) + share wn^2/(s^2 + 2 zeta wn s + wn^2)`.
pub fn tf_shared(omega_n: f64, zeta: f64, share: f64) -> TransferFunction {
    let w2 = omega_n * omega_n;
    let rigid = 1.0 - share;
    let den = [w2, 2.0 * zeta * omega_n, 1.0];
    if rigid == 0.0 {
        return TransferFunction::new(Poly::new(&[w2]), Poly::new(&den));
    }
    TransferFunction::new(Poly::new(&[w2, rigid * den[1], rigid]), Poly::new(&den))
}

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    let share = v.get(2).copied().unwrap_or(1.0);
    Box::new(LtiEffect::new(&INFO, tf_shared(v[0], v[1], share), ctx.h))
}
