//! Backlash (mechanical play) between servo and trunk: a dead band of total `width`. The output
//! only moves once the input has crossed the play; a sine of amplitude below `width/2` gives no
//! motion at all.
//!
//! Two laws, chosen by `in_servo`:
//!
//! * `0` (the default): a play operator on the CoM command ahead of the tracking dynamics,
//!   which keeps the trunk acceleration finite. Where the servo is linear this is the play's
//!   small-signal effect.
//! * `1`: the play inside the servo's loop, where a gear's play sits on a robot: the servo
//!   closes its loop on the drive's encoder (a `drive` part of the axis's inertia: the
//!   motor's reflected rotor), and the drive pushes the trunk through a stiff, damped
//!   transmission (`transmission_omega`, `transmission_zeta`: the trunk's mode on it with the
//!   drive held) once it has crossed the play; the disengaged trunk coasts against its
//!   bearing's drag (`load_drag`, 1/s). With the seed's force limit acting the laws part:
//!   in the play the limited force accelerates the drive alone, which then hits the trunk;
//!   before the servo, the play only delays the command of a clamped rigid trunk. The plant
//!   steps the two bodies ([`crate::effects::servo_link`], one link per axis: not with a
//!   flexible trunk `in_servo`); the describing functions simulate that loop.

use crate::effect::{check_switch, BuildContext, Effect, EffectInfo, ParamSpec, Site};
use crate::effects::servo::play_harmonics;
use crate::effects::servo_link::{com_response, TrunkLink};
use crate::effects::tracking_lowpass::TrackingLowpass;
use num_complex::Complex64;
use std::f64::consts::PI;

pub static PARAMS: [ParamSpec; 6] = [
    ParamSpec::required(
        "width",
        "m",
        0.0,
        0.1,
        "total play, expressed as CoM displacement",
    ),
    ParamSpec::optional(
        "in_servo",
        "1",
        0.0,
        1.0,
        0.0,
        "1: the play between the drive and the trunk inside the servo's loop; 0: a play on the CoM command before the servo",
    ),
    ParamSpec::optional(
        "transmission_omega",
        "rad/s",
        1.0,
        5000.0,
        150.0,
        "in_servo: the trunk's mode on the transmission with the drive held",
    ),
    ParamSpec::optional(
        "transmission_zeta",
        "1",
        1e-3,
        2.0,
        0.2,
        "in_servo: damping ratio of that mode",
    ),
    ParamSpec::optional(
        "drive",
        "1",
        0.01,
        0.9,
        0.3,
        "in_servo: part of the axis's inertia in the drive (the servo's encoder side)",
    ),
    ParamSpec::optional(
        "load_drag",
        "1/s",
        0.0,
        1000.0,
        20.0,
        "in_servo: viscous drag of the trunk at its bearing (brakes it in the play)",
    ),
];

/// `in_servo` is a switch between two laws, 0 or 1.
fn validate(v: &[f64]) -> Result<(), (usize, String)> {
    check_switch(
        v,
        1,
        "a play on the CoM command before the servo",
        "the play between drive and trunk, inside the servo's loop",
    )
}

pub static INFO: EffectInfo = EffectInfo {
    kind: crate::EffectKind::Backlash,
    title: "backlash (dead band)",
    doc: "Play of total width w: on the CoM reference (in_servo = 0) or between drive and trunk inside the servo (in_servo = 1).",
    site: Site::Command,
    core: false,
    linear: false,
    params: &PARAMS,
    validate: Some(validate),
    build,
};

/// The link a backlash `in_servo = 1` with values `v` puts in its axis's servo (`None` for a
/// play on the command).
pub fn servo_link(v: &[f64]) -> Option<TrunkLink> {
    let p = |k: usize| v.get(k).copied().or(PARAMS[k].default).unwrap_or(0.0);
    (p(1) == 1.0 && v[0] > 0.0).then(|| TrunkLink {
        omega_m: p(2),
        zeta_m: p(3),
        share: 1.0,
        drive: p(4),
        half_play: 0.5 * v[0],
        drag: p(5),
    })
}

/// A backlash inside the servo: only its frequency response (the two-body loop's
/// describing function over the rigid servo's); the servo steps it.
#[derive(Debug, Clone)]
pub struct PlayInServo {
    link: TrunkLink,
    servo: (f64, f64),
    h: f64,
}

impl Effect for PlayInServo {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    /// Without an amplitude, the engaged loop's small-signal filter.
    fn frequency_response(&self, omega: f64, amplitude: f64) -> Complex64 {
        if amplitude <= 0.0 {
            let (omega_n, zeta) = self.servo;
            return com_response(self.link, omega_n, zeta, omega)
                / TrackingLowpass { omega_n, zeta }.freq(omega);
        }
        self.harmonics(omega, amplitude).0
    }
    fn third_harmonic(&self, omega: f64, amplitude: f64) -> Complex64 {
        self.harmonics(omega, amplitude).1
    }
    fn harmonics(&self, omega: f64, amplitude: f64) -> (Complex64, Complex64) {
        play_harmonics(self.servo, self.h, self.link, omega, amplitude)
    }
    fn reset(&mut self, u: f64) -> f64 {
        u
    }
    #[inline]
    fn step(&mut self, u: f64) -> f64 {
        u
    }
}

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

/// The `k`-th harmonic (odd `k`) of a play of half-width `b`'s steady output for the input
/// `a sin(theta)`, over `a` (sin-referenced): `k = 1` is [`describing_function`]. Half-wave
/// symmetry leaves only odd harmonics; over the half period from the input's maximum the
/// output holds at `a - b` until the input has fallen by `2 b` (at `theta_1 = pi - asin(1 - 2
/// b/a)`), then follows `a sin(theta) + b`.
pub fn harmonic(b: f64, a: f64, k: u32) -> Complex64 {
    let zero = Complex64::new(0.0, 0.0);
    if a <= b || k.is_multiple_of(2) {
        return zero;
    }
    if b <= 0.0 {
        return if k == 1 {
            Complex64::new(1.0, 0.0)
        } else {
            zero
        };
    }
    let r = b / a;
    let t1 = PI - (1.0 - 2.0 * r).asin();
    let t2 = 1.5 * PI;
    // Integral of e^{-j m theta} from `from` to `to`.
    let e = |m: i64, from: f64, to: f64| {
        if m == 0 {
            Complex64::new(to - from, 0.0)
        } else {
            let m = m as f64;
            (Complex64::from_polar(1.0, -m * to) - Complex64::from_polar(1.0, -m * from))
                / Complex64::new(0.0, -m)
        }
    };
    let k = k as i64;
    let hold = (1.0 - r) * e(k, 0.5 * PI, t1);
    let follow =
        (e(k - 1, t1, t2) - e(k + 1, t1, t2)) / Complex64::new(0.0, 2.0) + r * e(k, t1, t2);
    Complex64::new(0.0, 2.0 / PI) * (hold + follow)
}

impl Effect for Backlash {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn frequency_response(&self, _omega: f64, amplitude: f64) -> Complex64 {
        describing_function(0.5 * self.width, amplitude)
    }
    fn third_harmonic(&self, _omega: f64, amplitude: f64) -> Complex64 {
        harmonic(0.5 * self.width, amplitude, 3)
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

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    match servo_link(v) {
        Some(link) => Box::new(PlayInServo {
            link,
            servo: ctx.servo.unwrap_or((30.0, 1.0)),
            h: ctx.h,
        }),
        None => Box::new(Backlash::new(v[0])),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `k`-th sin-referenced harmonic of the play's simulated steady output, over `a`.
    fn simulated(width: f64, a: f64, k: u32) -> Complex64 {
        let n = 20_000;
        let mut play = Backlash::new(width);
        play.reset(0.0);
        let mut acc = Complex64::new(0.0, 0.0);
        for period in 0..2 {
            for i in 0..n {
                let theta = 2.0 * PI * i as f64 / n as f64;
                let y = play.step(a * theta.sin());
                if period == 1 {
                    acc += y * Complex64::from_polar(1.0, -(k as f64) * theta);
                }
            }
        }
        acc * Complex64::new(0.0, 2.0 / n as f64) / a
    }

    #[test]
    fn first_harmonic_is_the_describing_function() {
        for r in [0.01, 0.2, 0.45, 0.8, 0.99] {
            let (b, a) = (r * 0.004, 0.004);
            let d = harmonic(b, a, 1) - describing_function(b, a);
            assert!(d.norm() < 1e-12, "r = {r}: {d}");
        }
        assert_eq!(harmonic(0.005, 0.004, 3), Complex64::new(0.0, 0.0));
    }

    #[test]
    fn third_harmonic_matches_the_simulated_play() {
        for r in [0.05, 0.3, 0.6, 0.9] {
            let width = 2.0 * r * 0.006;
            let exact = harmonic(0.5 * width, 0.006, 3);
            let sim = simulated(width, 0.006, 3);
            assert!(
                (exact - sim).norm() < 2e-3 * exact.norm().max(1e-3),
                "r = {r}: {exact} against {sim}"
            );
            // A real play distorts: at half-width 0.3 a the third harmonic is several percent.
            if r >= 0.3 {
                assert!(exact.norm() > 0.02, "r = {r}: {exact}");
            }
            assert!((harmonic(0.5 * width, 0.006, 1) - simulated(width, 0.006, 1)).norm() < 1e-3);
        }
    }
}
