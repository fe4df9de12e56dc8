//! A perturbation of one channel ([`Perturbation`]: the stable all-pass that takes a given
//! value at one frequency), and the plant with it stepped in time ([`PerturbedPlant`]): what
//! the perturbation does to a closed loop, independently of the frequency-domain check that
//! names it.
//!
//! `G_k -> G_k (1 + W_k Delta)` on channel `k = (i, j)` is the nominal plant plus the path
//! `W_k Delta G_k u_j` into output `i`. Both are the project's plant stepper ([`Plant`]): the
//! nominal plant of the model file (every `uncertainty` at `Delta = 0`), and a copy whose
//! pendulum keeps only channel `k`'s coefficients, whose output `i` is then `G_k u_j` (the plant
//! is linear in its pendulum; a sensor drift, an offset that is no part of `G_k`, is left out of
//! the copy). `W_k Delta` is an exact discretisation of its transfer function
//! ([`DiscreteLti`]), its input ramping between the plant's internal steps as the plant's own
//! channel blocks do.

use super::Weights;
use crate::axis::Channel;
use crate::controller::{CascadeController, CascadeParams};
use crate::effect::{Binding, Site};
use crate::lti::{DiscreteLti, Poly, TransferFunction};
use crate::model_file::{ModelError, ModelSpec};
use crate::plant::Plant;
use num_complex::Complex64;

/// A stable perturbation of one channel, `Delta(s) = delta (q - s) / (q + s)` (the constant
/// `delta` without `q`): `|Delta(jw)| = |delta|` at every frequency, so it lies inside the
/// weight whenever `|delta| <= 1`. Any value `Delta(jw*)` is reached at one frequency: the
/// all-pass turns the phase by `-2 atan(w*/q)` (anywhere in `(-pi, 0)`), the sign of `delta`
/// by `pi`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Perturbation {
    pub channel: Channel,
    pub delta: f64,
    /// All-pass corner `q`, rad/s.
    pub allpass: Option<f64>,
    /// The frequency it was matched at, rad/s.
    pub omega: f64,
}

impl Perturbation {
    /// The perturbation of `channel` whose value at `j omega` is `target`.
    pub fn matching(channel: Channel, target: Complex64, omega: f64) -> Perturbation {
        use std::f64::consts::PI;
        let mag = target.norm();
        let theta = target.arg();
        let (delta, phase) = if theta <= 0.0 {
            (mag, theta)
        } else {
            (-mag, theta - PI)
        };
        // phase in (-pi, 0]: -2 atan(omega / q) = phase.
        let allpass = (phase < -1e-12).then(|| omega / (-phase / 2.0).tan());
        Perturbation {
            channel,
            delta,
            allpass,
            omega,
        }
    }

    /// The same perturbation with its gain multiplied by `factor`.
    pub fn scaled(&self, factor: f64) -> Perturbation {
        Perturbation {
            delta: self.delta * factor,
            ..*self
        }
    }

    pub fn at(&self, s: Complex64) -> Complex64 {
        match self.allpass {
            Some(q) => self.delta * (q - s) / (q + s),
            None => Complex64::new(self.delta, 0.0),
        }
    }

    pub fn transfer_function(&self) -> TransferFunction {
        match self.allpass {
            Some(q) => TransferFunction::new(
                Poly::new(&[self.delta * q, -self.delta]),
                Poly::new(&[q, 1.0]),
            ),
            None => TransferFunction::gain(self.delta),
        }
    }
}

/// The plant of a model file with one channel perturbed.
#[derive(Debug)]
pub struct PerturbedPlant {
    nominal: Plant,
    isolated: Plant,
    filter: DiscreteLti,
    output: usize,
    zmp: [f64; 2],
}

/// `spec` with every `uncertainty` at `Delta = 0`.
pub fn nominal_spec(spec: &ModelSpec) -> ModelSpec {
    let mut nominal = spec.clone();
    for b in Binding::all_for(Site::Channel) {
        nominal.set_value(crate::EffectKind::Uncertainty, *b, "delta", 0.0);
    }
    nominal
}

impl PerturbedPlant {
    /// `h`: the plants' internal step, s. The channel must carry a weight in `spec`.
    pub fn new(spec: &ModelSpec, p: &Perturbation, h: f64) -> Result<PerturbedPlant, ModelError> {
        let file = spec.name.clone().unwrap_or_else(|| "model".into());
        let w = Weights::from_model(spec)
            .get(p.channel)
            .ok_or_else(|| ModelError {
                file: file.clone(),
                key: format!("uncertainty.{}", p.channel),
                message: "the perturbed channel has no uncertainty weight".into(),
            })?;
        let nominal = nominal_spec(spec);
        let mut isolated = nominal.clone();
        isolated.remove(crate::EffectKind::SensorDrift);
        for ch in Channel::ALL {
            if ch != p.channel {
                for c in ["a", "b"] {
                    let key = format!("{c}{}", ch.suffix());
                    isolated.set_value(crate::EffectKind::Pendulum, Binding::Global, &key, 0.0);
                }
            }
        }
        let weight = TransferFunction::new(Poly::new(&[w.k * w.z, w.k]), Poly::new(&[w.p, 1.0]));
        Ok(PerturbedPlant {
            nominal: Plant::new(&nominal, h)?,
            isolated: Plant::new(&isolated, h)?,
            filter: DiscreteLti::new(&weight.mul(&p.transfer_function()), h),
            output: p.channel.output.index(),
            zmp: [0.0; 2],
        })
    }

    /// At rest for the constant CoM reference `com_ref`; returns the ZMP.
    pub fn reset(&mut self, com_ref: [f64; 2]) -> [f64; 2] {
        let mut zmp = self.nominal.reset(com_ref).zmp;
        let z = self.isolated.reset(com_ref).zmp[self.output];
        zmp[self.output] += self.filter.reset(z);
        self.zmp = zmp;
        zmp
    }

    pub fn step_size(&self) -> f64 {
        self.nominal.step_size()
    }

    /// Advances `n` internal steps with the reference held at `com_ref` (zero-order hold);
    /// returns the ZMP.
    pub fn advance(&mut self, com_ref: [f64; 2], n: usize) -> [f64; 2] {
        for _ in 0..n {
            let mut zmp = self.nominal.step_from(com_ref, com_ref).zmp;
            let z = self.isolated.step_from(com_ref, com_ref).zmp[self.output];
            zmp[self.output] += self.filter.step(z);
            self.zmp = zmp;
        }
        self.zmp
    }
}

/// The exponential growth rate (1/s) of a signal's envelope sampled every `dt` s: the slope of
/// `ln RMS` over consecutive windows of `window` s, from `start` s on, over the windows whose
/// RMS is above `floor` (below it a decaying loop has reached rounding). `-inf` when fewer than
/// three windows are above the floor: the signal has decayed away.
pub fn growth_rate(signal: &[f64], dt: f64, start: f64, window: f64, floor: f64) -> f64 {
    let per = ((window / dt).round() as usize).max(1);
    let first = (start / dt).round() as usize;
    let mut pts: Vec<(f64, f64)> = Vec::new();
    let mut k = first;
    while k + per <= signal.len() {
        let w = &signal[k..k + per];
        let rms = (w.iter().map(|x| x * x).sum::<f64>() / per as f64).sqrt();
        if rms.is_nan() || rms <= floor {
            break;
        }
        pts.push(((k as f64 + per as f64 / 2.0) * dt, rms.ln()));
        k += per;
    }
    if pts.len() < 3 {
        return f64::NEG_INFINITY;
    }
    let n = pts.len() as f64;
    let (mt, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = pts.iter().map(|p| (p.0 - mt) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mt).powi(2)).sum();
    sxy / sxx
}

/// The cascade controller (the project's digital one, [`CascadeController`]) closing the loop
/// on `plant` from rest at zero: the ZMP reference steps by `step` m on `axis` at t = 0.
/// Returns the ZMP error on that axis, one sample per controller period `period` (a whole
/// number of the plant's internal steps). The trunk-angle limits of `params` apply.
pub fn step_error(
    plant: &mut PerturbedPlant,
    params: CascadeParams,
    period: f64,
    axis: usize,
    step: f64,
    duration: f64,
) -> Vec<f64> {
    let sub = (period / plant.step_size()).round().max(1.0) as usize;
    let tc = sub as f64 * plant.step_size();
    let mut ctrl = CascadeController::new(params, tc);
    ctrl.reset_to_com([0.0, 0.0]);
    let mut zmp = plant.reset([0.0, 0.0]);
    let mut reference = [0.0; 2];
    reference[axis] = step;
    let n = (duration / tc).round() as usize;
    let mut err = Vec::with_capacity(n);
    for _ in 0..n {
        err.push(reference[axis] - zmp[axis]);
        let com_ref = ctrl.step(reference, zmp);
        zmp = plant.advance(com_ref, sub);
    }
    err
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perturbation_matches_any_value_with_its_gain_everywhere() {
        let ch = Channel::ALL[3];
        for k in 0..36 {
            let target = Complex64::from_polar(0.7, -3.1 + 6.2 * k as f64 / 35.0);
            let p = Perturbation::matching(ch, target, 2.5);
            let v = p.at(Complex64::new(0.0, 2.5));
            assert!((v - target).norm() < 1e-12, "{v} vs {target}");
            for w in [1e-3, 0.1, 1.0, 10.0, 1e3] {
                assert!((p.at(Complex64::new(0.0, w)).norm() - 0.7).abs() < 1e-12);
            }
            let tf = p.transfer_function();
            assert!((tf.freq(2.5) - target).norm() < 1e-12);
            // Stable: the all-pass pole is at -q < 0.
            assert!(p.allpass.is_none_or(|q| q > 0.0));
        }
    }
}
