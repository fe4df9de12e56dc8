//! Work shared out over scoped threads.

use std::sync::atomic::{AtomicUsize, Ordering};

/// `(0..n).map(job)` on up to `threads` scoped threads (jobs handed out one at a time), results
/// in index order.
pub fn parallel_map<T: Send>(n: usize, threads: usize, job: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let workers = threads.clamp(1, n.max(1));
    if workers == 1 {
        return (0..n).map(job).collect();
    }
    let next = AtomicUsize::new(0);
    let mut out: Vec<(usize, T)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                s.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let k = next.fetch_add(1, Ordering::Relaxed);
                        if k >= n {
                            break;
                        }
                        mine.push((k, job(k)));
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
    out.sort_by_key(|r| r.0);
    out.into_iter().map(|r| r.1).collect()
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
}
