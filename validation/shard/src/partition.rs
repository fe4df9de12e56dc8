//! Units, shards and the partition.

use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// One unit of a job: a stable id (a file name: letters, digits, `.`, `_`, `-`) and its
/// expected cost (any unit of time; only ratios matter to the partition).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UnitSpec {
    /// The stable id: the name of the unit's result file.
    pub id: String,
    /// Expected cost (any unit of time; only ratios matter).
    pub cost: f64,
}

impl UnitSpec {
    /// The unit `id` of expected cost `cost` (checked when the job is made:
    /// [`Job::new`](crate::Job::new)).
    pub fn new(id: impl Into<String>, cost: f64) -> UnitSpec {
        UnitSpec {
            id: id.into(),
            cost,
        }
    }
}

/// Checks a job's units: ids non-empty, unique, usable as file names, costs finite and not
/// negative.
pub fn check_units(units: &[UnitSpec]) -> Result<()> {
    let mut seen = std::collections::BTreeSet::new();
    for u in units {
        let ok = !u.id.is_empty()
            && !u.id.starts_with('.')
            && u.id
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'));
        if !ok {
            bail!(
                "unit id {:?}: use letters, digits, '.', '_' and '-' only (not first '.')",
                u.id
            );
        }
        if !seen.insert(u.id.as_str()) {
            bail!("unit id {:?} appears twice in the job", u.id);
        }
        if !(u.cost.is_finite() && u.cost >= 0.0) {
            bail!(
                "unit {}: expected cost {} is not a finite cost",
                u.id,
                u.cost
            );
        }
    }
    Ok(())
}

/// Part `index` of `count` (`--shard i/n`, 1 <= i <= n).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    index: usize,
    count: usize,
}

impl Shard {
    /// The whole job (`1/1`).
    pub const WHOLE: Shard = Shard { index: 1, count: 1 };

    /// Part `index` of `count`; an error unless `1 <= index <= count`.
    pub fn new(index: usize, count: usize) -> Result<Shard> {
        if count == 0 || index == 0 || index > count {
            bail!("--shard {index}/{count}: expected i/n with 1 <= i <= n");
        }
        Ok(Shard { index, count })
    }

    /// 1-based.
    pub fn index(self) -> usize {
        self.index
    }

    /// How many parts the job is split into.
    pub fn count(self) -> usize {
        self.count
    }
}

impl FromStr for Shard {
    type Err = anyhow::Error;

    fn from_str(s: &str) -> Result<Shard> {
        let bad = || anyhow::anyhow!("--shard {s:?}: expected i/n with 1 <= i <= n, e.g. 2/4");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let i: usize = i.trim().parse().map_err(|_| bad())?;
        let n: usize = n.trim().parse().map_err(|_| bad())?;
        Shard::new(i, n).map_err(|_| bad())
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The units' indices in longest-processing-time-first order: expected cost descending, ties
/// by id ascending (a total order, so the same on every machine): the order a whole run takes
/// them in, as its threads come free.
pub fn lpt_order(units: &[UnitSpec]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..units.len()).collect();
    order.sort_by(|&a, &b| {
        units[b]
            .cost
            .total_cmp(&units[a].cost)
            .then_with(|| units[a].id.cmp(&units[b].id))
    });
    order
}

/// Splits the units into `n` parts balanced by expected cost: in longest-processing-time-first
/// order (expected cost descending, ties by id ascending), each unit goes to the part with the
/// least expected cost so far (ties: the lowest part). Each part lists
/// its unit indices in the order it runs them (longest first). Deterministic: it depends on
/// the ids and costs only, not on the units' order in the job.
pub fn partition(units: &[UnitSpec], n: usize) -> Vec<Vec<usize>> {
    let n = n.max(1);
    let mut parts = vec![Vec::new(); n];
    let mut load = vec![0.0_f64; n];
    for k in lpt_order(units) {
        let p = (0..n)
            .min_by(|&a, &b| load[a].total_cmp(&load[b]).then(a.cmp(&b)))
            .unwrap_or(0);
        load[p] += units[k].cost;
        parts[p].push(k);
    }
    parts
}

/// The unit indices of `shard` (see [`partition`]).
pub fn shard_units(units: &[UnitSpec], shard: Shard) -> Vec<usize> {
    partition(units, shard.count()).swap_remove(shard.index() - 1)
}

/// The units `shard` takes, in the order it takes them, each with whether it is in the shard's
/// own part: its part (longest expected first), then, with `steal`, the units of the other
/// parts in longest-processing-time-first order (those no other shard has claimed yet, when it
/// gets to them: [`crate::claim`]). A shard that finishes its part early takes the longest unit
/// left anywhere, as a thread of one process's pool takes the next in its queue.
pub fn shard_sequence(units: &[UnitSpec], shard: Shard, steal: bool) -> Vec<(usize, bool)> {
    let own = shard_units(units, shard);
    let mut seq: Vec<(usize, bool)> = own.iter().map(|&k| (k, true)).collect();
    if steal {
        let mine: std::collections::BTreeSet<usize> = own.into_iter().collect();
        seq.extend(
            lpt_order(units)
                .into_iter()
                .filter(|k| !mine.contains(k))
                .map(|k| (k, false)),
        );
    }
    seq
}

#[cfg(test)]
mod tests {
    use super::*;

    fn units(costs: &[f64]) -> Vec<UnitSpec> {
        costs
            .iter()
            .enumerate()
            .map(|(k, &c)| UnitSpec::new(format!("u{k:02}"), c))
            .collect()
    }

    #[test]
    fn shard_parses_and_refuses_nonsense() {
        let s: Shard = "2/4".parse().unwrap();
        assert_eq!((s.index(), s.count()), (2, 4));
        assert_eq!(s.to_string(), "2/4");
        for bad in ["0/4", "5/4", "1/0", "2", "a/b", "-1/3", ""] {
            let e = bad.parse::<Shard>().unwrap_err().to_string();
            assert!(e.contains("1 <= i <= n"), "{bad}: {e}");
        }
    }

    #[test]
    fn partition_covers_every_unit_once_and_balances_by_cost() {
        // LPT on 6, 5, 4, 3, 2, 1 over 2 parts: {6, 3, 2} = 11 and {5, 4, 1} = 10 (greedy by
        // hand: 6|5, 4 -> B (9), 3 -> A (9), 2 -> A (11; tie A first), 1 -> B (10)).
        let u = units(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let p = partition(&u, 2);
        let cost = |part: &[usize]| part.iter().map(|&k| u[k].cost).sum::<f64>();
        assert_eq!(p[0], vec![5, 2, 1]);
        assert_eq!(p[1], vec![4, 3, 0]);
        assert_eq!((cost(&p[0]), cost(&p[1])), (11.0, 10.0));
        for n in 1..=8 {
            let mut all: Vec<usize> = partition(&u, n).concat();
            all.sort();
            assert_eq!(all, (0..6).collect::<Vec<_>>(), "n = {n}");
        }
        // More parts than units: the extra parts are empty.
        assert_eq!(partition(&u, 8).iter().filter(|p| p.is_empty()).count(), 2);
    }

    #[test]
    fn partition_depends_on_ids_and_costs_not_on_job_order() {
        let u = units(&[3.0, 3.0, 1.0, 7.0, 2.0, 2.0, 5.0]);
        let mut rev = u.clone();
        rev.reverse();
        let ids = |units: &[UnitSpec], p: Vec<Vec<usize>>| -> Vec<Vec<String>> {
            p.into_iter()
                .map(|part| part.into_iter().map(|k| units[k].id.clone()).collect())
                .collect()
        };
        for n in 1..=4 {
            assert_eq!(ids(&u, partition(&u, n)), ids(&rev, partition(&rev, n)));
            for i in 1..=n {
                let s = Shard::new(i, n).unwrap();
                assert_eq!(shard_units(&u, s), partition(&u, n)[i - 1]);
            }
        }
    }

    #[test]
    fn a_stealing_shard_takes_its_part_then_the_rest_longest_first() {
        let u = units(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let s = Shard::new(2, 2).unwrap();
        assert_eq!(
            shard_sequence(&u, s, false),
            vec![(4, true), (3, true), (0, true)]
        );
        assert_eq!(
            shard_sequence(&u, s, true),
            vec![
                (4, true),
                (3, true),
                (0, true),
                (5, false),
                (2, false),
                (1, false)
            ]
        );
    }

    #[test]
    fn bad_units_are_named() {
        let e = check_units(&units(&[1.0, f64::NAN]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("u01"), "{e}");
        let mut u = units(&[1.0, 2.0]);
        u[1].id = "u00".into();
        assert!(check_units(&u).unwrap_err().to_string().contains("twice"));
        u[1].id = "../x".into();
        assert!(check_units(&u).unwrap_err().to_string().contains("letters"));
    }
}
