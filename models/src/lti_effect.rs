//! A linear effect given by its transfer function: exact response, first-order-hold step
//! (exact for inputs that ramp between steps and jump at them).

use crate::effect::{Effect, EffectInfo};
use crate::lti::{DiscreteLti, TransferFunction};
use num_complex::Complex64;

/// A linear effect: its transfer function, discretised exactly for the plant's step.
#[derive(Debug, Clone)]
pub struct LtiEffect {
    info: &'static EffectInfo,
    tf: TransferFunction,
    sys: DiscreteLti,
}

impl LtiEffect {
    /// The effect `info` of transfer function `tf`, stepped at `h` (s).
    pub fn new(info: &'static EffectInfo, tf: TransferFunction, h: f64) -> LtiEffect {
        let sys = DiscreteLti::new(&tf, h);
        LtiEffect { info, tf, sys }
    }
}

impl Effect for LtiEffect {
    fn info(&self) -> &'static EffectInfo {
        self.info
    }
    fn frequency_response(&self, omega: f64, _amplitude: f64) -> Complex64 {
        self.tf.freq(omega)
    }
    fn reset(&mut self, u: f64) -> f64 {
        self.sys.reset(u)
    }
    #[inline]
    fn step(&mut self, u: f64) -> f64 {
        self.sys.step(u)
    }
    #[inline]
    fn jump(&mut self, u: f64) -> f64 {
        self.sys.jump(u)
    }
    fn transfer_function(&self) -> Option<TransferFunction> {
        Some(self.tf.clone())
    }
}
