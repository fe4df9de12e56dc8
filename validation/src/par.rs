//! Work shared out over scoped threads.

use std::convert::Infallible;
use std::sync::atomic::{AtomicUsize, Ordering};

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
    let mut done: Vec<(usize, Result<T, E>)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                s.spawn(|| {
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
