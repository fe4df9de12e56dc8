//! First-harmonic estimation: the phasor of a sampled signal at a known frequency.
//!
//! Convention used throughout: a signal `c + |P| sin(omega t + arg P)` has phasor `P`, so the
//! ratio of output to input phasors is the frequency response `G(j omega)`.

use nalgebra::{Matrix3, Vector3};
use num_complex::Complex64;

/// Least-squares fit of `c + alpha sin(omega t) + beta cos(omega t)` to samples
/// `y[k]` at `t0 + k dt`; returns `alpha + j beta`. Use whole periods for the best conditioning.
pub fn first_harmonic(y: &[f64], omega: f64, dt: f64, t0: f64) -> Complex64 {
    let mut m = Matrix3::<f64>::zeros();
    let mut r = Vector3::<f64>::zeros();
    for (k, &yk) in y.iter().enumerate() {
        let t = t0 + k as f64 * dt;
        let (s, c) = (omega * t).sin_cos();
        let phi = Vector3::new(1.0, s, c);
        m += phi * phi.transpose();
        r += phi * yk;
    }
    match m.lu().solve(&r) {
        Some(x) => Complex64::new(x[1], x[2]),
        None => Complex64::new(f64::NAN, f64::NAN),
    }
}

/// Relative change of the one-period phasor below which a response counts as periodic.
const SETTLED_REL: f64 = 1e-7;
/// Longest subharmonic period, in input periods, recognised as a steady state.
const MAX_SUBHARMONIC: usize = 6;
/// Steady-state periods (of the response's own period) fitted.
const KEEP_PERIODS: usize = 4;

/// Steady-state first harmonics at `omega` of `N` signals that `sample(k)` produces one sample
/// at a time (`k = 1, 2, ...`, sample `k` at time `k dt`).
///
/// Runs `min_settle` samples, then period by period until the response repeats: the phasor of
/// every signal over one input period equals (within 1e-7, relative) the one `m` periods
/// earlier, twice in a row, for the smallest `m` in 1..=6 (`m > 1`: a subharmonic steady state,
/// which a servo deep in acceleration saturation can settle into). Then fits `4 m` periods, so
/// the result is the Fourier coefficient at `omega` of the periodic steady state. A fixed
/// settling time is not enough for nonlinear responses: a saturated servo can take hundreds of
/// periods to lock. After `max_settle` samples without a repeat, the next `4 m` periods (`m` =
/// 6) are fitted as they are.
pub fn steady_first_harmonics<const N: usize>(
    omega: f64,
    dt: f64,
    min_settle: usize,
    max_settle: usize,
    mut sample: impl FnMut(usize) -> [f64; N],
) -> [Complex64; N] {
    let per = (2.0 * std::f64::consts::PI / (omega * dt)).round().max(8.0) as usize;
    let mut k = 0usize;
    while k < min_settle {
        k += 1;
        sample(k);
    }
    let mut block = vec![[0.0; N]; per];
    let mut column = vec![0.0; per];
    // Per period: phasor, largest magnitude (for rounding), half range (for leakage); newest
    // last.
    type Entry<const N: usize> = ([Complex64; N], [f64; N], [f64; N]);
    let mut history: Vec<Entry<N>> = Vec::new();
    // A block of `per` samples is not exactly one period when the period is not a whole number
    // of steps; the harmonics then leak into the one-period phasor by about that mismatch.
    let mismatch = (per as f64 * dt * omega / (2.0 * std::f64::consts::PI) - 1.0).abs();
    let repeats = |a: &Entry<N>, b: &Entry<N>| {
        (0..N).all(|n| {
            let change = (a.0[n] - b.0[n]).norm();
            let floor = 1e-12 * a.1[n].max(b.1[n]) + 4.0 * mismatch * a.2[n].max(b.2[n]);
            change <= SETTLED_REL * a.0[n].norm().max(b.0[n].norm()) + floor
        })
    };
    let mut order = MAX_SUBHARMONIC;
    'settle: while k < max_settle.max(min_settle) {
        let t0 = (k + 1) as f64 * dt;
        for b in block.iter_mut() {
            k += 1;
            *b = sample(k);
        }
        let mut entry: Entry<N> = ([Complex64::new(0.0, 0.0); N], [0.0; N], [0.0; N]);
        for n in 0..N {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for (c, b) in column.iter_mut().zip(&block) {
                *c = b[n];
                lo = lo.min(b[n]);
                hi = hi.max(b[n]);
            }
            entry.0[n] = first_harmonic(&column, omega, dt, t0);
            entry.1[n] = lo.abs().max(hi.abs());
            entry.2[n] = 0.5 * (hi - lo);
        }
        if history.len() == MAX_SUBHARMONIC + 2 {
            history.remove(0);
        }
        history.push(entry);
        let last = history.len() - 1;
        for m in 1..=MAX_SUBHARMONIC {
            if last > m
                && repeats(&history[last], &history[last - m])
                && repeats(&history[last - 1], &history[last - 1 - m])
            {
                order = m;
                break 'settle;
            }
        }
    }
    let t0 = (k + 1) as f64 * dt;
    let mut kept = vec![[0.0; N]; per * KEEP_PERIODS * order];
    for s in kept.iter_mut() {
        k += 1;
        *s = sample(k);
    }
    let mut out = [Complex64::new(0.0, 0.0); N];
    let mut column = vec![0.0; kept.len()];
    for n in 0..N {
        for (c, s) in column.iter_mut().zip(&kept) {
            *c = s[n];
        }
        out[n] = first_harmonic(&column, omega, dt, t0);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_phasor() {
        let (w, dt) = (2.0, 0.01);
        let y: Vec<f64> = (0..1000)
            .map(|k| 0.3 + 1.5 * (w * (0.2 + k as f64 * dt) + 0.4).sin())
            .collect();
        let p = first_harmonic(&y, w, dt, 0.2);
        assert!((p.norm() - 1.5).abs() < 1e-9);
        assert!((p.arg() - 0.4).abs() < 1e-9);
    }

    #[test]
    fn steady_harmonics_wait_for_a_slow_transient() {
        // A transient decaying with tau = 50 s on a 1 rad/s sine: a fixed 10 s settling would
        // leave 80 % of it; the helper waits until the period repeats.
        let (w, dt) = (1.0, 1e-3);
        let p = steady_first_harmonics(w, dt, 10_000, 50_000_000, |k| {
            let t = k as f64 * dt;
            [2.0 * (w * t + 0.3).sin() + 5.0 * (-t / 50.0).exp() * (0.37 * t).sin()]
        });
        assert!(
            (p[0] - Complex64::from_polar(2.0, 0.3)).norm() < 1e-5,
            "{}",
            p[0]
        );
    }

    #[test]
    fn steady_harmonics_of_a_subharmonic_response() {
        // Period three times the input's: the Fourier coefficient at omega over whole
        // three-period spans is the fundamental's, the omega/3 component drops out.
        let (w, dt) = (2.0 * std::f64::consts::PI / 0.5, 1e-3);
        let p = steady_first_harmonics(w, dt, 0, 1_000_000, |k| {
            let t = k as f64 * dt;
            [0.7 * (w * t).cos() + 3.0 * (w / 3.0 * t).sin(), 1.0]
        });
        assert!((p[0] - Complex64::new(0.0, 0.7)).norm() < 1e-9, "{}", p[0]);
        assert!(p[1].norm() < 1e-12);
    }
}
