//! Pure time delay of the CoM command (communication, computation): `e^{-s tau}`.
//! Phase falls linearly with frequency, magnitude unchanged. Fractional delays interpolate
//! linearly between stored steps.

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use num_complex::Complex64;

/// Upper bound of the delay; the ring buffer is sized from it once, at build time.
pub const MAX_DELAY_S: f64 = 0.5;

pub static PARAMS: [ParamSpec; 1] = [ParamSpec::required(
    "delay",
    "s",
    0.0,
    MAX_DELAY_S,
    "transport delay of the CoM reference",
)];

pub static INFO: EffectInfo = EffectInfo {
    kind: "time_delay",
    title: "pure time delay",
    doc: "The CoM reference reaches the servo tau seconds late: e^{-s tau}.",
    site: Site::Command,
    core: false,
    linear: true,
    params: &PARAMS,
    validate: None,
    build,
};

#[derive(Debug, Clone)]
pub struct TimeDelay {
    pub delay: f64,
    buf: Vec<f64>,
    head: usize,
    whole: usize,
    frac: f64,
}

impl TimeDelay {
    pub fn new(delay: f64, h: f64) -> TimeDelay {
        let steps = delay / h;
        let whole = steps.floor() as usize;
        let frac = steps - whole as f64;
        let cap = ((MAX_DELAY_S / h).ceil() as usize).max(whole) + 3;
        TimeDelay {
            delay,
            buf: vec![0.0; cap],
            head: 0,
            whole,
            frac,
        }
    }
}

impl Effect for TimeDelay {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn frequency_response(&self, omega: f64, _amplitude: f64) -> Complex64 {
        Complex64::from_polar(1.0, -omega * self.delay)
    }
    fn reset(&mut self, u: f64) -> f64 {
        self.buf.iter_mut().for_each(|b| *b = u);
        u
    }
    #[inline]
    fn step(&mut self, u: f64) -> f64 {
        let n = self.buf.len();
        self.head = if self.head + 1 == n { 0 } else { self.head + 1 };
        self.buf[self.head] = u;
        // Indices behind the head, wrapped without a division.
        let back = |k: usize, head: usize| if head >= k { head - k } else { head + n - k };
        let i0 = back(self.whole, self.head);
        let i1 = back(self.whole + 1, self.head);
        (1.0 - self.frac) * self.buf[i0] + self.frac * self.buf[i1]
    }
}

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    Box::new(TimeDelay::new(v[0], ctx.h))
}
