//! What a designed record may be: timed like the campaign's records, and within the robot's
//! limits as the campaign and the rival models show them.
//!
//! - **Timing.** Each record is a transient plus whole steady periods, at least `periods` of
//!   them and at least `min_steady_s` (both simulators' rule). The campaign's own values are
//!   read back from its records' lengths (see [`RecordTiming::of`]).
//! - **Operating points**: the campaign's own (the robot stood at each of them, so each lies
//!   inside its support polygon; points between them are not proposed).
//! - **Frequencies**: a log grid from the campaign's lowest frequency to the lower of twice its
//!   highest and the slowest rival's tracking low-pass `omega_n` (where a critically damped
//!   servo follows at half amplitude: beyond it the trunk barely moves), never below the
//!   campaign's own highest; as many per decade as the campaign has.
//! - **Amplitudes**: a log grid from a tenth of the campaign's smallest to three times its
//!   largest, each candidate kept only if, for every rival model,
//!   - the excited output's first harmonic is at least [`SNR_FLOOR`] times its noise standard
//!     deviation and [`RESOLUTION_STEPS`] sensor resolution steps (the sine is measured, not the
//!     quantiser);
//!   - the ZMP stays inside the range the campaign's records reached (centre of the records at
//!     that operating point, plus and minus the first and third harmonic): the support polygon
//!     is not known, the range the robot stood through is;
//!   - the trunk acceleration the servo demands, `A w² |H(jw)|`, stays within the largest the
//!     campaign demanded of that axis and within an identified acceleration limit: the
//!     design respects the limit, it does not probe it.

use crate::observe::Observation;
use crate::profiles::servo_of as servo_params_of;
use num_complex::Complex64;
use zmp_campaign::Campaign;
use zmp_models::{Axis, Binding, EffectKind, ModelSpec};

/// A first harmonic at this many noise standard deviations is found with certainty by the
/// record analysis (its steady state and frequency are read from it).
pub const SNR_FLOOR: f64 = 10.0;
/// A sine of fewer resolution steps than this is shaped by the quantiser.
pub const RESOLUTION_STEPS: f64 = 3.0;

/// How records are timed: a transient, then whole periods.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordTiming {
    /// Sample rate of the records, Hz.
    pub sample_rate_hz: f64,
    /// Transient before the steady state is analysed, s.
    pub transient_s: f64,
    /// Fewest whole steady periods a record holds.
    pub periods: u32,
    /// Shortest steady state a record holds, s (slow sines still get `periods`).
    pub min_steady_s: f64,
    /// Whether the values were read back from a campaign timed by this rule (else they are the
    /// identification's windows: see [`RecordTiming::of`]).
    pub exact: bool,
}

impl RecordTiming {
    /// Whole steady periods at `omega`: at least `periods` and `min_steady_s`.
    pub fn steady_periods(&self, omega: f64) -> f64 {
        let period = 2.0 * std::f64::consts::PI / omega;
        (self.periods as f64)
            .max((self.min_steady_s / period - 1e-9).ceil())
            .max(1.0)
    }

    /// Steady-state length at `omega`, s.
    pub fn steady_s(&self, omega: f64) -> f64 {
        self.steady_periods(omega) * 2.0 * std::f64::consts::PI / omega
    }

    /// Whole record at `omega`, s.
    pub fn duration_s(&self, omega: f64) -> f64 {
        self.transient_s + self.steady_s(omega)
    }

    /// The campaign's timing. Its records are read as a transient `t` plus `n_k` whole
    /// periods (to a sample): the transient is the one on the sample grid (up to the shortest
    /// record) that leaves every record closest to a whole number of periods; `periods` is
    /// the fewest whole periods of any record and `min_steady_s` the shortest length that
    /// gives every record with more its count. When no transient leaves every record within
    /// two samples of whole periods (a campaign timed otherwise), the identification's windows
    /// stand in: the median steady-state start, the fewest whole periods and the shortest
    /// window of any record.
    pub fn of(campaign: &Campaign, obs: &[&Observation]) -> RecordTiming {
        let dts: Vec<f64> = campaign
            .records
            .iter()
            .map(|r| r.dt())
            .filter(|d| d.is_finite() && *d > 0.0)
            .collect();
        let rate = campaign
            .sample_rate_hz
            .unwrap_or_else(|| 1.0 / median(dts.clone()).max(1e-9));
        let lengths: Vec<(f64, f64)> = obs
            .iter()
            .filter_map(|o| {
                let r = campaign.records.get(o.index)?;
                let d = r.t.last()? - r.t.first()?;
                Some((d, 2.0 * std::f64::consts::PI / o.omega))
            })
            .collect();
        if let Some(t) = read_back(&lengths, rate) {
            return t;
        }
        let t0 = median(obs.iter().map(|o| o.t0).collect());
        let periods = obs
            .iter()
            .map(|o| (o.duration() * o.omega / (2.0 * std::f64::consts::PI)).floor())
            .fold(f64::INFINITY, f64::min)
            .max(1.0);
        RecordTiming {
            sample_rate_hz: rate,
            transient_s: (t0 * 10.0).ceil() / 10.0,
            periods: periods as u32,
            min_steady_s: obs
                .iter()
                .map(|o| o.duration())
                .fold(f64::INFINITY, f64::min),
            exact: false,
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The transient on the sample grid that leaves every `(length, period)` closest to whole
/// periods, and the timing it implies; `None` when some record stays more than two samples
/// off.
fn read_back(lengths: &[(f64, f64)], rate: f64) -> Option<RecordTiming> {
    let shortest = lengths.iter().map(|l| l.0).fold(f64::INFINITY, f64::min);
    if lengths.is_empty() || !shortest.is_finite() {
        return None;
    }
    let off = |t: f64, (d, p): (f64, f64)| {
        let n = ((d - t) / p).round().max(1.0);
        (d - t - n * p, n)
    };
    let steps = (shortest * rate).floor() as usize;
    let mut best = (f64::INFINITY, 0.0);
    for k in 0..steps {
        let t = k as f64 / rate;
        let worst = lengths
            .iter()
            .map(|&l| off(t, l).0.abs())
            .fold(0.0, f64::max);
        // Ties go to the longer transient (more settling).
        if worst <= best.0 + 1e-12 {
            best = (worst, t);
        }
    }
    if best.0 > 2.0 / rate {
        return None;
    }
    let t = best.1;
    let counts: Vec<(f64, f64)> = lengths.iter().map(|&l| (off(t, l).1, l.1)).collect();
    let periods = counts.iter().map(|c| c.0).fold(f64::INFINITY, f64::min);
    // Records with more periods than the least have them from `min_steady_s`: it lies above
    // `(n - 1) p` for each of them.
    let min_steady = counts
        .iter()
        .filter(|c| c.0 > periods)
        .map(|c| (c.0 - 1.0) * c.1)
        .fold(0.0, f64::max);
    // Rounded up to a millisecond: above every bound, below the next period of any record.
    let min_steady = ((min_steady * 1e3).floor() + 1.0) / 1e3;
    Some(RecordTiming {
        sample_rate_hz: rate,
        transient_s: (t * 1e6).round() / 1e6,
        periods: periods as u32,
        min_steady_s: if counts.iter().any(|c| c.0 > periods) {
            min_steady
        } else {
            0.0
        },
        exact: true,
    })
}

/// Where the acceleration cap of an axis comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CapSource {
    /// The largest acceleration the campaign demanded of the axis.
    Campaign,
    /// A rival's identified acceleration limit (below what the campaign demanded).
    IdentifiedLimit,
}

/// The limits the candidates respect, as used (printed with the design).
#[derive(Debug, Clone, PartialEq)]
pub struct Limits {
    /// Lowest candidate frequency: the campaign's lowest, rad/s.
    pub omega_min: f64,
    /// Highest candidate frequency, rad/s: up to twice the campaign's highest, below the
    /// slowest rival's servo `omega_n`.
    pub omega_max: f64,
    /// The slowest rival's tracking low-pass `omega_n`, rad/s.
    pub servo_omega_n: f64,
    /// Candidate frequencies, rad/s: log-spaced at the campaign's density per decade.
    pub frequencies: Vec<f64>,
    /// Candidate reference amplitudes, m: a log grid around the campaign's and its own.
    pub amplitudes: Vec<f64>,
    /// Candidate operating points `[x, y]`, m: those of the campaign's records.
    pub operating_points: Vec<[f64; 2]>,
    /// Per output `[lo, hi]`, m: the ZMP range the campaign's records reached.
    pub zmp_range: [[f64; 2]; 2],
    /// Per excited axis: the trunk acceleration allowed, m/s², and where it comes from.
    pub acceleration_cap: [(f64, CapSource); 2],
    /// The sensor resolution found in the records, m (0: none found).
    pub resolution: f64,
    /// The excited axes of the campaign.
    pub axes: Vec<Axis>,
}

/// A record the design may propose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The axis the reference sine drives.
    pub excited: Axis,
    /// Excitation frequency, rad/s.
    pub omega: f64,
    /// Reference amplitude, m.
    pub amplitude: f64,
    /// Operating point `[x, y]`, m.
    pub operating_point: [f64; 2],
}

/// The sensor resolution of the records' ZMP columns: the step every sample is a whole
/// multiple of (to a part in a million), from the smallest difference between distinct
/// values; 0 when the samples lie on no such grid.
pub fn sensor_resolution(campaign: &Campaign) -> f64 {
    let mut values: Vec<f64> = campaign
        .records
        .iter()
        .take(4)
        .flat_map(|r| r.zmp_x.iter().chain(&r.zmp_y).copied())
        .filter(|v| v.is_finite())
        .collect();
    values.sort_by(f64::total_cmp);
    values.dedup();
    let q = values
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    if !(q.is_finite() && q > 0.0) {
        return 0.0;
    }
    // The step to 6 significant digits (the differences of large readings carry their
    // rounding).
    let e = 10f64.powi(5 - q.log10().floor() as i32);
    let q = (q * e).round() / e;
    let on_grid = values.iter().all(|v| {
        let k = v / q;
        (k - k.round()).abs() <= 1e-6 * k.abs().max(1.0)
    });
    if on_grid {
        q
    } else {
        0.0
    }
}

/// The trunk acceleration `spec`'s servo demands for a sine of `amplitude` at `omega` on
/// axis `axis`: `A w² |H(jw)|`, m/s².
pub fn demand(spec: &ModelSpec, axis: Axis, omega: f64, amplitude: f64) -> f64 {
    let (wn, zeta) = servo_params_of(spec, Binding::Axis(axis));
    let h = Complex64::new(wn * wn, 0.0)
        / Complex64::new(wn * wn - omega * omega, 2.0 * zeta * wn * omega);
    amplitude * omega * omega * h.norm()
}

impl Limits {
    /// The limits for `rivals` on the campaign (`obs`, its records for the ZMP centres).
    pub fn of(
        campaign: &Campaign,
        obs: &[&Observation],
        rivals: &[&ModelSpec],
        omega_cap: Option<f64>,
    ) -> Limits {
        let omegas: Vec<f64> = crate::criterion::distinct_omegas(obs);
        let (lo, hi) = (omegas[0], omegas[omegas.len() - 1]);
        let servo_omega_n = rivals
            .iter()
            .flat_map(|s| Axis::BOTH.map(|a| servo_params_of(s, Binding::Axis(a)).0))
            .fold(f64::INFINITY, f64::min);
        let omega_max = hi.max(omega_cap.unwrap_or((2.0 * hi).min(servo_omega_n)));
        let per_decade = if omegas.len() > 1 && hi > lo {
            (omegas.len() - 1) as f64 / (hi / lo).log10()
        } else {
            8.0
        };
        let n = ((omega_max / lo).log10() * per_decade).ceil() as usize + 1;
        let frequencies = zmp_models::logspace(lo, omega_max, n.max(2));
        let a_min = obs
            .iter()
            .map(|o| o.nominal_amplitude)
            .fold(f64::INFINITY, f64::min);
        let a_max = obs.iter().map(|o| o.nominal_amplitude).fold(0.0, f64::max);
        let mut amplitudes = zmp_models::logspace(0.1 * a_min, 3.0 * a_max, 10);
        amplitudes.extend(obs.iter().map(|o| o.nominal_amplitude));
        amplitudes.sort_by(f64::total_cmp);
        amplitudes.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs());
        let mut operating_points: Vec<[f64; 2]> = Vec::new();
        for o in obs {
            if !operating_points.contains(&o.operating_point) {
                operating_points.push(o.operating_point);
            }
        }
        let mut zmp_range = [[f64::INFINITY, f64::NEG_INFINITY]; 2];
        for o in obs {
            let c = record_centre(campaign, o);
            for i in 0..2 {
                let e = o.y1[i].norm() + o.y3[i].norm();
                zmp_range[i][0] = zmp_range[i][0].min(c[i] - e);
                zmp_range[i][1] = zmp_range[i][1].max(c[i] + e);
            }
        }
        let mut axes: Vec<Axis> = Vec::new();
        for o in obs {
            if !axes.contains(&o.excited) {
                axes.push(o.excited);
            }
        }
        axes.sort_by_key(|a| a.index());
        let acceleration_cap = Axis::BOTH.map(|a| {
            let campaign_demand = obs
                .iter()
                .filter(|o| o.excited == a)
                .flat_map(|o| {
                    rivals
                        .iter()
                        .map(|s| demand(s, a, o.omega, o.nominal_amplitude))
                })
                .fold(0.0, f64::max);
            let limit = rivals
                .iter()
                .filter_map(|s| {
                    s.value(
                        EffectKind::AccelerationSaturation,
                        Binding::Axis(a),
                        "limit",
                    )
                })
                .fold(f64::INFINITY, f64::min);
            if limit < campaign_demand {
                (limit, CapSource::IdentifiedLimit)
            } else {
                (campaign_demand, CapSource::Campaign)
            }
        });
        Limits {
            omega_min: lo,
            omega_max,
            servo_omega_n,
            frequencies,
            amplitudes,
            operating_points,
            zmp_range,
            acceleration_cap,
            resolution: sensor_resolution(campaign),
            axes,
        }
    }

    /// Every combination of axis, operating point, frequency and amplitude, before the
    /// per-model checks.
    pub fn grid(&self) -> Vec<Candidate> {
        let mut out = Vec::new();
        for &excited in &self.axes {
            for &operating_point in &self.operating_points {
                for &omega in &self.frequencies {
                    for &amplitude in &self.amplitudes {
                        out.push(Candidate {
                            excited,
                            omega,
                            amplitude,
                            operating_point,
                        });
                    }
                }
            }
        }
        out
    }

    /// Whether a candidate whose predicted first and third harmonics (per output, over the
    /// amplitude) are `g`, `g3` under one rival (`spec`) is within the limits; `centre` is the
    /// ZMP at its operating point and `noise_std` the first harmonic's noise standard
    /// deviation on the excited output.
    pub fn admits(
        &self,
        spec: &ModelSpec,
        c: &Candidate,
        g: [Complex64; 2],
        g3: [Complex64; 2],
        centre: [f64; 2],
        noise_std: f64,
    ) -> bool {
        let j = c.excited.index();
        let signal = g[j].norm() * c.amplitude;
        if signal < SNR_FLOOR * noise_std || signal < RESOLUTION_STEPS * self.resolution {
            return false;
        }
        for i in 0..2 {
            let e = (g[i].norm() + g3[i].norm()) * c.amplitude;
            if centre[i] - e < self.zmp_range[i][0] || centre[i] + e > self.zmp_range[i][1] {
                return false;
            }
        }
        demand(spec, c.excited, c.omega, c.amplitude) <= self.acceleration_cap[j].0
    }
}

/// The mean ZMP of a record over its steady window, m.
fn record_centre(campaign: &Campaign, o: &Observation) -> [f64; 2] {
    let Some(r) = campaign.records.get(o.index) else {
        return [0.0; 2];
    };
    let mut sum = [0.0; 2];
    let mut n = 0usize;
    for k in 0..r.len() {
        if r.t[k] >= o.t0 && r.t[k] <= o.t1 {
            sum[0] += r.zmp_x[k];
            sum[1] += r.zmp_y[k];
            n += 1;
        }
    }
    if n == 0 {
        return [0.0; 2];
    }
    [sum[0] / n as f64, sum[1] / n as f64]
}

/// The ZMP centre at each operating point: the median of its records' centres.
pub fn centres(campaign: &Campaign, obs: &[&Observation]) -> Vec<([f64; 2], [f64; 2])> {
    let mut out: Vec<([f64; 2], Vec<[f64; 2]>)> = Vec::new();
    for o in obs {
        let c = record_centre(campaign, o);
        match out.iter_mut().find(|(op, _)| *op == o.operating_point) {
            Some((_, v)) => v.push(c),
            None => out.push((o.operating_point, vec![c])),
        }
    }
    out.into_iter()
        .map(|(op, v)| {
            let m = [0, 1].map(|i| median(v.iter().map(|c| c[i]).collect()));
            (op, m)
        })
        .collect()
}
