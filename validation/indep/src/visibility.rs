//! The visibility rule of drawn effects (see [`crate::draw`]): how much an effect changes the
//! first harmonics of a design's records against the noise.

use crate::design::Design;
use crate::draw::{VISIBLE_MIN_RECORDS, VISIBLE_RELATIVE, VISIBLE_SIGMAS};
use crate::integrate::simulate_records;
use crate::response::{record_noise_std, small_signal_response, steady_harmonic, Complex};
use crate::robot::{Effect, Noise, Robot};

/// The first harmonics of the probe design's records, per output.
pub(crate) type Harmonics = Vec<[Complex; 2]>;

/// How visible an effect is on a design.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Visibility {
    /// The verdict of the rule in the module docs.
    pub visible: bool,
    /// Largest change of a record's first harmonic, in noise standard deviations.
    pub max_sigmas: f64,
    /// Largest change of a record's first harmonic relative to it without the effect.
    pub max_relative: f64,
    /// Records that changed visibly.
    pub records: usize,
}

impl Visibility {
    /// Adds one record's first harmonics (per output) with and without the effect; the
    /// record counts `weight` times.
    fn add(&mut self, without: [Complex; 2], with: [Complex; 2], sigma: f64, weight: usize) {
        let mut counts = false;
        for i in 0..2 {
            let d = (with[i] - without[i]).abs();
            let sig = d / sigma.max(1e-300);
            let rel = d / without[i].abs().max(1e-300);
            self.max_sigmas = self.max_sigmas.max(sig);
            self.max_relative = self.max_relative.max(rel);
            counts |= sig >= VISIBLE_SIGMAS && rel >= VISIBLE_RELATIVE;
        }
        if counts {
            self.records += weight;
        }
        self.visible = self.records >= VISIBLE_MIN_RECORDS;
    }
}

/// The probe design of the nonlinear visibility test: the first operating point, noise-free,
/// the design's transient and one steady period.
fn probe_design(design: &Design) -> Design {
    Design {
        operating_points: vec![design.operating_points[0]],
        periods: 1.0,
        min_steady_s: 0.0,
        quantisation: 0.0,
        noise: Some(Noise::zero()),
        zmp_noise_std: None,
        ..design.clone()
    }
}

fn probe_harmonics(robot: &Robot, probe: &Design) -> Harmonics {
    let specs = probe.records();
    simulate_records(robot, probe, &specs)
        .iter()
        .map(|r| {
            let z = &r.truth.zmp_noise_free;
            [
                steady_harmonic(&r.meta, &r.t, &z[0]),
                steady_harmonic(&r.meta, &r.t, &z[1]),
            ]
        })
        .collect()
}

/// How visible `effect` (installed in `with`) is against `base` on `design`. `probe_cache`
/// keeps the base robot's probe harmonics between calls (same base, same design).
pub(crate) fn visibility(
    effect: Effect,
    base: &Robot,
    with: &Robot,
    design: &Design,
    probe_cache: &mut Option<Harmonics>,
) -> Visibility {
    let mut vis = Visibility::default();
    let records = design.records();
    match effect {
        Effect::Backlash
        | Effect::CoulombFriction
        | Effect::StribeckFriction
        | Effect::AccelerationSaturation
        | Effect::RateLimitedServo
        | Effect::CubicStiffness => {
            let probe = probe_design(design);
            let without = probe_cache
                .get_or_insert_with(|| probe_harmonics(base, &probe))
                .clone();
            let changed = probe_harmonics(with, &probe);
            let n_ops = design.operating_points.len();
            for k in 0..probe.records().len() {
                // Noise of the matching design record (the same at every operating point).
                let sigma = record_noise_std(base, design, &records[k]);
                vis.add(without[k], changed[k], sigma, n_ops);
            }
        }
        Effect::SensorDrift | Effect::SensorRezero => {
            for spec in &records {
                let Some(g) = small_signal_response(base, spec.operating_point, spec.omega) else {
                    continue;
                };
                let j = spec.excited.index();
                let without = [g[0][j].scale(spec.amplitude), g[1][j].scale(spec.amplitude)];
                let mut changed = without;
                // The drift's first harmonic is linear in the rate: the change is that of
                // the difference of the record's rates with and without.
                let (r1, r0) = (
                    with.sensor.record_drift_rate(spec.index),
                    base.sensor.record_drift_rate(spec.index),
                );
                for (i, c) in changed.iter_mut().enumerate() {
                    let d = 2.0 * (r1[i] - r0[i]).abs() / spec.omega;
                    *c = *c + Complex::new(d, 0.0);
                }
                vis.add(without, changed, record_noise_std(base, design, spec), 1);
            }
        }
        _ => {
            for spec in &records {
                let (Some(g0), Some(g1)) = (
                    small_signal_response(base, spec.operating_point, spec.omega),
                    small_signal_response(with, spec.operating_point, spec.omega),
                ) else {
                    continue;
                };
                let j = spec.excited.index();
                let a = spec.amplitude;
                vis.add(
                    [g0[0][j].scale(a), g0[1][j].scale(a)],
                    [g1[0][j].scale(a), g1[1][j].scale(a)],
                    record_noise_std(base, design, spec),
                    1,
                );
            }
        }
    }
    vis
}
