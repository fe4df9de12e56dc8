//! Backlash (mechanical play) between servo and trunk: a dead band of total `width`. The output
//! only moves once the input has crossed the play; a sine of amplitude below `width/2` gives no
//! motion at all. Modelled on the command ahead of the tracking dynamics, which keeps the trunk
//! acceleration finite (play between rigid bodies would give impacts no ZMP sensor resolves).

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use num_complex::Complex64;
use std::f64::consts::PI;

pub static PARAMS: [ParamSpec; 1] = [ParamSpec::required(
    "width",
    "m",
    0.0,
    0.1,
    "total play, expressed as CoM displacement",
)];

pub static INFO: EffectInfo = EffectInfo {
    kind: "backlash",
    title: "backlash (dead band)",
    doc: "Play operator of total width w on the CoM reference.",
    site: Site::Command,
    core: false,
    linear: false,
    params: &PARAMS,
    validate: None,
    build,
};

#[derive(Debug, Clone)]
pub struct Backlash {
    pub width: f64,
    y: f64,
}

impl Backlash {
    pub fn new(width: f64) -> Backlash {
        Backlash { width, y: 0.0 }
    }
}

/// Describing function of a play of half-width `b` for a sine of amplitude `a`
/// (Gelb & Vander Velde): zero while `a <= b`, tending to one for `a >> b`.
pub fn describing_function(b: f64, a: f64) -> Complex64 {
    if a <= b {
        return Complex64::new(0.0, 0.0);
    }
    if b <= 0.0 {
        return Complex64::new(1.0, 0.0);
    }
    let r = b / a;
    let re =
        (PI / 2.0 + (1.0 - 2.0 * r).asin() + 2.0 * (1.0 - 2.0 * r) * (r * (1.0 - r)).sqrt()) / PI;
    let im = -4.0 * r * (1.0 - r) / PI;
    Complex64::new(re, im)
}

impl Effect for Backlash {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn frequency_response(&self, _omega: f64, amplitude: f64) -> Complex64 {
        describing_function(0.5 * self.width, amplitude)
    }
    fn reset(&mut self, u: f64) -> f64 {
        self.y = u;
        u
    }
    /// The play operator is rate-independent: a jump moves it as a ramp would.
    #[inline]
    fn jump(&mut self, u: f64) -> f64 {
        self.step(u)
    }
    #[inline]
    fn step(&mut self, u: f64) -> f64 {
        let half = 0.5 * self.width;
        if u > self.y + half {
            self.y = u - half;
        } else if u < self.y - half {
            self.y = u + half;
        }
        self.y
    }
}

fn build(_ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    Box::new(Backlash::new(v[0]))
}
