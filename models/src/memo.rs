//! One memory of pure computations by the exact bits of their inputs, shared by the threads of
//! a process: the describing functions of a servo and the discretisations of linear blocks,
//! which a fit asks for many times with the same inputs.
//!
//! The hash keys are fixed (no per-process random seed), so a run's work, and its instruction
//! count under the benches' gate, does not depend on the process. Full, it starts afresh.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, DefaultHasher, Hash};
use std::sync::Mutex;

/// A bounded memory of `K -> V`, shared between threads, emptied when full.
pub struct Memo<K, V> {
    map: Mutex<Option<HashMap<K, V, BuildHasherDefault<DefaultHasher>>>>,
    max: usize,
}

impl<K: Hash + Eq, V: Clone> Memo<K, V> {
    /// An empty memory that keeps at most `max` entries.
    pub const fn new(max: usize) -> Memo<K, V> {
        Memo {
            map: Mutex::new(None),
            max,
        }
    }

    /// The value remembered for `key`, else `compute()` (run without the lock held, so that
    /// other threads go on meanwhile), remembered.
    pub fn get_or(&self, key: K, compute: impl FnOnce() -> V) -> V {
        if let Some(v) = self.lock().as_ref().and_then(|m| m.get(&key)) {
            return v.clone();
        }
        let v = compute();
        let mut guard = self.lock();
        let map = guard.get_or_insert_with(HashMap::default);
        if map.len() >= self.max {
            map.clear();
        }
        map.insert(key, v.clone());
        v
    }

    /// Forgets everything.
    pub fn clear(&self) {
        *self.lock() = None;
    }

    fn lock(
        &self,
    ) -> std::sync::MutexGuard<'_, Option<HashMap<K, V, BuildHasherDefault<DefaultHasher>>>> {
        self.map.lock().unwrap_or_else(|p| p.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    #[test]
    fn computes_once_per_key_and_starts_afresh_when_full() {
        let memo: Memo<u32, u32> = Memo::new(2);
        let calls = Cell::new(0);
        let square = |k: u32| {
            memo.get_or(k, || {
                calls.set(calls.get() + 1);
                k * k
            })
        };
        assert_eq!((square(3), square(3), square(4)), (9, 9, 16));
        assert_eq!(calls.get(), 2);
        // Full: the third key clears the memory, so 3 is computed again.
        assert_eq!((square(5), square(3)), (25, 9));
        assert_eq!(calls.get(), 4);
        memo.clear();
        assert_eq!(square(5), 25);
        assert_eq!(calls.get(), 5);
    }
}
