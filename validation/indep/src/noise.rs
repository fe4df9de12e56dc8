//! Measurement noise of the force-sensor ZMP: white plus first-order coloured noise, then
//! quantisation.
//!
//! The coloured part is the exact sampling of a first-order (Ornstein-Uhlenbeck) process of
//! stationary standard deviation `σ_c` and correlation time `τ_c`: the AR(1) recursion
//! `c_k = φ c_{k−1} + σ_c √(1−φ²) ε_k`, `φ = exp(−Δ/τ_c)`, started from its stationary law, so
//! its lag-m autocorrelation is `φ^m = exp(−mΔ/τ_c)` from the first sample on. This models
//! slow disturbances of the force sensors (cable motion, thermal and mechanical creep), the
//! white part their electronic noise. Each record draws from its own ChaCha8 stream (the
//! design's seed, stream = record index), so records are reproducible one by one and could be
//! simulated in any order.

use crate::robot::Noise;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// The noise generator of one record (both output axes).
pub(crate) struct MeasurementNoise {
    rng: ChaCha8Rng,
    white_std: f64,
    coloured_std: f64,
    phi: f64,
    innovation_std: f64,
    coloured: [f64; 2],
    quantisation: f64,
}

impl MeasurementNoise {
    /// The generator of record `index` of a campaign with noise seed `seed`, sample step `dt`.
    pub fn new(noise: &Noise, quantisation: f64, dt: f64, seed: u64, index: usize) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(index as u64);
        let phi = (-dt / noise.coloured_tau).exp();
        let mut coloured = [0.0; 2];
        if noise.coloured_std > 0.0 {
            for c in &mut coloured {
                let e: f64 = StandardNormal.sample(&mut rng);
                *c = noise.coloured_std * e;
            }
        }
        MeasurementNoise {
            rng,
            white_std: noise.white_std,
            coloured_std: noise.coloured_std,
            phi,
            innovation_std: noise.coloured_std * (1.0 - phi * phi).sqrt(),
            coloured,
            quantisation,
        }
    }

    /// The noise of the current sample for both axes; advances the coloured process.
    #[inline]
    pub fn next(&mut self) -> [f64; 2] {
        let mut out = [0.0; 2];
        for (i, o) in out.iter_mut().enumerate() {
            let mut n = self.coloured[i];
            if self.white_std > 0.0 {
                let e: f64 = StandardNormal.sample(&mut self.rng);
                n += self.white_std * e;
            }
            *o = n;
            if self.coloured_std > 0.0 {
                let e: f64 = StandardNormal.sample(&mut self.rng);
                self.coloured[i] = self.phi * self.coloured[i] + self.innovation_std * e;
            }
        }
        out
    }

    /// Rounds a reading to the quantisation step (identity when the step is 0).
    #[inline]
    pub fn quantise(&self, v: f64) -> f64 {
        if self.quantisation > 0.0 {
            (v / self.quantisation).round() * self.quantisation
        } else {
            v
        }
    }
}
