//! Pure time delay of the CoM command (communication, computation): `e^{-s tau}`.
//! Phase falls linearly with frequency, magnitude unchanged. Fractional delays interpolate
//! linearly between stored steps. A jump of the input (a held command switching at a step) is
//! stored with its step and passed on, as a jump, at the step it reaches the output: exact
//! when the delay is a whole number of steps; a fractional delay ramps it over one step.

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
    kind: crate::EffectKind::TimeDelay,
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
    /// The input at each stored step: its value at the step's end (left limit).
    buf: Vec<f64>,
    /// Its value just after the step's end (right limit): differs from `buf` where it jumped.
    post: Vec<f64>,
    head: usize,
    whole: usize,
    frac: f64,
}

impl TimeDelay {
    pub fn new(delay: f64, h: f64) -> TimeDelay {
        let steps = delay / h;
        // A delay within rounding of a whole number of steps is that number.
        let steps = if (steps - steps.round()).abs() < 1e-9 * steps.max(1.0) {
            steps.round()
        } else {
            steps
        };
        let whole = steps.floor() as usize;
        let frac = steps - whole as f64;
        let cap = whole + 3;
        TimeDelay {
            delay,
            buf: vec![0.0; cap],
            post: vec![0.0; cap],
            head: 0,
            whole,
            frac,
        }
    }

    /// Index `k` places behind the head, wrapped without a division.
    #[inline]
    fn back(&self, k: usize) -> usize {
        let n = self.buf.len();
        if self.head >= k {
            self.head - k
        } else {
            self.head + n - k
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
        self.post.iter_mut().for_each(|b| *b = u);
        u
    }
    #[inline]
    fn step(&mut self, u: f64) -> f64 {
        self.step_span(None, u).1
    }
    #[inline]
    fn jump(&mut self, u: f64) -> f64 {
        self.post[self.head] = u;
        // The output jumps now only without delay.
        if self.whole == 0 && self.frac == 0.0 {
            u
        } else {
            let i0 = self.back(self.whole);
            let i1 = self.back(self.whole + 1);
            (1.0 - self.frac) * self.buf[i0] + self.frac * self.post[i1]
        }
    }
    #[inline]
    fn step_span(&mut self, jump: Option<f64>, u: f64) -> (Option<f64>, f64) {
        if let Some(v) = jump {
            self.post[self.head] = v;
        }
        // The delayed instant of the step's start: a stored step when the delay is whole.
        let start = (self.frac == 0.0)
            .then(|| self.back(self.whole))
            .filter(|&i| self.post[i] != self.buf[i])
            .map(|i| self.post[i]);
        let n = self.buf.len();
        self.head = if self.head + 1 == n { 0 } else { self.head + 1 };
        self.buf[self.head] = u;
        self.post[self.head] = u;
        // Between stored steps i1 and i0 the input ran from post[i1] to buf[i0].
        let i0 = self.back(self.whole);
        let i1 = self.back(self.whole + 1);
        (
            start,
            (1.0 - self.frac) * self.buf[i0] + self.frac * self.post[i1],
        )
    }
}

/// Most stored steps of a delay: `delay / h` above it is refused (a named error of
/// [`crate::Plant::new`]) instead of allocating gigabytes.
pub const MAX_DELAY_STEPS: f64 = 1e7;

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    Box::new(TimeDelay::new(v[0], ctx.h))
}
