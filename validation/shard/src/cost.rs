//! The cost model: from the measured wall time of every unit, the critical path and the wall
//! time a job is predicted to take on N workers, each worker taking the longest unit left
//! (longest-processing-time-first). Units are independent, so the critical path is the
//! longest unit: no number of workers finishes sooner. LPT is within 4/3 of the best possible
//! schedule (Graham 1969); a pool that hands out units as workers come free runs the same
//! schedule when it is given the units longest first.

use serde::Serialize;

/// The worker counts `merge` predicts for.
pub const WORKERS: [usize; 5] = [1, 2, 8, 64, 256];

/// Makespan of the LPT schedule of `times` (seconds) on `workers` workers.
pub fn lpt_makespan(times: &[f64], workers: usize) -> f64 {
    let mut sorted: Vec<f64> = times.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    list_makespan(&sorted, workers)
}

/// Makespan of taking `times` (seconds) in the order given, each to the worker that comes
/// free first (list scheduling: a process's thread pool over its queue).
pub fn list_makespan(times: &[f64], workers: usize) -> f64 {
    let mut load = vec![0.0_f64; workers.max(1)];
    for &t in times {
        let k = (0..load.len())
            .min_by(|&a, &b| load[a].total_cmp(&load[b]))
            .unwrap_or(0);
        load[k] += t;
    }
    load.into_iter().fold(0.0, f64::max)
}

/// Makespan of shards that each take, one unit at a time, the next unit of their own
/// sequence (`seqs[i]`: unit indices into `times`, seconds) that no shard has taken yet: the
/// claims of `--steal` ([`crate::shard_sequence`]), or a static partition when the sequences
/// are disjoint. A shard that comes free first chooses first (ties: the lower shard).
pub fn shards_makespan(seqs: &[Vec<usize>], times: &[f64]) -> f64 {
    let mut clock = vec![0.0_f64; seqs.len()];
    let mut next = vec![0_usize; seqs.len()];
    let mut active: Vec<bool> = vec![true; seqs.len()];
    let mut taken = vec![false; times.len()];
    while let Some(i) = (0..seqs.len())
        .filter(|&i| active[i])
        .min_by(|&a, &b| clock[a].total_cmp(&clock[b]).then(a.cmp(&b)))
    {
        while next[i] < seqs[i].len() && taken[seqs[i][next[i]]] {
            next[i] += 1;
        }
        match seqs[i].get(next[i]) {
            Some(&k) => {
                taken[k] = true;
                clock[i] += times[k];
            }
            None => active[i] = false,
        }
    }
    clock.into_iter().fold(0.0, f64::max)
}

/// The longest unit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CriticalPath {
    /// Its id.
    pub unit: String,
    /// Its measured wall time, s: no schedule on any number of workers ends sooner.
    pub seconds: f64,
}

/// Predicted wall time on a number of workers.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Prediction {
    /// Workers running units at once.
    pub workers: usize,
    /// Wall time of the longest-processing-time-first schedule on them, s (no overhead).
    pub wall_s: f64,
}

/// What the measured unit times say about the job's cost.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CostModel {
    /// Units with a measured time.
    pub units: usize,
    /// Sum of the unit times (one worker, no overhead).
    pub total_s: f64,
    /// The longest unit (`None` without a measured time).
    pub critical_path: Option<CriticalPath>,
    /// The predicted wall time per count of workers asked.
    pub predicted: Vec<Prediction>,
}

/// The cost model of `(unit id, seconds)` for each count of `workers`.
pub fn cost_model(times: &[(String, f64)], workers: &[usize]) -> CostModel {
    let t: Vec<f64> = times.iter().map(|(_, s)| *s).collect();
    let critical_path = times
        .iter()
        .max_by(|a, b| a.1.total_cmp(&b.1).then_with(|| b.0.cmp(&a.0)))
        .map(|(id, s)| CriticalPath {
            unit: id.clone(),
            seconds: *s,
        });
    CostModel {
        units: times.len(),
        total_s: t.iter().sum(),
        critical_path,
        predicted: workers
            .iter()
            .map(|&w| Prediction {
                workers: w,
                wall_s: lpt_makespan(&t, w),
            })
            .collect(),
    }
}

impl CostModel {
    /// Lines for a terminal.
    pub fn text(&self) -> String {
        let mut s = format!(
            "cost model: {} units measured, {:.1} s of work",
            self.units, self.total_s
        );
        if let Some(c) = &self.critical_path {
            s.push_str(&format!(
                "; critical path: unit {} ({:.1} s), the shortest wall time any number of \
                 workers can reach",
                c.unit, c.seconds
            ));
        }
        s.push_str("\npredicted wall time (LPT over the measured unit times):");
        for p in &self.predicted {
            s.push_str(&format!(
                "\n  {:>4} worker{}: {}",
                p.workers,
                if p.workers == 1 { " " } else { "s" },
                human(p.wall_s)
            ));
        }
        s
    }
}

/// Seconds as `12.3 s`, `4.5 min` or `1.2 h`.
pub fn human(s: f64) -> String {
    if s < 120.0 {
        format!("{s:.1} s")
    } else if s < 7200.0 {
        format!("{:.1} min", s / 60.0)
    } else {
        format!("{:.2} h", s / 3600.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lpt_matches_schedules_worked_by_hand() {
        // 7, 5, 4, 3, 3 on 2 workers: 7 -> A, 5 -> B, 4 -> B (9), 3 -> A (10), 3 -> B (12).
        // Makespan 12 (the best is 11: {7, 4} {5, 3, 3}; LPT's 4/3 bound holds).
        assert_eq!(lpt_makespan(&[3.0, 7.0, 4.0, 3.0, 5.0], 2), 12.0);
        assert_eq!(lpt_makespan(&[3.0, 7.0, 4.0, 3.0, 5.0], 1), 22.0);
        // As many workers as units or more: the longest unit.
        assert_eq!(lpt_makespan(&[3.0, 7.0, 4.0], 3), 7.0);
        assert_eq!(lpt_makespan(&[3.0, 7.0, 4.0], 256), 7.0);
        assert_eq!(lpt_makespan(&[], 4), 0.0);
        // Equal units: ceil(n / w) of them per worker.
        assert_eq!(lpt_makespan(&[1.0; 10], 4), 3.0);
    }

    #[test]
    fn stealing_shards_match_a_schedule_worked_by_hand() {
        // Expected costs put {0, 3} in shard 1 and {1, 2} in shard 2 (units 0..4); measured,
        // unit 0 takes 10 s and the rest 1 s. Static: shard 1 ends at 11, shard 2 at 2.
        let times = [10.0, 1.0, 1.0, 1.0];
        let parts = vec![vec![0, 3], vec![1, 2]];
        assert_eq!(shards_makespan(&parts, &times), 11.0);
        // Stealing (own part, then the rest in order 0, 1, 2, 3): shard 2 runs 1 and 2, then
        // takes 3 at t = 2 while shard 1 runs 0 until 10: makespan 10.
        let steal = vec![vec![0, 3, 1, 2], vec![1, 2, 0, 3]];
        assert_eq!(shards_makespan(&steal, &times), 10.0);
        // One shard holding every unit: their sum; no shards: nothing.
        assert_eq!(shards_makespan(&[vec![0, 1, 2, 3]], &times), 13.0);
        assert_eq!(shards_makespan(&[], &times), 0.0);
    }

    #[test]
    fn the_model_names_the_critical_path_and_never_predicts_below_it() {
        let times: Vec<(String, f64)> =
            (0..20).map(|k| (format!("u{k}"), 1.0 + k as f64)).collect();
        let m = cost_model(&times, &WORKERS);
        assert_eq!(m.total_s, 210.0);
        let c = m.critical_path.clone().unwrap();
        assert_eq!((c.unit.as_str(), c.seconds), ("u19", 20.0));
        assert_eq!(m.predicted[0].wall_s, 210.0);
        for p in &m.predicted {
            assert!(p.wall_s >= 20.0 && p.wall_s >= 210.0 / p.workers as f64 - 1e-9);
        }
        assert_eq!(m.predicted.last().unwrap().wall_s, 20.0);
        assert!(m.text().contains("critical path: unit u19"), "{}", m.text());
    }
}
