//! Steps 1-3 for each record (steady state, FFT first estimate, harmonic regression, the
//! record's noise from its periods) and the campaign-wide pooling of the noise (`noise`).

use super::{
    noise, reason, sine, steady, worker_count, IdentifyOptions, NoisePower, NoiseSource,
    OutputNoise, RecordFit, SteadyComponents,
};
use num_complex::Complex64;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicUsize, Ordering};
use zmp_campaign::par::parallel_map;
use zmp_campaign::{Campaign, Record};

fn excluded(rec: &Record, index: usize, why: &str) -> RecordFit {
    RecordFit {
        index,
        excited: rec.meta.excited,
        omega: rec.meta.omega,
        omega_fit: rec.meta.omega,
        amplitude: rec.meta.amplitude,
        input_amplitude: 0.0,
        operating_point: rec.meta.operating_point,
        g: [Complex64::new(f64::NAN, f64::NAN); 2],
        sigma: [f64::NAN; 2],
        distortion: [f64::NAN; 2],
        input_distortion: f64::NAN,
        third_harmonic_snr: [f64::NAN; 2],
        noise_std: [f64::NAN; 2],
        steady_start_s: 0.0,
        periods: 0,
        excluded: Some(why.to_string()),
        components: None,
    }
}

fn is_constant(v: &[f64]) -> bool {
    match v.first() {
        None => true,
        Some(&f) => v.iter().all(|&x| x == f),
    }
}

/// Steps 1-3 for one record (`index` is its place in the campaign).
pub fn analyse_record(rec: &Record, index: usize, opts: &IdentifyOptions) -> RecordFit {
    let omega = rec.meta.omega;
    let dt = rec.dt();
    let [u, yx, yy] = match centred_signals(rec) {
        Ok(signals) => signals,
        Err(why) => return excluded(rec, index, why),
    };
    // 1. Steady state.
    let Some(st) = steady::detect_steady([&u[..], &yx[..], &yy[..]], omega, dt) else {
        return excluded(rec, index, reason::TOO_SHORT);
    };
    if st.periods < 2 {
        return excluded_after_steady(rec, index, reason::NO_STEADY, &st, dt);
    }
    let range = st.start..st.start + st.len;
    let sig = [&u[range.clone()], &yx[range.clone()], &yy[range]];
    // 2. First estimate: the excitation must be where the manifest says.
    if !excitation_where_declared(sig[0], omega, dt, st.len) {
        return excluded_after_steady(rec, index, reason::WRONG_FREQUENCY, &st, dt);
    }
    // 3. Harmonic regression at the refined frequency.
    let k_max = opts.harmonics.clamp(1, 8);
    let Some((w, hf)) = refined_harmonic_fit(sig, omega, dt, k_max) else {
        return excluded(rec, index, reason::BAD_DATA);
    };
    let noise = output_noises(sig, &hf, w, dt, &st, k_max);
    let p_in = hf.harmonics[0][0];
    let amp_in = p_in.norm();
    if amp_in.is_nan() || amp_in <= 1e-3 * rec.meta.amplitude.abs() || !amp_in.is_finite() {
        return excluded(rec, index, reason::ZERO_AMPLITUDE);
    }
    let out = OutputEstimates::from_fit(&hf, st.len as f64, k_max, opts.relative_floor);
    let harm_in: f64 = hf.harmonics[0][1..].iter().map(|h| h.norm_sqr()).sum();
    RecordFit {
        index,
        excited: rec.meta.excited,
        omega,
        omega_fit: w,
        amplitude: rec.meta.amplitude,
        input_amplitude: amp_in,
        operating_point: rec.meta.operating_point,
        g: out.g,
        sigma: out.sigma,
        distortion: out.distortion,
        input_distortion: harm_in.sqrt() / amp_in,
        third_harmonic_snr: out.snr3,
        noise_std: out.noise_std,
        steady_start_s: st.start as f64 * dt,
        periods: st.periods,
        excluded: None,
        components: Some(steady_components(rec, &st, &hf, w, dt, noise)),
    }
}

/// The excitation and both ZMP outputs, each less its mean (conditioning of the fits), or
/// why the record cannot be analysed: too short for two periods of at least four samples, no
/// excitation, a constant output, a sample that is not finite.
fn centred_signals(rec: &Record) -> Result<[Vec<f64>; 3], &'static str> {
    let omega = rec.meta.omega;
    let dt = rec.dt();
    if !(dt.is_finite() && dt > 0.0 && omega.is_finite() && omega > 0.0) {
        return Err(reason::TOO_SHORT);
    }
    let per = 2.0 * PI / (omega * dt);
    if (rec.len() as f64) < 2.0 * per || per < 4.0 {
        return Err(reason::TOO_SHORT);
    }
    let input = rec.excitation();
    if rec.meta.amplitude <= 0.0 || is_constant(input) {
        return Err(reason::ZERO_AMPLITUDE);
    }
    if is_constant(&rec.zmp_x) || is_constant(&rec.zmp_y) {
        return Err(reason::CONSTANT_OUTPUT);
    }
    let centre = |v: &[f64]| -> Vec<f64> {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        v.iter().map(|x| x - m).collect()
    };
    let signals = [centre(input), centre(&rec.zmp_x), centre(&rec.zmp_y)];
    if !signals.iter().all(|s| s.iter().all(|v| v.is_finite())) {
        return Err(reason::BAD_DATA);
    }
    Ok(signals)
}

/// A record left out after its steady state was found: where it starts and its periods are
/// reported with the reason.
fn excluded_after_steady(
    rec: &Record,
    index: usize,
    why: &str,
    st: &steady::Steady,
    dt: f64,
) -> RecordFit {
    let mut r = excluded(rec, index, why);
    r.steady_start_s = st.start as f64 * dt;
    r.periods = st.periods;
    r
}

/// Whether the windowed FFT of the steady input (`n` samples) peaks within two FFT bins of
/// the manifest's `omega` (rad/s) with a non-zero amplitude.
fn excitation_where_declared(input: &[f64], omega: f64, dt: f64, n: usize) -> bool {
    let (fft_phasors, w_fft) = sine::fft_estimate([input], omega, dt);
    let bin = 2.0 * PI / (n as f64 * dt);
    !((w_fft - omega).abs() > 2.0 * bin || fft_phasors[0].norm() == 0.0)
}

/// The harmonic regression with a trend column (a drifting sensor's ramp stays out of the
/// harmonics), the frequency refined on the signals less that trend, and the fit with the
/// trend column at the refined frequency (from the refinement's own pass; the first fit if
/// the frequency stayed): the refined frequency (rad/s) and that fit.
fn refined_harmonic_fit(
    sig: [&[f64]; 3],
    omega: f64,
    dt: f64,
    k_max: usize,
) -> Option<(f64, sine::HarmonicFit<3>)> {
    let first = sine::harmonic_fit_trend(sig, omega, dt, k_max)?;
    let (w, moved) = sine::refine_frequency(sig, first.trend, omega, dt, k_max)?;
    Some((w, moved.unwrap_or(first)))
}

/// The outputs' own noise: the residual once, its period-to-period variation (first and
/// third harmonic) and its bins near zero frequency (the trend); pooled over the campaign
/// later (the pooled fields start unmeasured).
fn output_noises(
    sig: [&[f64]; 3],
    hf: &sine::HarmonicFit<3>,
    w: f64,
    dt: f64,
    st: &steady::Steady,
    k_max: usize,
) -> [OutputNoise; 2] {
    let out_fit = hf.pick([1, 2]);
    let mut res = noise::spectrum::residuals([sig[1], sig[2]], &out_fit, w, dt, st.len);
    let w_window = noise::periods::window_frequency(st.len, dt, st.periods);
    let cleaned = noise::spectrum::CLEAN_HARMONICS;
    noise::spectrum::remove_harmonics::<2>(&mut res, st.len, w_window, dt, k_max + 1, cleaned);
    let by_period = noise::periods::period_noise::<2>(&res, st.len, dt, st.periods);
    let bins = noise::spectrum::zero_bin_frequencies(st.len, dt, w);
    let powers = noise::spectrum::bin_powers::<2>(&res, st.len, &bins, dt);
    let unmeasured = NoisePower {
        power: f64::NAN,
        dof: 0.0,
        source: NoiseSource::Unmeasured,
    };
    let own = |power: Option<f64>, dof: Option<f64>| match (power, dof) {
        (Some(power), Some(dof)) if power.is_finite() => NoisePower {
            power,
            dof,
            source: NoiseSource::Own,
        },
        _ => unmeasured,
    };
    [0, 1].map(|o| OutputNoise {
        periods_first: own(
            by_period.map(|b| b.first[o]),
            by_period.map(|b| b.first_dof),
        ),
        periods_third: own(
            by_period.map(|b| b.third[o]),
            by_period.map(|b| b.third_dof),
        ),
        zero_bins: bins
            .iter()
            .copied()
            .zip(powers[o].iter().copied())
            .collect(),
        first: unmeasured,
        third: unmeasured,
        trend: unmeasured,
    })
}

/// Per output (zmp_x, zmp_y): the column of `G` for the excited input and what the fit says
/// of it.
struct OutputEstimates {
    /// `G_ij = Y_i / U_j` at the fundamental.
    g: [Complex64; 2],
    /// Standard deviation of the real and of the imaginary part of `g`.
    sigma: [f64; 2],
    /// RMS of harmonics 2..K over the fundamental.
    distortion: [f64; 2],
    /// Third-harmonic amplitude over its standard error.
    snr3: [f64; 2],
    /// Residual standard deviation, m.
    noise_std: [f64; 2],
}

impl OutputEstimates {
    /// From the harmonic fit of `n` samples (input first, then both outputs): each phasor
    /// component has variance `2 var / n` over whole periods; `relative_floor` adds a
    /// relative error floor to `sigma`.
    fn from_fit(hf: &sine::HarmonicFit<3>, nn: f64, k_max: usize, relative_floor: f64) -> Self {
        let p_in = hf.harmonics[0][0];
        let amp_in = p_in.norm();
        let var_u = hf.noise_var[0];
        let mut e = OutputEstimates {
            g: [Complex64::new(0.0, 0.0); 2],
            sigma: [0.0; 2],
            distortion: [0.0; 2],
            snr3: [0.0; 2],
            noise_std: [0.0; 2],
        };
        for o in 0..2 {
            let p = hf.harmonics[1 + o][0];
            e.g[o] = p / p_in;
            let var_y = hf.noise_var[1 + o];
            // Each phasor component has variance 2 var / n over whole periods.
            let noise_var = (2.0 / nn) * (var_y + e.g[o].norm_sqr() * var_u) / (amp_in * amp_in);
            e.sigma[o] = (noise_var + (relative_floor * e.g[o].norm()).powi(2)).sqrt();
            let harm: f64 = hf.harmonics[1 + o][1..].iter().map(|h| h.norm_sqr()).sum();
            e.distortion[o] = harm.sqrt() / p.norm().max(1e-300);
            e.snr3[o] = if k_max >= 3 {
                hf.harmonics[1 + o][2].norm() / ((2.0 / nn) * var_y).sqrt().max(1e-300)
            } else {
                0.0
            };
            e.noise_std[o] = var_y.sqrt();
        }
        e
    }
}

/// The steady-state components the diagnosis compares: the window, the refined frequency `w`
/// (rad/s), the input and output phasors, trends, residual variances and the outputs' noise.
fn steady_components(
    rec: &Record,
    st: &steady::Steady,
    hf: &sine::HarmonicFit<3>,
    w: f64,
    dt: f64,
    noise: [OutputNoise; 2],
) -> SteadyComponents {
    let third = |j: usize| {
        hf.harmonics[j]
            .get(2)
            .copied()
            .unwrap_or(Complex64::new(0.0, 0.0))
    };
    SteadyComponents {
        t0: rec.t[st.start],
        t1: rec.t[st.start + st.len - 1],
        samples: st.len,
        periods: st.periods,
        omega: w,
        u1: hf.harmonics[0][0],
        y1: [hf.harmonics[1][0], hf.harmonics[2][0]],
        y3: [third(1), third(2)],
        trend: [hf.trend[1], hf.trend[2]],
        residual_var: [hf.noise_var[1], hf.noise_var[2]],
        input_residual_var: hf.noise_var[0],
        trend_omegas: trend_omegas(st.len as f64 * dt),
        noise,
        inv_diag_h1: hf.inv_diag_h1,
        inv_diag_trend: hf.inv_diag_trend,
    }
}

/// Analyses every record on `threads` scoped threads, results in record order; the noise's
/// noise is then pooled over the campaign ([`pool_noise`]).
pub fn analyse_records(
    campaign: &Campaign,
    opts: &IdentifyOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Vec<RecordFit> {
    let done = AtomicUsize::new(0);
    let mut fits = parallel_map(campaign.records.len(), worker_count(opts), |k| {
        let fit = analyse_in_time(&campaign.records[k], k, opts);
        progress(done.fetch_add(1, Ordering::Relaxed) + 1);
        fit
    });
    pool_noise(&mut fits, opts.relative_floor);
    fits
}

/// [`analyse_record`] unless the time limit of the work it serves has passed
/// ([`zmp_campaign::par::past_deadline`], checked before each record): then the record is left out
/// ([`reason::TIME_LIMIT`]), so that identification inside `loop --time-limit` ends in time.
fn analyse_in_time(rec: &Record, index: usize, opts: &IdentifyOptions) -> RecordFit {
    if zmp_campaign::par::past_deadline() {
        return excluded(rec, index, reason::TIME_LIMIT);
    }
    analyse_record(rec, index, opts)
}

/// [`analyse_records`] straight from the campaign folder `dir` (whose manifest is
/// `manifest`): each record is analysed on the thread that read it and its columns are dropped
/// there, so the campaign's data is never all in memory (what `cargo xtask identify` does).
/// The analyses equal those of [`read_campaign`](zmp_campaign::read_campaign) followed by
/// [`analyse_records`].
pub fn analyse_folder(
    dir: &std::path::Path,
    manifest: &zmp_campaign::Manifest,
    opts: &IdentifyOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<RecordFit>, zmp_campaign::CampaignError> {
    let done = AtomicUsize::new(0);
    let mut fits = zmp_campaign::map_records(dir, manifest, worker_count(opts), |k, record| {
        let fit = analyse_in_time(&record, k, opts);
        progress(done.fetch_add(1, Ordering::Relaxed) + 1);
        fit
    })?;
    pool_noise(&mut fits, opts.relative_floor);
    Ok(fits)
}

/// Where the fitted trend sees the noise, as `x = omega T / 2` over a window of length `T`:
/// the equal-weight quadrature nodes (the midpoints of the eight octiles) of the trend
/// column's spectral window `|f(x)|^2`, `f(x) = (sin x - x cos x) / x^2` (the Fourier
/// transform of the centred ramp; its integral is `pi/6`). The trend's variance under a
/// noise of spectrum `S` is its white-noise factor times the `|f|^2`-weighted mean of
/// `S`, so the mean of the pooled noise power at these nodes. Most of the
/// weight lies below one Fourier bin of the window (`x < pi`), where no bin of the record
/// itself can be read (its trend and DC take them): the pool reads it from the bins of the
/// campaign's longer records. The noise near the bins two to ten resolutions up, which a
/// first-order noise of 1 s (a force sensor's slow creep) already puts 10-30 times lower,
/// left the trend's standard error 2-3 times too small on short records: a clean robot's
/// trends were then "significant" and its cells failed at 3-5 times their floor.
pub const TREND_NODES: [f64; 8] = [0.9985, 1.517, 1.8915, 2.2375, 2.605, 3.0785, 5.588, 15.485];

/// [`TREND_NODES`] as frequencies (rad/s) for a window of `window_s` seconds.
pub fn trend_omegas(window_s: f64) -> [f64; TREND_NODES.len()] {
    TREND_NODES.map(|x| 2.0 * x / window_s.max(1e-9))
}

/// Pools the records' noise estimates over the campaign, per output and by frequency (see
/// `noise`): every record's period-to-period powers (at its frequency and at three times it,
/// one spectrum) and every record's bins near zero frequency (the trends'), each read at the
/// record's own frequencies. Updates each record's pooled noise, the standard errors of its
/// `g` and its third harmonic's signal-to-noise ratio. A record too short for two periods has
/// no components and is not pooled (`analyse_record` excludes it); a record whose periods
/// measured nothing gets the pooled value at its frequency like every other; with nothing to
/// pool at all (no record of two periods) a record keeps its residual variance, the
/// white-noise estimate, with its residual's degrees of freedom.
pub fn pool_noise(records: &mut [RecordFit], relative_floor: f64) {
    let analysed: Vec<usize> = (0..records.len())
        .filter(|&k| records[k].components.is_some())
        .collect();
    let comps: Vec<&SteadyComponents> = analysed
        .iter()
        .filter_map(|&k| records[k].components.as_ref())
        .collect();
    let pooled = [0, 1].map(|i| noise::campaign::pooled(&comps, i));
    for (n, &k) in analysed.iter().enumerate() {
        let r = &mut records[k];
        let c = r.components.as_mut().expect("analysed");
        for i in 0..2 {
            (c.noise[i].first, c.noise[i].third, c.noise[i].trend) = pooled[i][n];
            let se3 = c.y3_var(i).sqrt().max(1e-300);
            if r.third_harmonic_snr[i] > 0.0 {
                r.third_harmonic_snr[i] = c.y3[i].norm() / se3;
            }
            if r.excluded.is_none() || r.excluded.as_deref() == Some(reason::SATURATED) {
                let amp2 = c.u1.norm_sqr().max(1e-300);
                let u_var = c.input_residual_var * 0.5 * (c.inv_diag_h1[0] + c.inv_diag_h1[1]);
                let var = (c.y1_var(i) + r.g[i].norm_sqr() * u_var) / amp2;
                r.sigma[i] = (var + (relative_floor * r.g[i].norm()).powi(2)).sqrt();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::TREND_NODES;

    /// The nodes are the octile midpoints of `|f(x)|^2`: its integral up to node `k` is
    /// `(2k + 1)/16` of `pi/6`.
    #[test]
    fn trend_nodes_split_the_trend_windows_weight_into_equal_parts() {
        let f2 = |x: f64| {
            let f = (x.sin() - x * x.cos()) / (x * x);
            f * f
        };
        // Simpson on [0, node] (f ~ x/3 near 0, so start just above it).
        let integral = |b: f64| {
            let n = 200_000;
            let h = b / n as f64;
            let mut s = 0.0;
            for i in 0..=n {
                let x = (i as f64 * h).max(1e-9);
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                s += w * f2(x);
            }
            s * h / 3.0
        };
        let total = std::f64::consts::PI / 6.0;
        for (k, &x) in TREND_NODES.iter().enumerate() {
            let share = integral(x) / total;
            let want = (2 * k + 1) as f64 / 16.0;
            assert!(
                (share - want).abs() < 2e-3,
                "node {k} at {x}: share {share}, want {want}"
            );
        }
    }
}
