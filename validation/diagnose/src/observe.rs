//! What the diagnosis compares: per record, over its steady-state window, the first-harmonic
//! phasors of input and outputs, the third harmonics, and each output's linear trend, with
//! their noise variances.
//!
//! They come from the identification's own per-record analysis (one harmonic regression in
//! the crate: `[1, t - t_mid, sin k w t, cos k w t]` over whole periods of steady state, see
//! `identify`), so the diagnosis never refits a record. The variances follow the noise where
//! the components see it: the records' period-to-period variation at the excitation (first
//! harmonic) and at three times it (third), pooled over the campaign by frequency, and the
//! residual's power near zero frequency (trend); each with its degrees of freedom in
//! `zmp_identify::SteadyComponents`.

use num_complex::Complex64;
use zmp_identify::RecordFit;
use zmp_models::Axis;

/// The steady-state summary of one record.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// Position of the record in the campaign.
    pub index: usize,
    /// The axis the reference sine drives.
    pub excited: Axis,
    /// Excitation frequency, rad/s.
    pub omega: f64,
    /// Operating point `[x, y]` the sine is centred on, m.
    pub operating_point: [f64; 2],
    /// Reference amplitude the campaign commands, m (the describing functions' argument).
    pub nominal_amplitude: f64,
    /// Start of the steady-state window analysed, s.
    pub t0: f64,
    /// End of that window, s.
    pub t1: f64,
    /// Input first-harmonic phasor (sin-referenced), m.
    pub u1: Complex64,
    /// Output first-harmonic phasors `[zmp_x, zmp_y]`, m.
    pub y1: [Complex64; 2],
    /// Variance of the real (= imaginary) part of each `y1`, m² (coloured noise included).
    pub y1_var: [f64; 2],
    /// Third-harmonic phasors of the outputs, m.
    pub y3: [Complex64; 2],
    /// Variance of the real (= imaginary) part of each `y3`, m² (coloured noise included).
    pub y3_var: [f64; 2],
    /// Whether the third harmonic is compared with the model: three times the frequency lies
    /// within the campaign's excitation band, where the model's linear part is measured (above
    /// it a third harmonic would test an extrapolation of the fitted low-pass, not the
    /// distortion). Set over the campaign by [`mark_third_band`].
    pub third_band: bool,
    /// Linear trend of each output, m/s.
    pub slope: [f64; 2],
    /// Variance of each `slope`, (m/s)².
    pub slope_var: [f64; 2],
    /// Residual noise standard deviation of each output, m.
    pub noise_std: [f64; 2],
    /// Number of samples in the window.
    pub samples: usize,
}

impl Observation {
    /// The third harmonic of a response whose third harmonic is `g3` times the amplitude for
    /// an input of phase zero, for this record's input: the phase turns by three times the
    /// input's.
    pub fn third(&self, g3: Complex64) -> Complex64 {
        let a = self.u1.norm();
        if a == 0.0 {
            return Complex64::new(0.0, 0.0);
        }
        let p = self.u1 / a;
        g3 * a * p * p * p
    }

    /// Residual components this record contributes (see `measure::whitened`).
    pub fn components(&self) -> usize {
        if self.third_band {
            crate::measure::COMPONENTS
        } else {
            crate::measure::FIRST_COMPONENTS
        }
    }

    /// Measured frequency response of output `i` from the excited input.
    pub fn g(&self, i: usize) -> Complex64 {
        self.y1[i] / self.u1
    }

    /// Input amplitude, m.
    pub fn amplitude(&self) -> f64 {
        self.u1.norm()
    }

    /// Length of the analysed window, s.
    pub fn duration(&self) -> f64 {
        self.t1 - self.t0
    }
}

/// The observation of a record from its identification analysis (`None` when the record
/// could not be analysed). `nominal_amplitude` and `omega` are the campaign's.
pub fn observe(fit: &RecordFit) -> Option<Observation> {
    let c = fit.components.as_ref()?;
    let obs = Observation {
        index: fit.index,
        excited: fit.excited,
        omega: fit.omega,
        operating_point: fit.operating_point,
        nominal_amplitude: fit.amplitude,
        t0: c.t0,
        t1: c.t1,
        u1: c.u1,
        y1: c.y1,
        y1_var: [c.y1_var(0), c.y1_var(1)],
        y3: c.y3,
        y3_var: [c.y3_var(0), c.y3_var(1)],
        third_band: false,
        slope: c.trend,
        slope_var: [c.trend_var(0), c.trend_var(1)],
        noise_std: [c.residual_var[0].sqrt(), c.residual_var[1].sqrt()],
        samples: c.samples,
    };
    (obs.u1.norm() > 0.0 && obs.y1.iter().all(|y| y.re.is_finite() && y.im.is_finite()))
        .then_some(obs)
}

/// Marks the observations whose third harmonic lies within the campaign's excitation band
/// (three times their frequency at most the highest excited frequency).
pub fn mark_third_band(obs: &mut [Observation]) {
    let top = obs.iter().map(|o| o.omega).fold(0.0f64, f64::max);
    for o in obs.iter_mut() {
        o.third_band = 3.0 * o.omega <= top * (1.0 + 1e-9);
    }
}
