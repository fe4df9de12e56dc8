//! The seed's comparison figures (tables 2-4): correlation and RMS between the planned and the
//! measured ZMP (position, velocity, acceleration; x, y and the distance from the origin rho,
//! eq. 8) and the RMS of the roll joints' tracking, plus the mean ZMP bias that correlation
//! cannot see. Velocities and accelerations are differences over the seed's 0.03 s phases.
//!
//! The seed's "XY" RMS rows are computed two ways by the report: the RMS of the change of
//! `rho` (eq. 8's text, here `rms_*[2]`) and the root-sum-square `sqrt(X^2 + Y^2)` of the
//! per-axis RMS (what the seed's table 3 holds: [`super::tables::seed_xy_check`]).

use super::walk::Run;

/// Pearson correlation; NaN for constant signals.
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()) as f64;
    let ma = a.iter().sum::<f64>() / n;
    let mb = b.iter().sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt()
}

/// RMS of the difference.
pub fn rms_diff(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / n as f64).sqrt()
}

/// Mean of the difference `a - b`.
pub fn mean_diff(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    a.iter().zip(b).map(|(x, y)| x - y).sum::<f64>() / n as f64
}

/// Central differences over `dt` (ends one-sided); same length.
pub fn derivative(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            (x[b] - x[a]) / ((b - a).max(1) as f64 * dt)
        })
        .collect()
}

/// The three channels of the seed's tables: x, y and rho = |(x, y)|.
fn channels(v: &[[f64; 2]]) -> [Vec<f64>; 3] {
    [
        v.iter().map(|p| p[0]).collect(),
        v.iter().map(|p| p[1]).collect(),
        v.iter().map(|p| p[0].hypot(p[1])).collect(),
    ]
}

/// One run's figures.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunMetrics {
    /// Correlation of position and velocity, [x, y, xy].
    pub corr_pos: [f64; 3],
    pub corr_vel: [f64; 3],
    /// RMS of the difference: position (m), velocity (m/s), acceleration (m/s^2), [x, y, xy].
    pub rms_pos: [f64; 3],
    pub rms_vel: [f64; 3],
    pub rms_acc: [f64; 3],
    /// Mean ZMP bias measured - planned (m), [x, y].
    pub bias: [f64; 2],
    /// Roll joints' RMS tracking error: [left ankle, left hip, right ankle, right hip] of
    /// position (deg), velocity (deg/s), acceleration (deg/s^2).
    pub roll_pos: [f64; 4],
    pub roll_vel: [f64; 4],
    pub roll_acc: [f64; 4],
}

/// The figures of one run sampled every `dt` (s), over the whole record (the seed's 512
/// phases).
pub fn metrics(run: &Run, dt: f64) -> RunMetrics {
    metrics_over(run, dt, 0..run.zmp.len())
}

/// The figures over the phases `window` only (the seed's other variant: the 256 phases of the
/// motion). Velocities and accelerations are differentiated over the whole record first, so the
/// window's ends are central differences like its inside.
pub fn metrics_over(run: &Run, dt: f64, window: std::ops::Range<usize>) -> RunMetrics {
    let n = run.zmp.len().min(run.zmp_plan.len());
    let w = window.start.min(n)..window.end.min(n);
    let real = channels(&run.zmp);
    let ideal = channels(&run.zmp_plan);
    let mut m = RunMetrics {
        corr_pos: [0.0; 3],
        corr_vel: [0.0; 3],
        rms_pos: [0.0; 3],
        rms_vel: [0.0; 3],
        rms_acc: [0.0; 3],
        bias: [0.0; 2],
        roll_pos: [0.0; 4],
        roll_vel: [0.0; 4],
        roll_acc: [0.0; 4],
    };
    for c in 0..3 {
        let (rv, iv) = (derivative(&real[c], dt), derivative(&ideal[c], dt));
        let (ra, ia) = (derivative(&rv, dt), derivative(&iv, dt));
        let (rp, ip) = (&real[c][w.clone()], &ideal[c][w.clone()]);
        let (rv, iv, ra, ia) = (
            &rv[w.clone()],
            &iv[w.clone()],
            &ra[w.clone()],
            &ia[w.clone()],
        );
        m.corr_pos[c] = correlation(ip, rp);
        m.corr_vel[c] = correlation(iv, rv);
        m.rms_pos[c] = rms_diff(rp, ip);
        m.rms_vel[c] = rms_diff(rv, iv);
        m.rms_acc[c] = rms_diff(ra, ia);
    }
    for c in 0..2 {
        m.bias[c] = mean_diff(&real[c][w.clone()], &ideal[c][w.clone()]);
    }
    let nr = run.roll.len().min(run.roll_plan.len());
    let wr = w.start.min(nr)..w.end.min(nr);
    for j in 0..4 {
        let r: Vec<f64> = run.roll.iter().map(|v| v[j].to_degrees()).collect();
        let p: Vec<f64> = run.roll_plan.iter().map(|v| v[j].to_degrees()).collect();
        let (rv, pv) = (derivative(&r, dt), derivative(&p, dt));
        let (ra, pa) = (derivative(&rv, dt), derivative(&pv, dt));
        m.roll_pos[j] = rms_diff(&r[wr.clone()], &p[wr.clone()]);
        m.roll_vel[j] = rms_diff(&rv[wr.clone()], &pv[wr.clone()]);
        m.roll_acc[j] = rms_diff(&ra[wr.clone()], &pa[wr.clone()]);
    }
    m
}

/// The mean over runs, field by field.
pub fn mean(ms: &[RunMetrics]) -> RunMetrics {
    let n = ms.len() as f64;
    let avg3 = |f: &dyn Fn(&RunMetrics) -> [f64; 3]| {
        std::array::from_fn(|k| ms.iter().map(|m| f(m)[k]).sum::<f64>() / n)
    };
    let avg4 = |f: &dyn Fn(&RunMetrics) -> [f64; 4]| {
        std::array::from_fn(|k| ms.iter().map(|m| f(m)[k]).sum::<f64>() / n)
    };
    RunMetrics {
        corr_pos: avg3(&|m| m.corr_pos),
        corr_vel: avg3(&|m| m.corr_vel),
        rms_pos: avg3(&|m| m.rms_pos),
        rms_vel: avg3(&|m| m.rms_vel),
        rms_acc: avg3(&|m| m.rms_acc),
        bias: std::array::from_fn(|k| ms.iter().map(|m| m.bias[k]).sum::<f64>() / n),
        roll_pos: avg4(&|m| m.roll_pos),
        roll_vel: avg4(&|m| m.roll_vel),
        roll_acc: avg4(&|m| m.roll_acc),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_of_known_signals() {
        let a: Vec<f64> = (0..100).map(|k| (k as f64 * 0.1).sin()).collect();
        let b: Vec<f64> = a.iter().map(|v| 2.0 * v + 0.3).collect();
        assert!((correlation(&a, &b) - 1.0).abs() < 1e-12);
        assert!((mean_diff(&b, &a) - (0.3 + a.iter().sum::<f64>() / 100.0)).abs() < 1e-12);
        let c: Vec<f64> = a.iter().map(|v| v + 0.01).collect();
        assert!((rms_diff(&c, &a) - 0.01).abs() < 1e-12);
        let ramp: Vec<f64> = (0..10).map(|k| 0.5 * k as f64).collect();
        assert!(derivative(&ramp, 0.5)
            .iter()
            .all(|v| (v - 1.0).abs() < 1e-12));
    }
}
