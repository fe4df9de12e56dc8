//! Multiplicative uncertainty of one channel (first seed, sections 6.4–6.5):
//! `G_ij -> G_ij (1 + W_ij(s) Delta_ij(s))` with the weight `W(s) = k (s + z)/(s + p)` and
//! `||Delta||_inf <= 1`.
//!
//! The realisation of `Delta` is chosen by two parameters:
//! - `delta = 0`: nominal (no uncertainty acts);
//! - `delta_seed = 0`, `delta != 0`: the constant `Delta = delta`, `|delta| <= 1`;
//! - `delta_seed = n > 0`: a random stable `Delta(s) = delta * A(s) * L(s)`, drawn from the seed,
//!   with `A` a product of up to two all-pass sections `(q - s)/(q + s)` (`|A| = 1` exactly) and
//!   `L = (1 - mu) + mu wc/(s + wc)`, a convex mix whose gain never exceeds one; so
//!   `||Delta||_inf <= |delta| <= 1` holds by construction.

use crate::effect::{BuildContext, Effect, EffectInfo, ParamSpec, Site};
use crate::lti::{Poly, TransferFunction};
use crate::lti_effect::LtiEffect;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub static PARAMS: [ParamSpec; 5] = [
    ParamSpec::required("k", "1", 0.0, 1e3, "high-frequency gain of the weight W"),
    ParamSpec::required("z", "rad/s", 0.0, 1e4, "zero of the weight W"),
    ParamSpec::required(
        "p",
        "rad/s",
        1e-6,
        1e4,
        "pole of the weight W (stable: p > 0)",
    ),
    ParamSpec::optional(
        "delta",
        "1",
        -1.0,
        1.0,
        0.0,
        "Delta gain; 0 is the nominal model",
    ),
    ParamSpec::optional(
        "delta_seed",
        "1",
        0.0,
        4294967295.0,
        0.0,
        "0: constant Delta = delta; n > 0: random stable Delta drawn from seed n",
    ),
];

pub static INFO: EffectInfo = EffectInfo {
    kind: crate::EffectKind::Uncertainty,
    title: "multiplicative uncertainty W(s) Delta(s)",
    doc: "G_ij (1 + W_ij Delta_ij), W = k (s+z)/(s+p), |Delta| <= 1.",
    site: Site::Channel,
    core: false,
    linear: true,
    params: &PARAMS,
    validate: Some(validate),
    build,
};

fn validate(v: &[f64]) -> Result<(), (usize, String)> {
    if v[4].fract() != 0.0 {
        return Err((4, format!("delta_seed = {} must be a whole number", v[4])));
    }
    Ok(())
}

/// `W(s) = k (s + z)/(s + p)`.
pub fn weight(k: f64, z: f64, p: f64) -> TransferFunction {
    TransferFunction::new(Poly::new(&[k * z, k]), Poly::new(&[p, 1.0]))
}

/// The realisation of `Delta` described in the module docs.
pub fn delta(gain: f64, seed: u64) -> TransferFunction {
    let mut d = TransferFunction::gain(gain);
    if seed == 0 || gain == 0.0 {
        return d;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sections = rng.gen_range(0..=2);
    for _ in 0..sections {
        let q = 10f64.powf(rng.gen_range(-1.0..2.0));
        d = d.mul(&TransferFunction::new(
            Poly::new(&[q, -1.0]),
            Poly::new(&[q, 1.0]),
        ));
    }
    let mu: f64 = rng.gen_range(0.0..1.0);
    let wc = 10f64.powf(rng.gen_range(-1.0..2.0));
    let mix = TransferFunction::gain(1.0 - mu).add(&TransferFunction::new(
        Poly::new(&[mu * wc]),
        Poly::new(&[wc, 1.0]),
    ));
    d.mul(&mix)
}

/// `1 + W(s) Delta(s)` for the parameter values in [`PARAMS`] order.
pub fn channel_factor(v: &[f64]) -> TransferFunction {
    let w = weight(v[0], v[1], v[2]);
    TransferFunction::gain(1.0).add(&w.mul(&delta(v[3], v[4] as u64)))
}

fn build(ctx: &BuildContext, v: &[f64]) -> Box<dyn Effect> {
    if v[3] == 0.0 {
        // Nominal: 1 + W * 0 is exactly one; skip the filter.
        return Box::new(Nominal);
    }
    Box::new(LtiEffect::new(&INFO, channel_factor(v), ctx.h))
}

/// The nominal realisation `Delta = 0`: the channel passes unchanged.
#[derive(Debug, Clone, Copy)]
struct Nominal;

impl Effect for Nominal {
    fn info(&self) -> &'static EffectInfo {
        &INFO
    }
    fn frequency_response(&self, _omega: f64, _amplitude: f64) -> num_complex::Complex64 {
        num_complex::Complex64::new(1.0, 0.0)
    }
    fn reset(&mut self, u: f64) -> f64 {
        u
    }
    fn transfer_function(&self) -> Option<TransferFunction> {
        Some(TransferFunction::gain(1.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn random_delta_is_stable_with_hinf_norm_at_most_gain() {
        for seed in 1..200u64 {
            let d = delta(0.9, seed);
            // Stable: all denominator roots in the left half plane, checked by the response
            // being finite and bounded on a dense grid including very low and high frequencies.
            let mut peak: f64 = 0.0;
            for k in 0..4000 {
                let w = 10f64.powf(-4.0 + 8.0 * k as f64 / 3999.0);
                peak = peak.max(d.freq(w).norm());
            }
            assert!(peak <= 0.9 + 1e-12, "seed {seed}: peak {peak}");
            for c in &d.den.0 {
                assert!(
                    *c > 0.0,
                    "seed {seed}: denominator of a stable product has positive coefficients"
                );
            }
        }
    }
}
