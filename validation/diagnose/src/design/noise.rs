//! The noise a designed record will carry, from the campaign's own noise estimate.
//!
//! One sensor, one noise: per output, the variance of a record's first-harmonic phasor times
//! its steady window `W` is the noise's power density at the excitation frequency (for white
//! noise of variance `s²` sampled every `dt`, `var(Re y1) W = 2 s² dt`; coloured noise makes it
//! a function of frequency). The densities of every record (first harmonic at `w`, third
//! harmonic at `3 w`) are pooled across the campaign's records by frequency (their median:
//! a record whose estimate failed cannot move it) and interpolated in log-log between the
//! campaign's frequencies, held at the end values beyond them. The trend's variance scales as
//! `1 / W³` (a slope's standard error over a window `W`), pooled the same way. The sensor
//! noise does not depend on the amplitude, so a candidate record's variances are these
//! densities over its own steady window.

use crate::observe::Observation;

/// Pooled noise densities per output.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseModel {
    /// Per output `[zmp_x, zmp_y]`: `(omega rad/s, density m² s)`, ascending in frequency.
    density: [Vec<(f64, f64)>; 2],
    /// Per output: the trend variance times the window cubed, m² s.
    trend: [f64; 2],
    /// Median per-sample residual standard deviation over records and outputs, m.
    pub sample_std: f64,
}

/// Why a campaign gives no noise model: the output (0: `zmp_x`, 1: `zmp_y`) that has none.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NoNoise {
    /// Index of the output without a noise estimate.
    pub output: usize,
}

/// A usable variance: finite and positive.
fn usable(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Pools `(frequency, value)` samples by frequency (their median), ascending.
fn pool(mut samples: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out = Vec::new();
    let mut k = 0;
    while k < samples.len() {
        let w = samples[k].0;
        let mut same = Vec::new();
        while k < samples.len() && (samples[k].0 - w).abs() <= 1e-9 * w {
            same.push(samples[k].1);
            k += 1;
        }
        out.push((w, median(same)));
    }
    out
}

impl NoiseModel {
    /// The campaign's noise model from its observations; [`NoNoise`] names an output for
    /// which no record has a usable first-harmonic variance (a campaign simulated without
    /// noise, or records too short for an estimate).
    pub fn of(obs: &[&Observation]) -> Result<NoiseModel, NoNoise> {
        let mut density: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
        let mut trend = [0.0; 2];
        for (i, d) in density.iter_mut().enumerate() {
            let mut samples = Vec::new();
            let mut trends = Vec::new();
            let mut first = 0;
            for o in obs {
                let w = o.duration();
                // A record whose residual holds no noise has no estimate.
                if !(w > 0.0 && usable(o.noise_std[i])) {
                    continue;
                }
                if usable(o.y1_var[i]) {
                    samples.push((o.omega, o.y1_var[i] * w));
                    first += 1;
                }
                if usable(o.y3_var[i]) {
                    samples.push((3.0 * o.omega, o.y3_var[i] * w));
                }
                if usable(o.slope_var[i]) {
                    trends.push(o.slope_var[i] * w * w * w);
                }
            }
            if first == 0 || trends.is_empty() {
                return Err(NoNoise { output: i });
            }
            *d = pool(samples);
            trend[i] = median(trends);
        }
        let stds: Vec<f64> = obs
            .iter()
            .flat_map(|o| o.noise_std)
            .filter(|s| s.is_finite() && *s > 0.0)
            .collect();
        let sample_std = if stds.is_empty() { 0.0 } else { median(stds) };
        Ok(NoiseModel {
            density,
            trend,
            sample_std,
        })
    }

    /// The noise density of output `i` at `omega`, m² s: log-log interpolation between the
    /// pooled frequencies, the end values beyond them.
    pub fn density(&self, i: usize, omega: f64) -> f64 {
        let d = &self.density[i];
        if omega <= d[0].0 {
            return d[0].1;
        }
        let last = d[d.len() - 1];
        if omega >= last.0 {
            return last.1;
        }
        let k = d.partition_point(|p| p.0 <= omega);
        let (a, b) = (d[k - 1], d[k]);
        let t = (omega / a.0).ln() / (b.0 / a.0).ln();
        (a.1.ln() + t * (b.1 / a.1).ln()).exp()
    }

    /// Variances `(first harmonic, third harmonic, trend)` of output `i` for a record at
    /// `omega` with a steady window of `window` s.
    pub fn variances(&self, i: usize, omega: f64, window: f64) -> (f64, f64, f64) {
        (
            self.density(i, omega) / window,
            self.density(i, 3.0 * omega) / window,
            self.trend[i] / window.powi(3),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex64;
    use zmp_models::Axis;

    pub(crate) fn obs(omega: f64, window: f64, var: f64) -> Observation {
        Observation {
            index: 0,
            excited: Axis::X,
            omega,
            operating_point: [0.0; 2],
            nominal_amplitude: 0.005,
            t0: 1.0,
            t1: 1.0 + window,
            u1: Complex64::new(0.005, 0.0),
            y1: [Complex64::new(0.004, 0.0); 2],
            y1_var: [var; 2],
            y3: [Complex64::new(0.0, 0.0); 2],
            y3_var: [var; 2],
            third_band: false,
            slope: [0.0; 2],
            slope_var: [var / window / window; 2],
            noise_std: [5e-4; 2],
            samples: (window * 200.0) as usize,
        }
    }

    /// White noise: the density is the same at every frequency and a record's variance goes
    /// as one over its window; a frequency between two pooled ones is interpolated in log-log
    /// (a power law is reproduced exactly).
    #[test]
    fn densities_scale_with_the_window_and_interpolate_power_laws() {
        let a = obs(1.0, 10.0, 2e-10);
        let b = obs(1.0, 20.0, 1e-10);
        let m = NoiseModel::of(&[&a, &b]).unwrap();
        let (v1, _, _) = m.variances(0, 1.0, 40.0);
        assert!((v1 / 5e-11 - 1.0).abs() < 1e-12, "{v1}");
        // Density 1 at 1 rad/s and 100 at 10 rad/s: a square law, 25 at 5 rad/s.
        let c = obs(1.0, 1.0, 1.0);
        let mut d = obs(10.0, 1.0, 100.0);
        d.y3_var = [f64::NAN; 2];
        let mut c3 = c.clone();
        c3.y3_var = [f64::NAN; 2];
        let m = NoiseModel::of(&[&c3, &d]).unwrap();
        assert!((m.density(0, 5.0) / 25.0 - 1.0).abs() < 1e-9);
        assert_eq!(m.density(0, 0.1), 1.0);
        assert_eq!(m.density(0, 50.0), 100.0);
    }

    #[test]
    fn no_usable_variance_is_no_noise_model() {
        let mut a = obs(1.0, 10.0, 0.0);
        a.slope_var = [0.0; 2];
        let mut b = obs(2.0, 10.0, f64::NAN);
        b.slope_var = [f64::NAN; 2];
        assert_eq!(NoiseModel::of(&[&a, &b]), Err(NoNoise { output: 0 }));
    }
}
