//! Per-record signal analysis: steady-state detection on sliding whole-period windows, a
//! windowed FFT first estimate, and the harmonic sine fit by variable projection (linear in the
//! harmonic amplitudes, a 1-D refinement of the frequency).

#![allow(clippy::needless_range_loop)]

use num_complex::Complex64;
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

/// Resynchronisation period of the sin/cos recurrences (exact `sin_cos` every this many samples).
const RESYNC: usize = 1024;

/// `sum_k y_k w_k e^{-i alpha k}` for each `alpha`, with the Hann window
/// `w_k = 1/2 - cos(beta k)/2`; rotations by recurrence, resynchronised every [`RESYNC`].
fn windowed_dtft<const B: usize>(y: &[f64], alphas: &[f64; B], beta: f64) -> [Complex64; B] {
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

impl<const S: usize> HarmonicFit<S> {
    /// The summed normalised residual that the frequency refinement minimises.
    fn cost(&self) -> f64 {
        (0..S).map(|j| self.rss[j] / self.yy[j].max(1e-300)).sum()
    }
}

/// Largest regressor count: DC and seven harmonics.
const MAX_COLS: usize = 15;

/// Fits DC + `k_max` harmonics of `omega` to each signal (centred), time from sample 0 of the
/// slice. The data enter through one pass of sums, sin/cos by recurrence; the normal matrix is
/// in closed form (see [`geometric_sums`]).
pub(crate) fn harmonic_fit<const S: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
    k_max: usize,
) -> Option<HarmonicFit<S>> {
    // Dispatch on the harmonic count so the accumulation loops unroll.
    match k_max {
        1 => fit_k::<S, 1>(signals, omega, dt, false).map(|f| f.0),
        2 => fit_k::<S, 2>(signals, omega, dt, false).map(|f| f.0),
        3 => fit_k::<S, 3>(signals, omega, dt, false).map(|f| f.0),
        4 => fit_k::<S, 4>(signals, omega, dt, false).map(|f| f.0),
        5 => fit_k::<S, 5>(signals, omega, dt, false).map(|f| f.0),
        6 => fit_k::<S, 6>(signals, omega, dt, false).map(|f| f.0),
        _ => fit_k::<S, 7>(signals, omega, dt, false).map(|f| f.0),
    }
}

/// [`harmonic_fit`] and the first and second derivatives of its cost
/// ([`HarmonicFit::cost`]) with respect to `omega`, exactly (variable projection).
fn harmonic_fit_with_slope<const S: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
    k_max: usize,
) -> Option<(HarmonicFit<S>, f64, f64)> {
    match k_max {
        1 => fit_k::<S, 1>(signals, omega, dt, true),
        2 => fit_k::<S, 2>(signals, omega, dt, true),
        3 => fit_k::<S, 3>(signals, omega, dt, true),
        4 => fit_k::<S, 4>(signals, omega, dt, true),
        5 => fit_k::<S, 5>(signals, omega, dt, true),
        6 => fit_k::<S, 6>(signals, omega, dt, true),
        _ => fit_k::<S, 7>(signals, omega, dt, true),
    }
}

/// `G_p(m) = sum_{k<n} k^p e^{i m theta k}` for `p = 0, 1, 2`: the sums that every entry of the
/// normal matrix of the harmonic regressors (and its derivatives in the frequency) is made of.
/// In closed form from the Dirichlet kernel `D = sin(n phi/2)/sin(phi/2)`, `phi = m theta`:
/// `G_0 = e^{i phi c} D`, `G_1 = -i dG_0/dphi`, `G_2 = -d2G_0/dphi2`, `c = (n-1)/2`. Summed
/// directly (slow, exact) where `sin(phi/2)` nearly vanishes (a harmonic at a multiple of the
/// sampling rate).
fn geometric_sums(n: usize, theta: f64, m: usize) -> [Complex64; 3] {
    let nf = n as f64;
    if m == 0 {
        return [
            Complex64::new(nf, 0.0),
            Complex64::new(nf * (nf - 1.0) / 2.0, 0.0),
            Complex64::new((nf - 1.0) * nf * (2.0 * nf - 1.0) / 6.0, 0.0),
        ];
    }
    let phi = m as f64 * theta;
    let (s, co) = (0.5 * phi).sin_cos();
    if s.abs() < 1e-6 {
        let mut g = [Complex64::new(0.0, 0.0); 3];
        for k in 0..n {
            let kf = k as f64;
            let (sn, cs) = (phi * kf).sin_cos();
            let z = Complex64::new(cs, sn);
            g[0] += z;
            g[1] += z * kf;
            g[2] += z * (kf * kf);
        }
        return g;
    }
    let (big_s, big_c) = (0.5 * nf * phi).sin_cos();
    let c = (nf - 1.0) / 2.0;
    let d0 = big_s / s;
    let u = 0.5 * nf * big_c * s - 0.5 * big_s * co;
    let d1 = u / (s * s);
    let d2 = big_s * (1.0 - nf * nf) / (4.0 * s) - u * co / (s * s * s);
    let (es, ec) = (phi * c).sin_cos();
    let e = Complex64::new(ec, es);
    let i = Complex64::new(0.0, 1.0);
    [
        e * d0,
        e * (c * d0 - i * d1),
        e * (c * c * d0 - 2.0 * c * d1 * i - d2),
    ]
}

/// The `m x m` matrix `sum_k w_k phi_a phi_b` of the regressors (DC, then sin and cos of each
/// harmonic) from `e[q] = sum_k w_k e^{i q theta k}`, `q = 0..=2K`, by the product formulas.
fn regressor_matrix(e: &[Complex64], k_max: usize) -> nalgebra::DMatrix<f64> {
    // Column 0 is DC (harmonic 0, "cos"), column 2h-1 sin(h x), column 2h cos(h x).
    let col = |c: usize| -> (bool, usize) { (c % 2 == 1, c.div_ceil(2)) };
    let entry = |p: usize, q: usize| -> f64 {
        let ((p_sin, a), (q_sin, b)) = (col(p), col(q));
        let (diff, sum) = (e[a.abs_diff(b)], e[a + b]);
        // Products of sines and cosines as sums and differences of angles.
        match (p_sin, q_sin) {
            (false, false) if a == 0 && b == 0 => e[0].re,
            (false, false) if a == 0 || b == 0 => sum.re,
            (false, false) => 0.5 * (diff.re + sum.re),
            (true, true) => 0.5 * (diff.re - sum.re),
            (true, false) if b == 0 => sum.im,
            (false, true) if a == 0 => sum.im,
            // sin A cos B = (sin(A + B) + sin(A - B)) / 2
            (true, false) => 0.5 * (sum.im + if a >= b { diff.im } else { -diff.im }),
            (false, true) => 0.5 * (sum.im + if b >= a { diff.im } else { -diff.im }),
        }
    };
    let m = 1 + 2 * k_max;
    nalgebra::DMatrix::from_fn(m, m, entry)
}

/// One pass of sums and the fit at `omega`; with `slope`, also the first and second derivative
/// of the cost in `omega` (returned as 0 otherwise).
fn fit_k<const S: usize, const K: usize>(
    signals: [&[f64]; S],
    omega: f64,
    dt: f64,
    slope: bool,
) -> Option<(HarmonicFit<S>, f64, f64)> {
    let n = signals.iter().map(|s| s.len()).min().unwrap_or(0);
    let m = 1 + 2 * K;
    // r[j][a] = sum phi_a y_j; with `slope` also u = sum t phi_a y_j and v = sum t^2 phi_a y_j
    // (signal-major, so the per-sample updates run over contiguous regressors).
    let mut r = [[0.0f64; MAX_COLS]; S];
    let mut u = [[0.0f64; MAX_COLS]; S];
    let mut v = [[0.0f64; MAX_COLS]; S];
    let mut yy = [0.0; S];
    if slope {
        accumulate::<S, K, true>(signals, n, omega, dt, &mut r, &mut u, &mut v, &mut yy);
    } else {
        accumulate::<S, K, false>(signals, n, omega, dt, &mut r, &mut u, &mut v, &mut yy);
    }
    let theta = omega * dt;
    let g: Vec<[Complex64; 3]> = (0..=2 * K).map(|q| geometric_sums(n, theta, q)).collect();
    let e0: Vec<Complex64> = g.iter().map(|g| g[0]).collect();
    let chol = regressor_matrix(&e0, K).cholesky()?;
    let mut harmonics: [Vec<Complex64>; S] = std::array::from_fn(|_| Vec::new());
    let mut noise_var = [0.0; S];
    let mut rss = [0.0; S];
    let mut xs = Vec::with_capacity(S);
    for j in 0..S {
        let rj = nalgebra::DVector::from_iterator(m, (0..m).map(|a| r[j][a]));
        let x = chol.solve(&rj);
        rss[j] = (yy[j] - x.dot(&rj)).max(0.0);
        noise_var[j] = rss[j] / (n as f64 - m as f64).max(1.0);
        harmonics[j] = (0..K)
            .map(|h| Complex64::new(x[1 + 2 * h], x[2 + 2 * h]))
            .collect();
        xs.push(x);
    }
    let fit = HarmonicFit {
        harmonics,
        noise_var,
        rss,
        yy,
    };
    if !slope {
        return Some((fit, 0.0, 0.0));
    }
    // d/domega of sum_k e^{i q omega dt k} is i q dt G_1(q); the second derivative
    // -(q dt)^2 G_2(q).
    let e1: Vec<Complex64> = (0..=2 * K)
        .map(|q| Complex64::new(0.0, q as f64 * dt) * g[q][1])
        .collect();
    let e2: Vec<Complex64> = (0..=2 * K)
        .map(|q| -(q as f64 * dt).powi(2) * g[q][2])
        .collect();
    let (m1, m2) = (regressor_matrix(&e1, K), regressor_matrix(&e2, K));
    // With f = r^T M^-1 r = yy - rss and x = M^-1 r:
    // f' = 2 r'.x - x^T M' x, f'' = 2 r''.x - x^T M'' x + 2 g^T M^-1 g, g = r' - M' x.
    // d sin(h w t)/dw = h t cos(h w t), d cos(h w t)/dw = -h t sin(h w t).
    let (mut d1, mut d2) = (0.0, 0.0);
    for j in 0..S {
        let x = &xs[j];
        let mut r1 = nalgebra::DVector::zeros(m);
        let mut r2 = nalgebra::DVector::zeros(m);
        for h in 1..=K {
            let (sa, ca) = (2 * h - 1, 2 * h);
            let hf = h as f64;
            r1[sa] = hf * u[j][ca];
            r1[ca] = -hf * u[j][sa];
            r2[sa] = -hf * hf * v[j][sa];
            r2[ca] = -hf * hf * v[j][ca];
        }
        let m1x = &m1 * x;
        let gj = &r1 - &m1x;
        let f1 = 2.0 * r1.dot(x) - x.dot(&m1x);
        let f2 = 2.0 * r2.dot(x) - x.dot(&(&m2 * x)) + 2.0 * gj.dot(&chol.solve(&gj));
        let scale = yy[j].max(1e-300);
        d1 -= f1 / scale;
        d2 -= f2 / scale;
    }
    Some((fit, d1, d2))
}

/// The data sums of [`fit_k`]: `r[j][a] = sum_k phi_a(k) y_j[k]` and, with `SLOPE`, the same
/// weighted by `t_k` (`u`) and `t_k^2` (`v`), `t_k = k dt`; `yy[j] = sum y_j^2`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn accumulate<const S: usize, const K: usize, const SLOPE: bool>(
    signals: [&[f64]; S],
    n: usize,
    omega: f64,
    dt: f64,
    r: &mut [[f64; MAX_COLS]; S],
    u: &mut [[f64; MAX_COLS]; S],
    v: &mut [[f64; MAX_COLS]; S],
    yy: &mut [f64; S],
) {
    let mut phi = [0.0f64; MAX_COLS];
    // Sliced to exactly n so that the per-sample reads need no bounds checks.
    let signals = signals.map(|s| &s[..n]);
    let (ds, dc) = (omega * dt).sin_cos();
    let (mut s1, mut c1) = (0.0f64, 1.0f64);
    for k in 0..n {
        if k % RESYNC == 0 {
            (s1, c1) = (omega * k as f64 * dt).sin_cos();
        }
        let (mut sk, mut ck) = (s1, c1);
        for h in 0..K {
            phi[1 + 2 * h] = sk;
            phi[2 + 2 * h] = ck;
            let ns = sk * c1 + ck * s1;
            ck = ck * c1 - sk * s1;
            sk = ns;
        }
        let t = k as f64 * dt;
        for j in 0..S {
            let y = signals[j][k];
            yy[j] += y * y;
            r[j][0] += y;
            for a in 1..1 + 2 * K {
                r[j][a] += phi[a] * y;
            }
            if SLOPE {
                let ty = t * y;
                let tty = t * ty;
                for a in 1..1 + 2 * K {
                    u[j][a] += phi[a] * ty;
                    v[j][a] += phi[a] * tty;
                }
            }
        }
        let ns = s1 * dc + c1 * ds;
        c1 = c1 * dc - s1 * ds;
        s1 = ns;
    }
}

/// Variable projection on the frequency: the summed normalised residual of the harmonic fit
/// ([`HarmonicFit::cost`]) is minimised over `omega` by one Newton step from `omega0`, with
/// its exact first and second derivatives from the same pass of sums as the fit at `omega0`
/// (the step is clamped to two tenths of the record's frequency resolution, and kept only if
/// it lowers the residual).
pub(crate) fn refine_frequency<const S: usize>(
    signals: [&[f64]; S],
    omega0: f64,
    dt: f64,
    k_max: usize,
) -> Option<(f64, HarmonicFit<S>)> {
    let n = signals[0].len();
    let (f0, d1, d2) = harmonic_fit_with_slope(signals, omega0, dt, k_max)?;
    let span = n as f64 * dt;
    // A tenth of the frequency resolution of the record.
    let delta = 0.1 * 2.0 * PI / span;
    if d2 > 0.0 {
        let step = (-d1 / d2).clamp(-2.0 * delta, 2.0 * delta);
        if step.abs() > 1e-6 * delta {
            let w = omega0 + step;
            let fw = harmonic_fit(signals, w, dt, k_max)?;
            if fw.cost() < f0.cost() {
                return Some((w, fw));
            }
        }
    }
    Some((omega0, f0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sine with harmonics and a deterministic pseudo-noise, `n` samples.
    fn signal(n: usize, omega: f64, dt: f64, phase: f64) -> Vec<f64> {
        (0..n)
            .map(|k| {
                let t = k as f64 * dt;
                let noise = ((k as f64 * 12.9898).sin() * 43758.5453).fract() - 0.5;
                0.3 + (omega * t + phase).sin()
                    + 0.05 * (3.0 * omega * t + 0.2).sin()
                    + 0.02 * (2.0 * omega * t).cos()
                    + 0.01 * noise
            })
            .collect()
    }

    /// The fit with the normal matrix summed sample by sample, solved densely.
    fn brute_force(y: &[f64], omega: f64, dt: f64, k: usize) -> (Vec<f64>, f64) {
        let m = 1 + 2 * k;
        let mut ata = nalgebra::DMatrix::<f64>::zeros(m, m);
        let mut aty = nalgebra::DVector::<f64>::zeros(m);
        let mut yy = 0.0;
        for (i, &yi) in y.iter().enumerate() {
            let x = omega * i as f64 * dt;
            let phi = nalgebra::DVector::from_fn(m, |a, _| match a {
                0 => 1.0,
                a if a % 2 == 1 => (a.div_ceil(2) as f64 * x).sin(),
                a => ((a / 2) as f64 * x).cos(),
            });
            ata += &phi * phi.transpose();
            aty += &phi * yi;
            yy += yi * yi;
        }
        let x = ata.cholesky().unwrap().solve(&aty);
        (x.iter().copied().collect(), yy - x.dot(&aty))
    }

    #[test]
    fn closed_form_normal_matrix_matches_summation() {
        let (dt, omega) = (0.005, 3.7);
        for (n, k) in [(2000usize, 3usize), (777, 1), (5003, 5)] {
            let y = signal(n, omega * 1.001, dt, 0.4);
            let fit = harmonic_fit([&y[..]], omega, dt, k).unwrap();
            let (x, rss) = brute_force(&y, omega, dt, k);
            for h in 0..k {
                let got = fit.harmonics[0][h];
                let want = Complex64::new(x[1 + 2 * h], x[2 + 2 * h]);
                assert!(
                    (got - want).norm() < 1e-9,
                    "n {n} k {k} h {h}: {got} vs {want}"
                );
            }
            assert!(
                (fit.rss[0] - rss).abs() < 1e-8 * fit.yy[0],
                "{} vs {rss}",
                fit.rss[0]
            );
        }
    }

    #[test]
    fn cost_derivatives_match_finite_differences() {
        let (dt, omega, n) = (0.005, 2.3, 4000);
        let y1 = signal(n, omega * 1.0007, dt, 0.1);
        let y2: Vec<f64> = signal(n, omega * 1.0007, dt, 1.3)
            .iter()
            .map(|v| 0.4 * v)
            .collect();
        let sig = [&y1[..], &y2[..]];
        let (f0, d1, d2) = harmonic_fit_with_slope(sig, omega, dt, 3).unwrap();
        let h = 1e-4;
        let c = |w: f64| harmonic_fit(sig, w, dt, 3).unwrap().cost();
        let fd1 = (c(omega + h) - c(omega - h)) / (2.0 * h);
        let fd2 = (c(omega + h) - 2.0 * f0.cost() + c(omega - h)) / (h * h);
        assert!(
            (d1 - fd1).abs() < 1e-4 * fd1.abs().max(1.0),
            "{d1} vs {fd1}"
        );
        assert!((d2 - fd2).abs() < 1e-3 * fd2.abs(), "{d2} vs {fd2}");
        // The Newton step lands on the minimum of the cost.
        let (w, _) = refine_frequency(sig, omega, dt, 3).unwrap();
        let (lo, hi) = (c(w - 1e-4), c(w + 1e-4));
        assert!(c(w) <= lo && c(w) <= hi, "{w}: {lo} {} {hi}", c(w));
    }

    #[test]
    fn windowed_dtft_matches_direct_sum() {
        let n = 3001;
        let y = signal(n, 1.9, 0.005, 0.7);
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
}
