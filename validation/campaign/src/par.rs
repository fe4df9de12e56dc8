//! Work shared out over scoped threads.
//!
//! One budget of threads per piece of work: an entry point sets it with [`with_threads`]
//! (the user's `--threads`, 1 for the instruction-count benches), work nested inside a
//! [`parallel_map`] worker gets 1 plus the pool's workers that have run out of jobs (the outer
//! map already uses the cores; at its tail, the last long job may use the cores the others left
//! idle), and code deep in a call tree asks [`budget`] instead of starting threads of its own.
//!
//! A time limit travels the same way: an entry point sets it with [`with_deadline`], the
//! workers of a [`parallel_map`] inherit their caller's, and a long computation deep in the
//! tree asks [`past_deadline`] (the diagnosis's fits: see `diagnose::engine`).

use std::cell::{Cell, RefCell};
use std::convert::Infallible;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

#[derive(Clone)]
enum Budget {
    /// Not set: the machine's cores.
    Machine,
    Fixed(usize),
    /// A pool's worker: 1 plus the pool's workers that found no more jobs.
    Worker(Arc<AtomicUsize>),
}

thread_local! {
    static BUDGET: RefCell<Budget> = const { RefCell::new(Budget::Machine) };
    static DEADLINE: Cell<Option<Instant>> = const { Cell::new(None) };
}

/// Runs `f` with `deadline` as this thread's time limit (and its pools' workers'); restored
/// afterwards, also when `f` panics. An inner deadline later than the one already set does
/// not extend it.
pub fn with_deadline<R>(deadline: Option<Instant>, f: impl FnOnce() -> R) -> R {
    struct Restore(Option<Instant>);
    impl Drop for Restore {
        fn drop(&mut self) {
            DEADLINE.with(|d| d.set(self.0));
        }
    }
    let outer = DEADLINE.with(Cell::get);
    let inner = match (outer, deadline) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    };
    let _restore = Restore(outer);
    DEADLINE.with(|d| d.set(inner));
    f()
}

/// Whether this thread's time limit (see [`with_deadline`]) has passed.
pub fn past_deadline() -> bool {
    DEADLINE
        .with(Cell::get)
        .is_some_and(|d| Instant::now() >= d)
}

/// Threads the work on this thread may use: what [`with_threads`] set; inside a
/// [`parallel_map`] worker 1 plus its pool's idle workers; else the available cores.
pub fn budget() -> usize {
    match BUDGET.with(|b| b.borrow().clone()) {
        Budget::Machine => std::thread::available_parallelism().map_or(1, |n| n.get()),
        Budget::Fixed(n) => n,
        Budget::Worker(idle) => 1 + idle.load(Ordering::Relaxed),
    }
    .max(1)
}

fn set_budget(b: Budget) -> Budget {
    BUDGET.with(|cell| cell.replace(b))
}

/// Runs `f` with the thread budget `threads` on this thread (restored afterwards, also when
/// `f` panics).
pub fn with_threads<R>(threads: usize, f: impl FnOnce() -> R) -> R {
    struct Restore(Option<Budget>);
    impl Drop for Restore {
        fn drop(&mut self) {
            if let Some(b) = self.0.take() {
                set_budget(b);
            }
        }
    }
    let _restore = Restore(Some(set_budget(Budget::Fixed(threads.max(1)))));
    f()
}

/// `(0..n).map(job)` on up to `threads` scoped threads (jobs handed out one at a time), results
/// in index order.
pub fn parallel_map<T: Send>(n: usize, threads: usize, job: impl Fn(usize) -> T + Sync) -> Vec<T> {
    match try_parallel_map(n, threads, |k| Ok::<T, Infallible>(job(k))) {
        Ok(v) => v,
        Err(never) => match never {},
    }
}

/// [`parallel_map`] for fallible jobs: on failure returns the error of the smallest failing
/// index (deterministically, whatever the scheduling); indices above a known failure are
/// skipped.
pub fn try_parallel_map<T: Send, E: Send>(
    n: usize,
    threads: usize,
    job: impl Fn(usize) -> Result<T, E> + Sync,
) -> Result<Vec<T>, E> {
    let workers = threads.clamp(1, n.max(1));
    if workers == 1 {
        return (0..n).map(job).collect();
    }
    let next = AtomicUsize::new(0);
    let first_failure = AtomicUsize::new(usize::MAX);
    let idle = Arc::new(AtomicUsize::new(0));
    let deadline = DEADLINE.with(Cell::get);
    let mut done: Vec<(usize, Result<T, E>)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                s.spawn(|| {
                    set_budget(Budget::Worker(Arc::clone(&idle)));
                    DEADLINE.with(|d| d.set(deadline));
                    let mut mine = Vec::new();
                    loop {
                        let k = next.fetch_add(1, Ordering::Relaxed);
                        if k >= n || k > first_failure.load(Ordering::Relaxed) {
                            break;
                        }
                        let result = job(k);
                        if result.is_err() {
                            first_failure.fetch_min(k, Ordering::Relaxed);
                        }
                        mine.push((k, result));
                    }
                    idle.fetch_add(1, Ordering::Relaxed);
                    mine
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    });
    // Every index below the first failure was processed, so in index order the first error
    // comes before any gap.
    done.sort_by_key(|r| r.0);
    done.into_iter().map(|r| r.1).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn budget_is_set_restored_and_grows_at_a_pools_tail() {
        let unset = || matches!(BUDGET.with(|b| b.borrow().clone()), Budget::Machine);
        with_threads(3, || {
            assert_eq!(budget(), 3);
            // Job 0 returns at once; its worker then finds no job left and goes idle, which
            // job 1 (busy while job 0 ran: it saw a budget of 1) sees as a second thread.
            let seen = parallel_map(2, 2, |k| {
                if k == 0 {
                    return (budget(), budget());
                }
                let first = budget();
                let t = std::time::Instant::now();
                while budget() < 2 && t.elapsed().as_secs() < 10 {
                    std::thread::yield_now();
                }
                (first, budget())
            });
            assert!(seen[0].0 <= 2 && seen[1].0 <= 2, "{seen:?}");
            assert_eq!(seen[1].1, 2, "{seen:?}");
            // A map that runs on the calling thread (one worker) keeps the caller's budget.
            assert_eq!(parallel_map(2, 1, |_| budget()), vec![3; 2]);
            with_threads(2, || assert_eq!(budget(), 2));
            assert_eq!(budget(), 3);
        });
        assert!(unset());
        let caught = std::panic::catch_unwind(|| with_threads(5, || panic!("inside")));
        assert!(caught.is_err());
        assert!(unset());
    }

    #[test]
    fn a_deadline_reaches_the_workers_and_is_restored() {
        let now = Instant::now();
        assert!(!past_deadline());
        with_deadline(Some(now), || {
            assert!(past_deadline());
            // The workers of a pool see their caller's deadline.
            assert_eq!(parallel_map(4, 2, |_| past_deadline()), vec![true; 4]);
            // A later inner deadline does not extend the outer one.
            let later = now + std::time::Duration::from_secs(3600);
            with_deadline(Some(later), || assert!(past_deadline()));
            with_deadline(None, || assert!(past_deadline()));
        });
        assert!(!past_deadline());
        let later = Instant::now() + std::time::Duration::from_secs(3600);
        with_deadline(Some(later), || {
            assert!(!past_deadline());
            assert_eq!(parallel_map(3, 2, |_| past_deadline()), vec![false; 3]);
        });
        let caught = std::panic::catch_unwind(|| with_deadline(Some(now), || panic!("inside")));
        assert!(caught.is_err());
        assert!(!past_deadline());
    }

    #[test]
    fn parallel_map_keeps_order() {
        for threads in [1, 2, 5] {
            let v = parallel_map(11, threads, |k| k * k);
            assert_eq!(v, (0..11).map(|k| k * k).collect::<Vec<_>>());
        }
        assert!(parallel_map(0, 2, |k| k).is_empty());
    }

    #[test]
    fn try_parallel_map_returns_the_first_error_in_index_order() {
        for threads in [1, 2, 5] {
            let r = try_parallel_map(40, threads, |k| if k % 7 == 3 { Err(k) } else { Ok(k) });
            assert_eq!(r, Err(3));
            let ok = try_parallel_map(9, threads, Ok::<usize, ()>);
            assert_eq!(ok, Ok((0..9).collect::<Vec<_>>()));
        }
    }
}
