//! The first estimate of a record's excitation: the Hann-windowed DFT at three bins near the
//! commanded frequency (the peak, interpolated) and each signal's phasor there.

#![allow(clippy::needless_range_loop)]

use num_complex::Complex64;
use std::f64::consts::PI;
use zmp_campaign::windowed_dtft;

/// First estimate: Hann window, then the DFT bin nearest `omega` of the input zero-padded to a
/// power of two; returns the phasor of each signal (amplitude corrected for the window's
/// coherent gain, phase relative to `t = 0` of the slice) and the frequency of the peak bin of
/// the first signal, interpolated. Only three bins are needed, so they are summed directly
/// (what an FFT of the padded record would give there, without the other bins).
pub(crate) fn fft_estimate<const S: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
) -> ([Complex64; S], f64) {
    let n = signals[0].len();
    // The Hann window w_k = 1/2 - cos(beta k)/2; its coherent gain sum(w)/2 is n/4 (the
    // cosines sum to zero over the whole period n).
    let beta = 2.0 * PI / n as f64;
    let gain = n as f64 / 4.0;
    // Frequency: the Hann-windowed input, zero-padded to a power of two, its peak bin near
    // omega refined by a parabola through the log magnitudes.
    let n2 = n.next_power_of_two().max(16);
    let bin_w = 2.0 * PI / (n2 as f64 * dt);
    let k0 = ((omega / bin_w).round() as usize).clamp(1, n2 / 2 - 1);
    // X_b = sum y_k w_k e^{-i alpha_b k} at the bins k0 - 1, k0, k0 + 1 (alpha = 2 pi b / n2);
    // for every signal, the windowed DTFT at omega (alpha = omega dt).
    let alphas = [
        2.0 * PI * (k0 - 1) as f64 / n2 as f64,
        2.0 * PI * k0 as f64 / n2 as f64,
        2.0 * PI * (k0 + 1) as f64 / n2 as f64,
    ];
    // One pass over the first signal for the three bins and its phasor at omega.
    let [b0, b1, b2, x0] = windowed_dtft(
        signals[0],
        &[alphas[0], alphas[1], alphas[2], omega * dt],
        beta,
    );
    let m = |x: Complex64| x.norm().max(1e-300).ln();
    let (a, b, c) = (m(b0), m(b1), m(b2));
    let d = a - 2.0 * b + c;
    let off = if d < 0.0 { 0.5 * (a - c) / d } else { 0.0 };
    let w_est = (k0 as f64 + off.clamp(-0.5, 0.5)) * bin_w;
    // Phasors at the commanded frequency: X = sum y w e^{-j omega t}.
    // For y = |P| sin(omega t + phi), X = |P| e^{j(phi - pi/2)} gain, so P = j X / gain.
    let mut out = [Complex64::new(0.0, 0.0); S];
    for (j, sig) in signals.iter().enumerate() {
        let x = if j == 0 {
            x0
        } else {
            let [x] = windowed_dtft(sig, &[omega * dt], beta);
            x
        };
        out[j] = Complex64::new(0.0, 1.0) * x / gain;
    }
    (out, w_est)
}
