//! The one error measure of the diagnosis, and its noise floor.
//!
//! Per record: the RMS over the steady-state window of the difference between the measured and
//! the modelled steady-state response (first harmonic and linear trend of both ZMP outputs),
//! divided by the RMS of the measured first harmonic: an NRMSE of the steady-state time series,
//! computed exactly from the fitted components. The campaign figure is the RMS over records, so
//! a failure in a few records (one band, one amplitude) still counts. The noise floor is the same
//! measure for the estimation noise of the measured components alone: what a perfect model
//! would score.

use super::observe::Observation;
use num_complex::Complex64;
use zmp_models::{Axis, Binding, Channel, ModelSpec, Plant};

/// Internal step used to evaluate models in the diagnosis, s.
pub const EVAL_STEP: f64 = 0.002;

/// The model's steady-state prediction for one record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    pub g: [Complex64; 2],
    pub slope: [f64; 2],
}

/// Squared error and squared noise floor of one record (already normalised).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordScore {
    pub error2: f64,
    pub floor2: f64,
}

impl RecordScore {
    pub fn error(&self) -> f64 {
        self.error2.sqrt()
    }
    pub fn floor(&self) -> f64 {
        self.floor2.sqrt()
    }
}

/// Predictions of `spec` for every observation.
pub fn predict(
    spec: &ModelSpec,
    obs: &[&Observation],
) -> Result<Vec<Prediction>, zmp_models::ModelError> {
    let mut plant = Plant::new(spec, EVAL_STEP)?;
    let nonlinear = spec.effects.iter().any(|e| !e.info.linear);
    let rate = |i: usize| {
        spec.value(
            "sensor_drift",
            Binding::Axis(Axis::from_index(i).expect("0 or 1")),
            "rate",
        )
        .unwrap_or(0.0)
    };
    let rates = [rate(0), rate(1)];
    let mut out = Vec::with_capacity(obs.len());
    for o in obs {
        plant.set_operating_point(o.operating_point);
        let j = o.excited.index();
        let mut g = [Complex64::new(0.0, 0.0); 2];
        if nonlinear {
            for (i, gi) in g.iter_mut().enumerate() {
                let ch = Channel::new(Axis::from_index(i).expect("0 or 1"), o.excited);
                *gi = plant.describing_response(ch, o.omega, o.amplitude());
            }
        } else {
            let fr = plant.frequency_response(o.omega);
            g = [fr[0][j], fr[1][j]];
        }
        out.push(Prediction { g, slope: rates });
    }
    Ok(out)
}

/// Error and floor of one record against a prediction.
pub fn score(o: &Observation, p: &Prediction) -> RecordScore {
    let t = o.duration();
    let mut num = 0.0;
    let mut floor = 0.0;
    let mut den = 0.0;
    for i in 0..2 {
        let d = o.y1[i] - p.g[i] * o.u1;
        num += 0.5 * d.norm_sqr() + (o.slope[i] - p.slope[i]).powi(2) * t * t / 12.0;
        floor += o.y1_var[i] + o.slope_var[i] * t * t / 12.0;
        den += 0.5 * o.y1[i].norm_sqr();
    }
    let den = den.max(1e-300);
    RecordScore {
        error2: num / den,
        floor2: floor / den,
    }
}

/// RMS over records of the per-record figures: `(error, noise floor)`.
pub fn aggregate(scores: &[RecordScore]) -> (f64, f64) {
    if scores.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let n = scores.len() as f64;
    let e = scores.iter().map(|s| s.error2).sum::<f64>() / n;
    let f = scores.iter().map(|s| s.floor2).sum::<f64>() / n;
    (e.sqrt(), f.sqrt())
}

/// Weighted residuals for fitting: real and imaginary first-harmonic misfit and trend misfit,
/// each over its noise standard deviation.
pub fn residuals(o: &Observation, p: &Prediction, out: &mut Vec<f64>) {
    for i in 0..2 {
        let d = o.y1[i] - p.g[i] * o.u1;
        let s = o.y1_var[i].sqrt().max(1e-12);
        out.push(d.re / s);
        out.push(d.im / s);
        out.push((o.slope[i] - p.slope[i]) / o.slope_var[i].sqrt().max(1e-15));
    }
}
