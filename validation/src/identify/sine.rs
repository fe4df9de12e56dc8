//! Per-record signal analysis: steady-state detection on sliding whole-period windows, a
//! windowed FFT first estimate, and the harmonic sine fit by variable projection (linear in the
//! harmonic amplitudes, a 1-D refinement of the frequency).

#![allow(clippy::needless_range_loop)]

use num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// Sums of one block of samples for the 3-parameter (DC, sin, cos) fit of `S` signals.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sums<const S: usize> {
    n: f64,
    s: f64,
    c: f64,
    ss: f64,
    sc: f64,
    cc: f64,
    y: [f64; S],
    ys: [f64; S],
    yc: [f64; S],
    yy: [f64; S],
}

impl<const S: usize> Default for Sums<S> {
    fn default() -> Self {
        Sums {
            n: 0.0,
            s: 0.0,
            c: 0.0,
            ss: 0.0,
            sc: 0.0,
            cc: 0.0,
            y: [0.0; S],
            ys: [0.0; S],
            yc: [0.0; S],
            yy: [0.0; S],
        }
    }
}

impl<const S: usize> Sums<S> {
    fn add(&mut self, o: &Sums<S>) {
        self.n += o.n;
        self.s += o.s;
        self.c += o.c;
        self.ss += o.ss;
        self.sc += o.sc;
        self.cc += o.cc;
        for k in 0..S {
            self.y[k] += o.y[k];
            self.ys[k] += o.ys[k];
            self.yc[k] += o.yc[k];
            self.yy[k] += o.yy[k];
        }
    }

    /// Phasor and residual variance of each signal.
    fn solve(&self) -> Option<[(Complex64, f64); S]> {
        let m = nalgebra::Matrix3::new(
            self.n, self.s, self.c, self.s, self.ss, self.sc, self.c, self.sc, self.cc,
        );
        let chol = m.cholesky()?;
        let mut out = [(Complex64::new(0.0, 0.0), 0.0); S];
        for k in 0..S {
            let r = nalgebra::Vector3::new(self.y[k], self.ys[k], self.yc[k]);
            let x = chol.solve(&r);
            let rss = (self.yy[k] - x.dot(&r)).max(0.0);
            out[k] = (Complex64::new(x[1], x[2]), rss / (self.n - 3.0).max(1.0));
        }
        Some(out)
    }
}

/// Block sums of `signals` (already centred) over the sample ranges `bounds[i]..bounds[i+1]`,
/// sin/cos of `omega t_k`, `t_k = k dt` from the record's first sample.
pub(crate) fn block_sums<const S: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
    bounds: &[usize],
) -> Vec<Sums<S>> {
    let mut out = Vec::with_capacity(bounds.len().saturating_sub(1));
    for w in bounds.windows(2) {
        let mut b = Sums::<S>::default();
        let (s0, c0) = (omega * w[0] as f64 * dt).sin_cos();
        let (ds, dc) = (omega * dt).sin_cos();
        let (mut s, mut c) = (s0, c0);
        for k in w[0]..w[1] {
            b.n += 1.0;
            b.s += s;
            b.c += c;
            b.ss += s * s;
            b.sc += s * c;
            b.cc += c * c;
            for j in 0..S {
                let y = signals[j][k];
                b.y[j] += y;
                b.ys[j] += y * s;
                b.yc[j] += y * c;
                b.yy[j] += y * y;
            }
            let ns = s * dc + c * ds;
            c = c * dc - s * ds;
            s = ns;
        }
        out.push(b);
    }
    out
}

/// Result of the steady-state detector.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Steady {
    /// First sample of the steady state.
    pub start: usize,
    /// Whole periods kept from `start`.
    pub periods: usize,
    /// Samples kept (`periods` periods).
    pub len: usize,
}

/// Finds where the transient ends: one-period windows slid by a quarter period; the first
/// window after which every window's phasor (of every signal) stays within its noise of the
/// final value. Returns `None` when the record holds fewer than two periods.
pub(crate) fn detect_steady<const S: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
) -> Option<Steady> {
    let n = signals[0].len();
    let per = 2.0 * PI / (omega * dt);
    if (n as f64) < 2.0 * per - 1e-9 {
        return None;
    }
    let quarters = ((n as f64) / (per / 4.0)).floor() as usize;
    let bounds: Vec<usize> = (0..=quarters)
        .map(|q| ((q as f64 * per / 4.0).round() as usize).min(n))
        .collect();
    let blocks = block_sums(signals, omega, dt, &bounds);
    // Windows of four consecutive quarter blocks.
    let nwin = blocks.len().saturating_sub(3);
    let mut wins: Vec<[(Complex64, f64); S]> = Vec::with_capacity(nwin);
    for i in 0..nwin {
        let mut s = blocks[i];
        for b in &blocks[i + 1..i + 4] {
            s.add(b);
        }
        wins.push(s.solve()?);
    }
    if wins.is_empty() {
        return None;
    }
    // Final value: the mean over the last half of the windows (at least the last one).
    let tail = (nwin / 2).max(1);
    let mut fin = [Complex64::new(0.0, 0.0); S];
    let mut var = [0.0; S];
    for w in &wins[nwin - tail..] {
        for k in 0..S {
            fin[k] += w[k].0 / tail as f64;
        }
    }
    // Noise variance: the median of the window residual variances (robust to the transient).
    for k in 0..S {
        let mut v: Vec<f64> = wins.iter().map(|w| w[k].1).collect();
        v.sort_by(|a, b| a.total_cmp(b));
        var[k] = v[v.len() / 2];
    }
    let n_win = per;
    let mut first = 0usize;
    for (i, w) in wins.iter().enumerate() {
        let ok = (0..S).all(|k| {
            let sig = (2.0 * var[k] / n_win).sqrt();
            (w[k].0 - fin[k]).norm() <= 4.5 * sig + 2e-3 * fin[k].norm() + 1e-12
        });
        if !ok {
            first = i + 1;
        }
    }
    let start = bounds.get(first).copied().unwrap_or(n);
    let periods = (((n - start) as f64) / per + 1e-9).floor() as usize;
    if periods < 2 {
        return Some(Steady {
            start,
            periods,
            len: 0,
        });
    }
    let len = ((periods as f64 * per).round() as usize).min(n - start);
    Some(Steady {
        start,
        periods,
        len,
    })
}

/// First estimate by FFT: Hann window, then the bin nearest `omega`; returns the phasor of each
/// signal (amplitude corrected for the window's coherent gain, phase relative to `t = 0` of
/// the slice) and the frequency of the peak bin of the first signal, interpolated.
pub(crate) fn fft_estimate<const S: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
) -> ([Complex64; S], f64) {
    thread_local! {
        // Plans are cached by size; sizes are powers of two, so a handful per thread.
        static PLANNER: std::cell::RefCell<FftPlanner<f64>> = std::cell::RefCell::new(FftPlanner::new());
    }
    let n = signals[0].len();
    let win: Vec<f64> = (0..n)
        .map(|k| 0.5 - 0.5 * (2.0 * PI * k as f64 / n as f64).cos())
        .collect();
    let gain: f64 = win.iter().sum::<f64>() / 2.0;
    // Frequency: the Hann-windowed input, zero-padded to a power of two, its peak bin near
    // omega refined by a parabola through the log magnitudes.
    let n2 = n.next_power_of_two().max(16);
    let fft = PLANNER.with(|p| p.borrow_mut().plan_fft_forward(n2));
    let mut buf = vec![Complex64::new(0.0, 0.0); n2];
    for (b, (y, w)) in buf.iter_mut().zip(signals[0].iter().zip(&win)) {
        *b = Complex64::new(y * w, 0.0);
    }
    fft.process(&mut buf);
    let bin_w = 2.0 * PI / (n2 as f64 * dt);
    let k0 = ((omega / bin_w).round() as usize).clamp(1, n2 / 2 - 1);
    let m = |k: usize| buf[k].norm().max(1e-300).ln();
    let (a, b, c) = (m(k0 - 1), m(k0), m(k0 + 1));
    let d = a - 2.0 * b + c;
    let off = if d < 0.0 { 0.5 * (a - c) / d } else { 0.0 };
    let w_est = (k0 as f64 + off.clamp(-0.5, 0.5)) * bin_w;
    // Phasors at the commanded frequency: the windowed DTFT there, X = sum y w e^{-j omega t}.
    // For y = |P| sin(omega t + phi), X = |P| e^{j(phi - pi/2)} gain, so P = j X / gain.
    let mut out = [Complex64::new(0.0, 0.0); S];
    let (ds, dc) = (omega * dt).sin_cos();
    for (j, sig) in signals.iter().enumerate() {
        let (mut sn, mut cs) = (0.0f64, 1.0f64);
        let (mut re, mut im) = (0.0, 0.0);
        for (k, (y, w)) in sig.iter().zip(&win).enumerate() {
            if k % 1024 == 0 {
                (sn, cs) = (omega * k as f64 * dt).sin_cos();
            }
            let yw = y * w;
            re += yw * cs;
            im -= yw * sn;
            let ns = sn * dc + cs * ds;
            cs = cs * dc - sn * ds;
            sn = ns;
        }
        out[j] = Complex64::new(0.0, 1.0) * Complex64::new(re, im) / gain;
    }
    (out, w_est)
}

/// Harmonic least-squares fit of `S` signals at one frequency.
#[derive(Debug, Clone)]
pub(crate) struct HarmonicFit<const S: usize> {
    /// Phasors of harmonics 1..=K per signal (`[signal][k-1]`).
    pub harmonics: [Vec<Complex64>; S],
    /// Residual variance per signal.
    pub noise_var: [f64; S],
    /// Residual sum of squares per signal.
    pub rss: [f64; S],
    /// Sum of squares of the centred signal.
    pub yy: [f64; S],
}

/// Fits DC + `k_max` harmonics of `omega` to each signal (centred), time from sample 0 of the
/// slice. The normal equations are accumulated in one pass, sin/cos by recurrence.
pub(crate) fn harmonic_fit<const S: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
    k_max: usize,
) -> Option<HarmonicFit<S>> {
    // Dispatch on the harmonic count so the accumulation loops unroll.
    match k_max {
        1 => harmonic_fit_k::<S, 1>(signals, omega, dt),
        2 => harmonic_fit_k::<S, 2>(signals, omega, dt),
        3 => harmonic_fit_k::<S, 3>(signals, omega, dt),
        4 => harmonic_fit_k::<S, 4>(signals, omega, dt),
        5 => harmonic_fit_k::<S, 5>(signals, omega, dt),
        6 => harmonic_fit_k::<S, 6>(signals, omega, dt),
        _ => harmonic_fit_k::<S, 7>(signals, omega, dt),
    }
}

/// Largest regressor count: DC and seven harmonics.
const MAX_COLS: usize = 15;

fn harmonic_fit_k<const S: usize, const K: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
) -> Option<HarmonicFit<S>> {
    let k_max = K;
    let n = signals.iter().map(|s| s.len()).min().unwrap_or(0);
    let m = 1 + 2 * K;
    let mut ata_f = [[0.0f64; MAX_COLS]; MAX_COLS];
    let mut aty_f = [[0.0f64; S]; MAX_COLS];
    let mut yy = [0.0; S];
    let mut phi = [0.0f64; MAX_COLS];
    let (ds, dc) = (omega * dt).sin_cos();
    let (mut s1, mut c1) = (0.0f64, 1.0f64);
    const RESYNC: usize = 1024;
    for k in 0..n {
        if k % RESYNC == 0 {
            let (s, c) = (omega * k as f64 * dt).sin_cos();
            s1 = s;
            c1 = c;
        }
        phi[0] = 1.0;
        let (mut sk, mut ck) = (s1, c1);
        for h in 0..K {
            phi[1 + 2 * h] = sk;
            phi[2 + 2 * h] = ck;
            let ns = sk * c1 + ck * s1;
            ck = ck * c1 - sk * s1;
            sk = ns;
        }
        for a in 0..1 + 2 * K {
            let pa = phi[a];
            for b in a..1 + 2 * K {
                ata_f[a][b] += pa * phi[b];
            }
        }
        for j in 0..S {
            let y = signals[j][k];
            yy[j] += y * y;
            for a in 0..1 + 2 * K {
                aty_f[a][j] += phi[a] * y;
            }
        }
        let ns = s1 * dc + c1 * ds;
        c1 = c1 * dc - s1 * ds;
        s1 = ns;
    }
    let mut ata = vec![0.0; m * m];
    for a in 0..m {
        for b in a..m {
            ata[a * m + b] = ata_f[a][b];
            ata[b * m + a] = ata_f[a][b];
        }
    }
    let aty: Vec<[f64; S]> = aty_f[..m].to_vec();
    let chol = nalgebra::DMatrix::from_row_slice(m, m, &ata).cholesky()?;
    let mut harmonics: [Vec<Complex64>; S] = std::array::from_fn(|_| Vec::new());
    let mut noise_var = [0.0; S];
    let mut rss = [0.0; S];
    for j in 0..S {
        let r = nalgebra::DVector::from_iterator(m, (0..m).map(|a| aty[a][j]));
        let x = chol.solve(&r);
        rss[j] = (yy[j] - x.dot(&r)).max(0.0);
        noise_var[j] = rss[j] / (n as f64 - m as f64).max(1.0);
        harmonics[j] = (0..k_max)
            .map(|h| Complex64::new(x[1 + 2 * h], x[2 + 2 * h]))
            .collect();
    }
    Some(HarmonicFit {
        harmonics,
        noise_var,
        rss,
        yy,
    })
}

/// Variable projection on the frequency: the summed normalised residual of the harmonic fit
/// is minimised over `omega` by parabolic interpolation around `omega0` (one Gauss-Newton step
/// on the residual's quadratic model, kept only if it lowers the residual).
pub(crate) fn refine_frequency<const S: usize>(
    signals: [&[f64]; S],
    omega0: f64,
    dt: f64,
    k_max: usize,
) -> Option<(f64, HarmonicFit<S>)> {
    let n = signals[0].len();
    let cost =
        |f: &HarmonicFit<S>| -> f64 { (0..S).map(|j| f.rss[j] / f.yy[j].max(1e-300)).sum::<f64>() };
    let f0 = harmonic_fit(signals, omega0, dt, k_max)?;
    let span = n as f64 * dt;
    // A tenth of the frequency resolution of the record.
    let delta = 0.1 * 2.0 * PI / span;
    let fm = harmonic_fit(signals, omega0 - delta, dt, k_max)?;
    let fp = harmonic_fit(signals, omega0 + delta, dt, k_max)?;
    let (c0, cm, cp) = (cost(&f0), cost(&fm), cost(&fp));
    let curv = cm - 2.0 * c0 + cp;
    if curv > 0.0 {
        let step = (0.5 * delta * (cm - cp) / curv).clamp(-2.0 * delta, 2.0 * delta);
        if step.abs() > 1e-6 * delta {
            let w = omega0 + step;
            let fw = harmonic_fit(signals, w, dt, k_max)?;
            if cost(&fw) < c0 {
                return Some((w, fw));
            }
        }
    }
    Some((omega0, f0))
}
