//! Where a record's transient ends: one-period windows slid by a quarter period, each fitted
//! with DC, a linear trend and the fundamental; the steady state starts at the first window
//! after which every window's phasor stays within its noise of the final value.
//!
//! The trend column makes the detector blind to a drifting sensor: over one period a ramp
//! `r t` projects onto the fundamental by about `2 r / omega`, with a sign that turns with the
//! window's phase, so a detector without it sees windows that never agree once the drift is
//! a fraction of a millimetre per second.

use num_complex::Complex64;
use std::f64::consts::PI;

/// Sums of one block of samples for the 4-parameter (DC, trend, sin, cos) fit of `S` signals;
/// time in seconds from the record's first sample.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sums<const S: usize> {
    n: f64,
    t: f64,
    tt: f64,
    s: f64,
    c: f64,
    ts: f64,
    tc: f64,
    ss: f64,
    sc: f64,
    cc: f64,
    y: [f64; S],
    ty: [f64; S],
    ys: [f64; S],
    yc: [f64; S],
    yy: [f64; S],
}

impl<const S: usize> Default for Sums<S> {
    fn default() -> Self {
        Sums {
            n: 0.0,
            t: 0.0,
            tt: 0.0,
            s: 0.0,
            c: 0.0,
            ts: 0.0,
            tc: 0.0,
            ss: 0.0,
            sc: 0.0,
            cc: 0.0,
            y: [0.0; S],
            ty: [0.0; S],
            ys: [0.0; S],
            yc: [0.0; S],
            yy: [0.0; S],
        }
    }
}

impl<const S: usize> Sums<S> {
    fn add(&mut self, o: &Sums<S>) {
        self.n += o.n;
        self.t += o.t;
        self.tt += o.tt;
        self.s += o.s;
        self.c += o.c;
        self.ts += o.ts;
        self.tc += o.tc;
        self.ss += o.ss;
        self.sc += o.sc;
        self.cc += o.cc;
        for k in 0..S {
            self.y[k] += o.y[k];
            self.ty[k] += o.ty[k];
            self.ys[k] += o.ys[k];
            self.yc[k] += o.yc[k];
            self.yy[k] += o.yy[k];
        }
    }

    /// Phasor and residual variance of each signal, the trend fitted alongside.
    fn solve(&self) -> Option<[(Complex64, f64); S]> {
        // Time from the window's mean (conditioning): sums about the mean time.
        let tm = self.t / self.n;
        let t = 0.0;
        let tt = self.tt - tm * self.t;
        let ts = self.ts - tm * self.s;
        let tc = self.tc - tm * self.c;
        #[rustfmt::skip]
        let m = nalgebra::Matrix4::new(
            self.n, t,  self.s,  self.c,
            t,      tt, ts,      tc,
            self.s, ts, self.ss, self.sc,
            self.c, tc, self.sc, self.cc,
        );
        let chol = m.cholesky()?;
        let mut out = [(Complex64::new(0.0, 0.0), 0.0); S];
        for k in 0..S {
            let ty = self.ty[k] - tm * self.y[k];
            let r = nalgebra::Vector4::new(self.y[k], ty, self.ys[k], self.yc[k]);
            let x = chol.solve(&r);
            let rss = (self.yy[k] - x.dot(&r)).max(0.0);
            out[k] = (Complex64::new(x[2], x[3]), rss / (self.n - 4.0).max(1.0));
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
    let (ds, dc) = (omega * dt).sin_cos();
    for w in bounds.windows(2) {
        let mut b = Sums::<S>::default();
        let (mut s, mut c) = (omega * w[0] as f64 * dt).sin_cos();
        for k in w[0]..w[1] {
            let t = k as f64 * dt;
            b.n += 1.0;
            b.t += t;
            b.tt += t * t;
            b.s += s;
            b.c += c;
            b.ts += t * s;
            b.tc += t * c;
            b.ss += s * s;
            b.sc += s * c;
            b.cc += c * c;
            for j in 0..S {
                let y = signals[j][k];
                b.y[j] += y;
                b.ty[j] += t * y;
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
    // A one-period window's phasor with a trend fitted alongside: the sin and cos columns
    // have about n/2 of weight each, the trend takes a little more of it. Coloured noise (a
    // sensor's slow wander) scatters the windows' phasors more than the residual variance
    // says: the scatter of the last half's windows about their mean is measured too (the
    // distance of a complex Gaussian from its mean has median 1.177 sigma), and the larger
    // of the two decides.
    let n_win = per;
    let mut sig = [0.0; S];
    for k in 0..S {
        let mut d: Vec<f64> = wins[nwin - tail..]
            .iter()
            .map(|w| (w[k].0 - fin[k]).norm())
            .collect();
        d.sort_by(f64::total_cmp);
        let empirical = if d.len() >= 4 {
            d[d.len() / 2] / 1.177
        } else {
            0.0
        };
        sig[k] = (2.5 * var[k] / n_win).sqrt().max(empirical);
    }
    let mut first = 0usize;
    for (i, w) in wins.iter().enumerate() {
        let ok =
            (0..S).all(|k| (w[k].0 - fin[k]).norm() <= 4.5 * sig[k] + 2e-3 * fin[k].norm() + 1e-12);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A first-order transient into a sine, plus a drift and a deterministic pseudo-noise.
    fn record(n: usize, omega: f64, dt: f64, tau: f64, drift: f64, noise: f64) -> Vec<f64> {
        (0..n)
            .map(|k| {
                let t = k as f64 * dt;
                let u = ((k as f64 * 12.9898).sin() * 43758.5453).fract() - 0.5;
                0.004 * (omega * t).sin() + 0.003 * (-t / tau).exp() + drift * t + noise * u
            })
            .collect()
    }

    #[test]
    fn coloured_noise_does_not_hide_the_steady_state() {
        // First-order noise with a 0.5 s correlation time (0.3 mm) on top of the white part:
        // one-period windows at 0.8 rad/s scatter far more than white noise of the same
        // residual variance would.
        let (dt, omega) = (0.005, 0.8);
        let n = (40.0 / dt) as usize;
        let mut y = record(n, omega, dt, 1.5, 0.0, 3e-4);
        let pole = (-dt / 0.5f64).exp();
        let mut e = 0.0;
        for (k, v) in y.iter_mut().enumerate() {
            let u = ((k as f64 * 78.233).sin() * 12345.678).fract() - 0.5;
            e = pole * e + 3e-4 * (12.0f64 * (1.0 - pole * pole)).sqrt() * u;
            *v += e;
        }
        let st = detect_steady([&y[..]], omega, dt).unwrap();
        let t0 = st.start as f64 * dt;
        assert!(t0 <= 15.0, "steady state from {t0} s");
        assert!(st.periods >= 3, "{} periods", st.periods);
    }

    #[test]
    fn the_transient_is_found_with_and_without_a_drifting_sensor() {
        let (dt, omega) = (0.005, 0.8);
        let n = (40.0 / dt) as usize;
        // 0.5 mm/s of drift: 20 mm over the record, five times the sine.
        let start = |drift: f64| {
            let y = record(n, omega, dt, 1.5, drift, 5e-4);
            detect_steady([&y[..]], omega, dt).unwrap()
        };
        let clean = start(0.0).start as f64 * dt;
        for drift in [0.0, 5e-4, -5e-4] {
            let st = start(drift);
            let t0 = st.start as f64 * dt;
            // The drift moves the start by at most two window steps (a quarter period each).
            let quarter = 0.25 * 2.0 * PI / omega;
            assert!(
                (t0 - clean).abs() <= 2.0 * quarter + 1e-9,
                "drift {drift}: {t0} vs {clean}"
            );
            // exp(-t/1.5) falls below the noise of a window (~2e-5 m) after about 7.5 s.
            assert!(
                (3.0..=12.0).contains(&t0),
                "drift {drift}: steady state from {t0} s"
            );
            assert!(st.periods >= 3, "drift {drift}: {} periods", st.periods);
        }
    }
}
