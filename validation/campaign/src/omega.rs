//! Each record's stated frequency against its own data: the dominant line of the command.
//!
//! A record's `omega` in `campaign.toml` decides where identification looks (its steady state,
//! its harmonic fit); a wrong value is not noticed by a fit made at that value, and one wrong
//! record inflated the noise floor 40-1000x. So the reader finds the dominant line of the
//! excited command (its CoM reference, a sine by the format), independently of `omega`, and
//! refuses a record whose stated frequency is further from it than the record can resolve.
//!
//! Most records state their frequency right, and for those one windowed sum at the stated
//! frequency shows the line there (its amplitude at least 0.6 of the command's RMS amplitude:
//! for a sine, within 0.85 of a resolution bin); only the others have their spectrum computed.
//!
//! The line: the Hann-windowed command less its mean, zero-padded to a power of two, its
//! largest DFT bin, refined by a parabola through the log magnitudes of that bin and its two
//! neighbours. The tolerance is the record's frequency resolution, `2 pi / T` for a record of
//! `T` seconds (one bin of its unpadded DFT): a pure sine's interpolated peak lies within a
//! small fraction of a bin of its frequency (the interpolation's bias is below a tenth of a
//! bin for the Hann window; the command's quantisation moves it less), so a stated frequency
//! more than one bin away is a different line, not an estimate's error. Records too short to
//! resolve either frequency (fewer than [`MIN_SAMPLES`] samples, or under [`MIN_PERIODS`]
//! periods of both the stated and the found frequency) and constant commands are not checked
//! here (identification sets them aside), nor is a command that is not a line (less than
//! [`LINE_SHARE`] of its power in its peak's main lobe: noise, steps), which has no frequency
//! to state.

use crate::{CampaignError, Part, Record};
use num_complex::Complex64;
use rustfft::FftPlanner;
use std::cell::RefCell;
use std::f64::consts::PI;
use std::path::Path;

/// Fewest samples a record needs for its line to be told from broadband content: the Hann
/// window's main lobe (4 bins) then spans at most 1/16 of the band's 64 bins.
pub const MIN_SAMPLES: usize = 128;
/// Fewest periods (of the stated or of the found frequency) a record needs for the check.
pub const MIN_PERIODS: f64 = 2.0;
/// Share of a command's power its dominant line must hold for the command to be a line.
pub const LINE_SHARE: f64 = 0.5;

/// The dominant line of `u` (sampled every `dt` s), rad/s; `None` for a constant or
/// non-finite signal, fewer than [`MIN_SAMPLES`] samples, or a signal that is not a line (its
/// peak's main lobe holds less than [`LINE_SHARE`] of its power).
pub fn dominant_line(u: &[f64], dt: f64) -> Option<f64> {
    let n = u.len();
    if n < MIN_SAMPLES || !(dt.is_finite() && dt > 0.0) {
        return None;
    }
    let mean = u.iter().sum::<f64>() / n as f64;
    // Scaled to at most 1 (squares of huge values would overflow).
    let scale = u.iter().map(|x| (x - mean).abs()).fold(0.0, f64::max);
    if !(mean.is_finite() && scale.is_finite() && scale > 0.0) {
        return None;
    }
    let n2 = n.next_power_of_two();
    thread_local! {
        static FFT: RefCell<(FftPlanner<f64>, Vec<Complex64>)> =
            RefCell::new((FftPlanner::new(), Vec::new()));
    }
    FFT.with(|cell| {
        let (planner, buf) = &mut *cell.borrow_mut();
        buf.clear();
        buf.resize(n2, Complex64::new(0.0, 0.0));
        let beta = 2.0 * PI / n as f64;
        for (k, (b, &x)) in buf.iter_mut().zip(u).enumerate() {
            let w = 0.5 - 0.5 * (beta * k as f64).cos();
            b.re = (x - mean) / scale * w;
        }
        planner.plan_fft_forward(n2).process(buf);
        let half = n2 / 2;
        let power = |k: usize| buf[k].norm_sqr();
        let peak = (1..=half).max_by(|&a, &b| power(a).total_cmp(&power(b)))?;
        // A line holds at least half the command's power in its main lobe (two bins of the
        // unpadded record on either side for the Hann window; a sine holds all but 1e-4 of it
        // there); a command that is not one (noise, steps) has no line to check against.
        let lobe = (2 * n2).div_ceil(n);
        let total: f64 = (1..=half).map(power).sum();
        let near: f64 = (peak.saturating_sub(lobe).max(1)..=(peak + lobe).min(half))
            .map(power)
            .sum();
        if !(power(peak) > 0.0 && near >= LINE_SHARE * total) {
            return None;
        }
        let off = if peak > 1 && peak < half {
            let ln = |k: usize| power(k).max(1e-300).ln();
            let (a, b, c) = (ln(peak - 1), ln(peak), ln(peak + 1));
            let d = a - 2.0 * b + c;
            if d < 0.0 {
                (0.5 * (a - c) / d).clamp(-0.5, 0.5)
            } else {
                0.0
            }
        } else {
            0.0
        };
        Some((peak as f64 + off) * 2.0 * PI / (n2 as f64 * dt))
    })
}

/// Resynchronisation period of the rotations of [`windowed_dtft`] (an exact `sin_cos` every
/// this many samples).
const RESYNC: usize = 1024;

/// `sum_k y_k w_k e^{-i alpha k}` for each `alpha`, with the Hann window
/// `w_k = 1/2 - cos(beta k)/2`; rotations by recurrence, resynchronised every `RESYNC`. The
/// one windowed transform of the workspace: the reader's check here and identification's
/// first estimate (`zmp-identify`) use it.
#[allow(clippy::needless_range_loop)]
pub fn windowed_dtft<const B: usize>(y: &[f64], alphas: &[f64; B], beta: f64) -> [Complex64; B] {
    let step = |a: f64| {
        let (s, c) = a.sin_cos();
        Complex64::new(c, -s)
    };
    let rot: [Complex64; B] = std::array::from_fn(|b| step(alphas[b]));
    let rot_w = step(-beta);
    let mut z = [Complex64::new(1.0, 0.0); B];
    let mut zw = Complex64::new(1.0, 0.0);
    let mut acc = [Complex64::new(0.0, 0.0); B];
    for (k, &yk) in y.iter().enumerate() {
        if k % RESYNC == 0 {
            for b in 0..B {
                z[b] = step(alphas[b] * k as f64);
            }
            zw = step(-beta * k as f64);
        }
        let yw = yk * (0.5 - 0.5 * zw.re);
        for b in 0..B {
            acc[b] += z[b] * yw;
            z[b] *= rot[b];
        }
        zw *= rot_w;
    }
    acc
}

/// The amplitude of `u`'s Hann-windowed line at `omega` over its RMS amplitude (`sqrt 2` its
/// standard deviation): for a pure sine `|W(d)|`, the window's response `d` resolution bins
/// from its frequency (1 at it, 0.5 one bin away, under 0.03 beyond two).
fn share_at(u: &[f64], omega: f64, dt: f64) -> f64 {
    let n = u.len() as f64;
    let mean = u.iter().sum::<f64>() / n;
    let centred: Vec<f64> = u.iter().map(|x| x - mean).collect();
    let rms_amplitude = (2.0 * centred.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
    let [x] = windowed_dtft(&centred, &[omega * dt], 2.0 * PI / n);
    // The Hann window's coherent gain is n / 4 for the amplitude of a sine.
    (x.norm() / (n / 4.0)) / rms_amplitude
}

/// [`share_at`] above which the stated frequency is taken as within the record's resolution
/// of its line without looking for the line: for a pure sine 0.6 means within 0.85 bins (the
/// tolerance is one bin), so this shortcut never accepts what the full check would refuse,
/// and it never refuses anything (below it, the line is found and compared).
const SURE_SHARE: f64 = 0.6;

/// Checks `record`'s stated `omega` against the dominant line of its excited command (see the
/// module docs); the error names `campaign.toml` (`manifest`), the record and `omega`, and the
/// record's file. The stated frequency is looked at first (one windowed sum, [`share_at`]); the
/// command's spectrum is computed only when that does not show the line there.
pub(crate) fn check_omega(
    record: &Record,
    manifest: &Path,
    shown: &Path,
    index: usize,
) -> Result<(), CampaignError> {
    let n = record.len();
    let dt = record.dt();
    let stated = record.meta.omega;
    if n < MIN_SAMPLES || !(dt.is_finite() && dt > 0.0) {
        return Ok(());
    }
    if stated * dt < PI && share_at(record.excitation(), stated, dt) >= SURE_SHARE {
        return Ok(());
    }
    let Some(found) = dominant_line(record.excitation(), dt) else {
        return Ok(());
    };
    let span = n as f64 * dt;
    let periods = |w: f64| w * span / (2.0 * PI);
    if periods(stated).max(periods(found)) < MIN_PERIODS {
        return Ok(());
    }
    let resolution = 2.0 * PI / span;
    if (found - stated).abs() <= resolution {
        return Ok(());
    }
    let column = match record.meta.excited {
        zmp_models::Axis::X => "x_cr",
        zmp_models::Axis::Y => "y_cr",
    };
    Err(CampaignError::invalid(
        Part::Manifest,
        manifest,
        None,
        Some(index),
        Some("omega"),
        format!(
            "is {stated} rad/s, but the command {column} in {} has its dominant line at \
             {found:.4} rad/s, further than the record's frequency resolution ({resolution:.4} \
             rad/s = 2 pi / {span:.2} s) from it: the record would be fitted at the wrong \
             frequency; correct omega (or the record)",
            shown.display()
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windowed_dtft_matches_direct_sum() {
        let n = 3001;
        let y: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 * 0.005;
                0.3 + (1.9 * t + 0.7).sin() + 0.05 * (5.7 * t + 0.2).sin()
            })
            .collect();
        let beta = 2.0 * PI / n as f64;
        let alphas = [0.0095, 0.0123, 0.5];
        let got = windowed_dtft(&y, &alphas, beta);
        for (b, &alpha) in alphas.iter().enumerate() {
            let want: Complex64 = y
                .iter()
                .enumerate()
                .map(|(k, &v)| {
                    let w = 0.5 - 0.5 * (beta * k as f64).cos();
                    v * w * Complex64::from_polar(1.0, -alpha * k as f64)
                })
                .sum();
            assert!(
                (got[b] - want).norm() < 1e-9 * want.norm().max(1.0),
                "{alpha}"
            );
        }
    }

    fn sine(n: usize, dt: f64, w: f64) -> Vec<f64> {
        (0..n)
            .map(|k| 0.02 + 0.004 * (w * k as f64 * dt + 0.3).sin())
            .collect()
    }

    #[test]
    fn the_line_is_found_within_a_fraction_of_the_resolution() {
        for (n, dt, w) in [
            (1600, 0.005, 0.5),
            (4000, 0.005, 3.7),
            (2001, 0.01, 12.0),
            (128, 0.01, 40.0),
        ] {
            let found = dominant_line(&sine(n, dt, w), dt).unwrap();
            let resolution = 2.0 * PI / (n as f64 * dt);
            assert!(
                (found - w).abs() < 0.25 * resolution,
                "{w}: found {found}, resolution {resolution}"
            );
        }
        assert!(dominant_line(&[1.0; 100], 0.01).is_none());
        assert!(dominant_line(&sine(100, 0.01, 3.0), 0.01).is_none());
        // The shortcut: a sine's share is the window's response at the offset.
        let (n, dt, w) = (4000, 0.005, 3.7);
        let bin = 2.0 * PI / (n as f64 * dt);
        let u = sine(n, dt, w);
        for (off, lo, hi) in [
            (0.0, 0.99, 1.01),
            (0.5, 0.8, 0.9),
            (1.0, 0.48, 0.52),
            (1.2, 0.3, 0.45),
        ] {
            let s = share_at(&u, w + off * bin, dt);
            assert!(s > lo && s < hi, "{off} bins: {s}");
        }
        // Noise is not a line.
        let mut x = 1u64;
        let noise: Vec<f64> = (0..500)
            .map(|_| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (x >> 11) as f64 / (1u64 << 53) as f64
            })
            .collect();
        assert!(dominant_line(&noise, 0.01).is_none());
    }
}
