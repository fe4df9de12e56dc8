//! Tracking low-pass `H(s) = wn^2 / (s^2 + 2 zeta wn s + wn^2)` (first seed, section 6.3).
//!
//! It is the servo that moves the trunk: the CoM follows its reference through `H`. One servo
//! per input axis, so `H_ij = H_j` (the seed's four are equal). The servo's state gives the CoM
//! position, velocity and acceleration that the pendulum needs.

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use crate::lti::{Poly, TransferFunction};
use num_complex::Complex64;

pub static PARAMS: [ParamSpec; 2] = [
    ParamSpec::required(
        "omega_n",
        "rad/s",
        1e-3,
        1e4,
        "natural frequency of the servo tracking",
    ),
    ParamSpec::required(
        "zeta",
        "1",
        1e-3,
        10.0,
        "damping ratio of the servo tracking",
    ),
];

pub static INFO: EffectInfo = EffectInfo {
    kind: crate::EffectKind::TrackingLowpass,
    title: "tracking low-pass wn^2/(s^2+2 zeta wn s+wn^2)",
    doc: "The servo's CoM tracking; x_c = H(s) x_cr per input axis (first seed, section 6.3).",
    site: Site::Servo,
    core: true,
    linear: true,
    params: &PARAMS,
    validate: Some(validate),
    build,
};

fn validate(v: &[f64]) -> Result<(), (usize, String)> {
    if v[0].is_nan() || v[0] <= 0.0 {
        return Err((
            0,
            format!(
                "omega_n = {} makes the tracking low-pass unstable (needs omega_n > 0)",
                v[0]
            ),
        ));
    }
    if v[1].is_nan() || v[1] <= 0.0 {
        return Err((
            1,
            format!(
                "zeta = {} makes the tracking low-pass unstable (needs zeta > 0)",
                v[1]
            ),
        ));
    }
    Ok(())
}

#[derive(Debug, Clone, Copy)]
pub struct TrackingLowpass {
    pub omega_n: f64,
    pub zeta: f64,
}

impl TrackingLowpass {
    pub fn tf(&self) -> TransferFunction {
        let w2 = self.omega_n * self.omega_n;
        TransferFunction::new(
            Poly::new(&[w2]),
            Poly::new(&[w2, 2.0 * self.zeta * self.omega_n, 1.0]),
        )
    }

    /// `tf().freq(omega)` without building the transfer function (no allocation: the
    /// describing functions evaluate it millions of times); the same Horner sums, so the same
    /// bits.
    #[inline]
    pub fn freq(&self, omega: f64) -> Complex64 {
        let s = Complex64::new(0.0, omega);
        let horner = |c: &[f64]| {
            c.iter()
                .rev()
                .fold(Complex64::new(0.0, 0.0), |acc, &c| acc * s + c)
        };
        let w2 = self.omega_n * self.omega_n;
        horner(&[w2]) / horner(&[w2, 2.0 * self.zeta * self.omega_n, 1.0])
    }

    /// Time constant of the slowest pole, s: `1/(zeta wn)` when underdamped; when overdamped
    /// the slow real pole `wn (zeta - sqrt(zeta^2 - 1))`, i.e. `tau = (zeta + sqrt(zeta^2 - 1))/wn`.
    pub fn slowest_time_constant(&self) -> f64 {
        if self.zeta < 1.0 {
            1.0 / (self.zeta * self.omega_n)
        } else {
            (self.zeta + (self.zeta * self.zeta - 1.0).sqrt()) / self.omega_n
        }
    }
}

impl Effect for TrackingLowpass {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn frequency_response(&self, omega: f64, _amplitude: f64) -> Complex64 {
        self.freq(omega)
    }
    fn reset(&mut self, u: f64) -> f64 {
        u
    }
    fn transfer_function(&self) -> Option<TransferFunction> {
        Some(self.tf())
    }
}

fn build(_ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    Box::new(TrackingLowpass {
        omega_n: v[0],
        zeta: v[1],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn freq_is_the_transfer_functions_value_to_the_bit() {
        for wn in [0.5, 12.8, 30.0, 77.7, 400.0] {
            for zeta in [0.05, 0.7, 1.0, 2.3] {
                for omega in [0.0, 0.3, 4.2, 30.0, 125.0, 3e3] {
                    let lp = TrackingLowpass { omega_n: wn, zeta };
                    let (a, b) = (lp.freq(omega), lp.tf().freq(omega));
                    assert_eq!(
                        (a.re.to_bits(), a.im.to_bits()),
                        (b.re.to_bits(), b.im.to_bits()),
                        "wn {wn}, zeta {zeta}, omega {omega}: {a} against {b}"
                    );
                }
            }
        }
    }
}
