//! The operator cache: removal operators shared by the requests that ask about the same
//! process, radial grid and tool positions.
//!
//! Assembling M costs a running integral of the rate along the path per radius (about 130
//! rates on a plane, each a closed form; about 80 on a curved part, each an adaptive
//! quadrature): for 1001 × 1001 about 6 ms flat and 11 ms on a sphere on two cores
//! (docs/PERFORMANCE.md), where applying it to a dwell takes well under a millisecond. A
//! shop's callers ask about the same set-up again and again (a front-end editing the dwell, a
//! batch of targets on one process), so predictions and optimizations take M from here.
//!
//! The key is every bit M depends on (the process's radii, speeds, Preston coefficient,
//! pressure and its model, the part's surface and the pad's orientation; each grid radius; each
//! position), compared in full, so a hit is the operator a fresh assembly would give, and a
//! response never depends on what was asked before. Memory is bounded in bytes: the least
//! recently used operators go first, and one larger than the whole budget is not kept.

use std::collections::HashMap;
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use crate::physics::{
    Layout, Motion, Process, RemovalKernel, RemovalOperator, RowReading, Turning,
};

/// Default memory budget of the cache, bytes.
pub const DEFAULT_OPERATOR_CACHE_BYTES: usize = 64 * 1024 * 1024;

/// What the cache has done and holds, for metrics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct OperatorCacheStats {
    pub hits: u64,
    pub misses: u64,
    pub evictions: u64,
    pub entries: usize,
    pub bytes: usize,
    pub capacity_bytes: usize,
}

struct Entry {
    operator: Arc<RemovalOperator>,
    bytes: usize,
    last_used: u64,
}

#[derive(Default)]
struct Held {
    entries: HashMap<Vec<u64>, Entry>,
    bytes: usize,
    clock: u64,
}

/// Removal operators by everything they depend on, within a memory budget; one per service.
pub struct OperatorCache {
    held: Mutex<Held>,
    capacity_bytes: usize,
    hits: AtomicU64,
    misses: AtomicU64,
    evictions: AtomicU64,
}

impl std::fmt::Debug for OperatorCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OperatorCache")
            .field("stats", &self.stats())
            .finish()
    }
}

impl Default for OperatorCache {
    fn default() -> Self {
        OperatorCache::new(DEFAULT_OPERATOR_CACHE_BYTES)
    }
}

/// Every bit the operator of `process` from `motion` to `radii_mm` depends on.
fn key(process: &Process, radii_mm: &[f64], motion: &Motion) -> Vec<u64> {
    // The stations are the motion: with C turning at a constant speed they fix the cells.
    // (The 1-D operator is C at constant speed; a C law's removal is 2-D, `physics::polar`.)
    debug_assert_eq!(motion.turning(), &Turning::Constant);
    let stations_mm = motion.radii_mm();
    let s = process.spec();
    let surface = s.part.surface.key_bits();
    let mut key = Vec::with_capacity(12 + surface.len() + radii_mm.len() + stations_mm.len());
    key.extend(
        [
            s.workpiece_radius_mm,
            s.tool_radius_mm,
            s.workpiece_rpm,
            s.tool_rpm,
            s.preston_coefficient_m2_per_n,
            s.pressure_kpa,
        ]
        .map(f64::to_bits),
    );
    key.extend([
        s.part.orientation as u64,
        radii_mm.len() as u64,
        stations_mm.len() as u64,
    ]);
    key.extend(s.pressure_model.key_bits());
    key.extend(surface);
    key.extend(radii_mm.iter().chain(stations_mm).map(|v| v.to_bits()));
    key
}

impl OperatorCache {
    /// A cache holding at most `capacity_bytes` of operators (0: keeps none).
    pub fn new(capacity_bytes: usize) -> Self {
        OperatorCache {
            held: Mutex::new(Held::default()),
            capacity_bytes,
            hits: AtomicU64::new(0),
            misses: AtomicU64::new(0),
            evictions: AtomicU64::new(0),
        }
    }

    /// The operator of `process` from `motion` to `radii_mm`, assembled (outside the
    /// lock, by row) when not held.
    pub fn operator(
        &self,
        process: &Process,
        radii_mm: &[f64],
        motion: &Motion,
    ) -> Arc<RemovalOperator> {
        self.operator_reading(process, radii_mm, motion, None).0
    }

    /// [`Self::operator`], and when it is assembled now, `reading`'s figure at its rows as the
    /// operator's rows read it ([`RemovalOperator::assemble_reading`]); `None` for the
    /// reading when the operator was held (or the rows could not read it).
    pub fn operator_reading(
        &self,
        process: &Process,
        radii_mm: &[f64],
        motion: &Motion,
        reading: Option<&dyn RowReading>,
    ) -> (Arc<RemovalOperator>, Option<Vec<f64>>) {
        let key = key(process, radii_mm, motion);
        if let Some(held) = self.lookup(&key) {
            return (held, None);
        }
        let (operator, read) = RemovalOperator::assemble_reading(
            &RemovalKernel::new(process),
            radii_mm,
            motion,
            reading,
            Layout::Rows,
        );
        (self.keep(key, operator), read)
    }

    /// [`Self::operator_reading`] for a caller that first needs only the rows `first`, with
    /// `during(operator, rows)` run on an operator holding them (`rows`: where they are in
    /// it): the held operator, or when it is assembled now, the rows `first` alone while the
    /// others are assembled beside it ([`RemovalOperator::assemble_while`]).
    pub fn operator_while<R: Send>(
        &self,
        process: &Process,
        radii_mm: &[f64],
        motion: &Motion,
        reading: Option<&dyn RowReading>,
        first: Range<usize>,
        during: impl FnOnce(&RemovalOperator, Range<usize>) -> R + Send,
    ) -> (Arc<RemovalOperator>, Option<Vec<f64>>, R) {
        let key = key(process, radii_mm, motion);
        if let Some(held) = self.lookup(&key) {
            let result = during(&held, first);
            return (held, None, result);
        }
        let (operator, read, result) = RemovalOperator::assemble_while(
            &RemovalKernel::new(process),
            radii_mm,
            motion,
            reading,
            first,
            during,
        );
        (self.keep(key, operator), read, result)
    }

    /// The operator held under `key`, counted as a hit (or the miss counted).
    fn lookup(&self, key: &[u64]) -> Option<Arc<RemovalOperator>> {
        if let Ok(mut held) = self.held.lock() {
            held.clock += 1;
            let now = held.clock;
            if let Some(entry) = held.entries.get_mut(key) {
                entry.last_used = now;
                self.hits.fetch_add(1, Ordering::Relaxed);
                return Some(entry.operator.clone());
            }
        }
        self.misses.fetch_add(1, Ordering::Relaxed);
        None
    }

    /// A newly assembled operator, shared, and kept within the budget.
    fn keep(&self, key: Vec<u64>, operator: RemovalOperator) -> Arc<RemovalOperator> {
        let operator = Arc::new(operator);
        let bytes = operator.heap_bytes() + 8 * key.len();
        if bytes > self.capacity_bytes {
            return operator;
        }
        let Ok(mut held) = self.held.lock() else {
            return operator;
        };
        while held.bytes + bytes > self.capacity_bytes {
            let Some(oldest) = held
                .entries
                .iter()
                .min_by_key(|(_, e)| e.last_used)
                .map(|(k, _)| k.clone())
            else {
                break;
            };
            if let Some(gone) = held.entries.remove(&oldest) {
                held.bytes -= gone.bytes;
                self.evictions.fetch_add(1, Ordering::Relaxed);
            }
        }
        held.clock += 1;
        let last_used = held.clock;
        // Two requests may have assembled the same operator at once: keep one.
        if let Some(previous) = held.entries.insert(
            key,
            Entry {
                operator: operator.clone(),
                bytes,
                last_used,
            },
        ) {
            held.bytes -= previous.bytes;
        }
        held.bytes += bytes;
        operator
    }

    pub fn stats(&self) -> OperatorCacheStats {
        let (entries, bytes) = self
            .held
            .lock()
            .map(|h| (h.entries.len(), h.bytes))
            .unwrap_or_default();
        OperatorCacheStats {
            hits: self.hits.load(Ordering::Relaxed),
            misses: self.misses.load(Ordering::Relaxed),
            evictions: self.evictions.load(Ordering::Relaxed),
            entries,
            bytes,
            capacity_bytes: self.capacity_bytes,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::process::tests::paper_spec;
    use crate::physics::ProcessSpec;

    fn even(n: usize) -> Vec<f64> {
        (0..n).map(|j| 50.0 * j as f64 / (n - 1) as f64).collect()
    }

    fn stations(n: usize) -> Motion {
        Motion::radial(even(n))
    }

    /// A hit is the operator a fresh assembly gives, bit for bit; any input that changes M
    /// misses; the budget holds, the least recently used going first.
    #[test]
    fn hits_are_exact_misses_follow_every_input_and_the_budget_holds() {
        let process = Process::new(paper_spec(-10.0, 200.0)).unwrap();
        let (radii, positions) = (even(201), stations(101));
        let cache = OperatorCache::new(usize::MAX);
        let first = cache.operator(&process, &radii, &positions);
        let again = cache.operator(&process, &radii, &positions);
        assert!(Arc::ptr_eq(&first, &again));
        let fresh = RemovalOperator::assemble(&RemovalKernel::new(&process), &radii, &positions);
        assert_eq!(*again, fresh);
        assert_eq!((cache.stats().hits, cache.stats().misses), (1, 1));

        let other = Process::new(ProcessSpec {
            pressure_kpa: 10.000000001,
            ..paper_spec(-10.0, 200.0)
        })
        .unwrap();
        let mut moved = positions.radii_mm().to_vec();
        moved[50] += 1e-9;
        let moved = Motion::radial(moved);
        for (p, r, x) in [
            (&other, &radii, &positions),
            (&process, &even(202), &positions),
            (&process, &radii, &moved),
        ] {
            let m = cache.operator(p, r, x);
            assert_eq!(*m, RemovalOperator::assemble(&RemovalKernel::new(p), r, x));
        }
        let stats = cache.stats();
        assert_eq!((stats.hits, stats.misses, stats.entries), (1, 4, 4));

        // Room for two of these operators: a third evicts the least recently used.
        let one = cache.stats().bytes / 4;
        let small = OperatorCache::new(2 * one + one / 2);
        small.operator(&process, &radii, &positions);
        small.operator(&other, &radii, &positions);
        small.operator(&process, &radii, &positions); // the first is now the newer
        small.operator(&process, &radii, &moved);
        let stats = small.stats();
        assert_eq!((stats.entries, stats.evictions), (2, 1));
        assert!(stats.bytes <= stats.capacity_bytes);
        small.operator(&process, &radii, &positions);
        assert_eq!(small.stats().hits, 2, "the recently used one stayed");
        // A budget of 0 keeps nothing and still answers.
        let none = OperatorCache::new(0);
        assert_eq!(*none.operator(&process, &radii, &positions), fresh);
        assert_eq!(none.stats().entries, 0);
    }
}
