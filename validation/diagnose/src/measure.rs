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
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, Channel, ModelSpec, Plant};

/// Internal step used to evaluate models in the diagnosis, s.
pub const EVAL_STEP: f64 = 0.001;

/// The model's steady-state prediction for one record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// First harmonic of each output `[zmp_x, zmp_y]` over the input's first harmonic.
    pub g: [Complex64; 2],
    /// Third harmonic of each output over the input's amplitude, for an input of phase zero
    /// (see [`Observation::third`]); zero for a linear model.
    pub g3: [Complex64; 2],
    /// Linear trend of each output over the window, m/s (compared with the record's).
    pub slope: [f64; 2],
}

/// Squared error and squared noise floor of one record (already normalised).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordScore {
    /// Squared prediction error, summed over both outputs.
    pub error2: f64,
    /// Squared noise floor: the error noise alone would produce.
    pub floor2: f64,
}

impl RecordScore {
    /// The record's error (root of `error2`).
    pub fn error(&self) -> f64 {
        self.error2.sqrt()
    }
    /// The record's noise floor (root of `floor2`).
    pub fn floor(&self) -> f64 {
        self.floor2.sqrt()
    }
}

/// Predictions of `spec` for every observation. Models with nonlinear effects (describing
/// functions from simulation) are evaluated on the thread budget ([`zmp_campaign::par::budget`]:
/// inside a candidate's fit, which already runs beside the others, 1 plus the pool's idle
/// workers), split by frequency so that each describing function is computed once.
pub fn predict(
    spec: &ModelSpec,
    obs: &[&Observation],
) -> Result<Vec<Prediction>, zmp_models::ModelError> {
    Ok(predict_until(spec, obs, &|| false)?.expect("never stopped"))
}

/// [`predict`] that gives up (`Ok(None)`) once the time limit of the work it serves has
/// passed ([`zmp_campaign::par::past_deadline`]), checked before each record: what a fit's evaluation
/// uses, so that a fit past the limit ends with its best so far. A deadline checked only
/// before each evaluation lets one evaluation of a model with a friction, whose stick-slip
/// records are simulated one by one (seconds each), run past it by the time of all of them.
pub fn predict_in_time(
    spec: &ModelSpec,
    obs: &[&Observation],
) -> Result<Option<Vec<Prediction>>, zmp_models::ModelError> {
    predict_until(spec, obs, &zmp_campaign::par::past_deadline)
}

/// [`predict`] that asks `stop` before each record (on every worker) and gives up
/// (`Ok(None)`) at the first `true`.
pub fn predict_until(
    spec: &ModelSpec,
    obs: &[&Observation],
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<Option<Vec<Prediction>>, zmp_models::ModelError> {
    let nonlinear = spec.effects.iter().any(|e| !e.info.linear);
    let workers = zmp_campaign::par::budget().min(obs.len() / 4);
    if !nonlinear || workers < 2 {
        return predict_serial(spec, obs, stop);
    }
    let omegas = {
        let mut w: Vec<f64> = obs.iter().map(|o| o.omega).collect();
        w.sort_by(f64::total_cmp);
        w.dedup();
        w
    };
    // Deal the frequencies out in turn: the low ones cost the most.
    let part_of =
        |o: &Observation| omegas.iter().position(|w| *w == o.omega).unwrap_or(0) % workers;
    let parts: Vec<Vec<usize>> = (0..workers)
        .map(|p| (0..obs.len()).filter(|&k| part_of(obs[k]) == p).collect())
        .collect();
    let results = zmp_campaign::par::parallel_map(workers, workers, |p| {
        let mine: Vec<&Observation> = parts[p].iter().map(|&k| obs[k]).collect();
        predict_serial(spec, &mine, stop)
    });
    let mut out = vec![
        Prediction {
            g: [Complex64::new(0.0, 0.0); 2],
            g3: [Complex64::new(0.0, 0.0); 2],
            slope: [0.0; 2]
        };
        obs.len()
    ];
    for (ix, r) in parts.iter().zip(results) {
        let Some(r) = r? else {
            return Ok(None);
        };
        for (&k, p) in ix.iter().zip(r) {
            out[k] = p;
        }
    }
    Ok(Some(out))
}

fn predict_serial(
    spec: &ModelSpec,
    obs: &[&Observation],
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<Option<Vec<Prediction>>, zmp_models::ModelError> {
    let mut plant = Plant::new(spec, EVAL_STEP)?;
    let nonlinear = spec.effects.iter().any(|e| !e.info.linear);
    let rate = |i: usize| {
        spec.value(
            EffectKind::SensorDrift,
            Binding::Axis(Axis::from_index(i).expect("0 or 1")),
            "rate",
        )
        .unwrap_or(0.0)
    };
    let rates = [rate(0), rate(1)];
    // A drift per record: each record's trend is its own (a nuisance parameter, counted by
    // the criterion: `HeldOut::nuisance`).
    let own = [0, 1].map(|i| crate::profiles::drift_per_record(spec, i));
    let mut out = Vec::with_capacity(obs.len());
    for o in obs {
        if stop() {
            return Ok(None);
        }
        plant.set_operating_point(o.operating_point);
        let j = o.excited.index();
        let mut g = [Complex64::new(0.0, 0.0); 2];
        let mut g3 = [Complex64::new(0.0, 0.0); 2];
        if nonlinear {
            for i in 0..2 {
                let ch = Channel::new(Axis::from_index(i).expect("0 or 1"), o.excited);
                // The third harmonic only where it is compared.
                if o.third_band {
                    (g[i], g3[i]) = plant.describing_harmonics(ch, o.omega, o.nominal_amplitude);
                } else {
                    g[i] = plant.describing_response(ch, o.omega, o.nominal_amplitude);
                }
            }
        } else {
            let fr = plant.frequency_response(o.omega);
            g = [fr[0][j], fr[1][j]];
        }
        out.push(Prediction {
            g,
            g3,
            slope: [0, 1].map(|i| if own[i] { o.slope[i] } else { rates[i] }),
        });
    }
    Ok(Some(out))
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

/// Residuals for fitting: the record's error measure split into its parts (real and imaginary
/// first-harmonic misfit and trend misfit of each output, over the record's normalisation), so
/// that the least-squares cost is exactly the sum over records of the squared error measure
/// the diagnosis scores with.
pub fn residuals(o: &Observation, p: &Prediction, out: &mut Vec<f64>) {
    let t = o.duration();
    let den: f64 = (0..2)
        .map(|i| 0.5 * o.y1[i].norm_sqr())
        .sum::<f64>()
        .max(1e-300);
    let k1 = (0.5 / den).sqrt();
    let k2 = (t * t / (12.0 * den)).sqrt();
    for i in 0..2 {
        let d = o.y1[i] - p.g[i] * o.u1;
        out.push(d.re * k1);
        out.push(d.im * k1);
        out.push((o.slope[i] - p.slope[i]) * k2);
    }
}

/// Relative accuracy floor of a measured first harmonic, added in quadrature to its noise
/// (the identification's default `relative_floor`): what white-noise statistics do not
/// describe (sensor calibration, sampling, the model's own numerics).
pub const REL_FLOOR: f64 = 3e-4;

/// Residual components of one record at most: the real and imaginary first-harmonic misfit,
/// the trend misfit and (within the third-harmonic band, see [`Observation::third_band`]) the
/// real and imaginary third-harmonic misfit of each output.
pub const COMPONENTS: usize = 10;

/// Of which the first-harmonic and trend components, which every record has.
pub const FIRST_COMPONENTS: usize = 6;

/// Residual components the observations contribute: the chi-square of a right model is about
/// this.
pub fn components(obs: &[&Observation]) -> usize {
    obs.iter().map(|o| o.components()).sum()
}

/// Noise-weighted residuals of one record: each component of the misfit over its own
/// standard deviation (first and third harmonic: the measured phasor's noise at its
/// frequency, coloured noise included, with [`REL_FLOOR`] of the first harmonic; trend: the
/// fitted trend's). Their sum of squares is the record's chi-square, about
/// [`Observation::components`] for a model that is right. First the six first-harmonic and
/// trend components (per output: real, imaginary, trend), then, where the third harmonic is
/// compared ([`Observation::third_band`]), its four (per output: real, imaginary). The third
/// harmonic is what tells a distortion (friction, play, a clamp) from a linear effect of the
/// same first-harmonic shape.
pub fn whitened(o: &Observation, p: &Prediction, out: &mut Vec<f64>) {
    let floor = |i: usize| (REL_FLOOR * o.y1[i].norm()).powi(2);
    for i in 0..2 {
        let d = o.y1[i] - p.g[i] * o.u1;
        let s1 = (o.y1_var[i] + floor(i)).sqrt().max(1e-300);
        let s2 = o.slope_var[i].sqrt().max(1e-300);
        out.push(d.re / s1);
        out.push(d.im / s1);
        out.push((o.slope[i] - p.slope[i]) / s2);
    }
    if o.third_band {
        for i in 0..2 {
            let d3 = o.y3[i] - o.third(p.g3[i]);
            let s3 = (o.y3_var[i] + floor(i)).sqrt().max(1e-300);
            out.push(d3.re / s3);
            out.push(d3.im / s3);
        }
    }
}

/// The chi-square of records against their predictions: [`chi2`] summed (about
/// [`components`] for a model that is right).
pub fn chi2_total(obs: &[&Observation], preds: &[Prediction]) -> f64 {
    obs.iter().zip(preds).map(|(o, p)| chi2(o, p)).sum()
}

/// The chi-square of records against their predictions in two parts, each with its count of
/// components: first harmonic and trend, and the third harmonic (where compared). A misfit of
/// one part is judged against that part's own count, so well-predicted third harmonics cannot
/// dilute a first-harmonic misfit (nor the other way round).
pub fn chi2_parts(obs: &[&Observation], preds: &[Prediction]) -> [(f64, usize); 2] {
    let mut parts = [(0.0, 0), (0.0, 0)];
    let mut r = Vec::with_capacity(COMPONENTS);
    for (o, p) in obs.iter().zip(preds) {
        r.clear();
        whitened(o, p, &mut r);
        let (first, third) = r.split_at(FIRST_COMPONENTS);
        for (part, v) in parts.iter_mut().zip([first, third]) {
            part.0 += v.iter().map(|x| x * x).sum::<f64>();
            part.1 += v.len();
        }
    }
    parts
}

/// The chi-square of one record against a prediction (see [`whitened`]).
pub fn chi2(o: &Observation, p: &Prediction) -> f64 {
    let mut r = Vec::with_capacity(COMPONENTS);
    whitened(o, p, &mut r);
    r.iter().map(|v| v * v).sum()
}
