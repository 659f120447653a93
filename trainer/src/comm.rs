//! What the learner needs from a multi-process run (MPI ranks, each stepping its own envs): sums and gathers
//! whose results are bit-identical on every rank, so all ranks keep the same weights without ever sending them.
//! The learner knows only this trait; `Single` is the one-process run, the MPI implementation lives in the app.

use std::cell::Cell;
use std::time::{Duration, Instant};

/// Time spent in collectives and bytes this rank sent plus received, since the last `take`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CommStats {
    pub seconds: f64,
    pub bytes: u64,
    pub calls: u64,
}

/// Collectives over the ranks of a run. Every rank calls the same collectives in the same order.
pub trait Comm {
    fn rank(&self) -> usize;
    fn size(&self) -> usize;
    /// Element-wise sum over ranks, written back on every rank; the same bits on all of them.
    fn sum_f32(&self, buf: &mut [f32]);
    fn sum_f64(&self, buf: &mut [f64]);
    /// Every rank's `local` (all the same length), concatenated in rank order, on every rank.
    fn all_gather_f64(&self, local: &[f64]) -> Vec<f64>;
    /// Every rank's bytes in rank order on rank 0; an empty list elsewhere.
    fn gather_bytes(&self, local: &[u8]) -> Vec<Vec<u8>>;
    /// Communication time and traffic since the last call.
    fn take_stats(&self) -> CommStats;
}

/// One process: every collective is the identity.
#[derive(Debug, Default)]
pub struct Single;

impl Comm for Single {
    fn rank(&self) -> usize {
        0
    }
    fn size(&self) -> usize {
        1
    }
    fn sum_f32(&self, _: &mut [f32]) {}
    fn sum_f64(&self, _: &mut [f64]) {}
    fn all_gather_f64(&self, local: &[f64]) -> Vec<f64> {
        local.to_vec()
    }
    fn gather_bytes(&self, local: &[u8]) -> Vec<Vec<u8>> {
        vec![local.to_vec()]
    }
    fn take_stats(&self) -> CommStats {
        CommStats::default()
    }
}

/// Accumulates `CommStats` for an implementation: wrap each collective in `record`.
#[derive(Debug, Default)]
pub struct StatsCell {
    seconds: Cell<Duration>,
    bytes: Cell<u64>,
    calls: Cell<u64>,
}

impl StatsCell {
    pub fn record<T>(&self, bytes: usize, f: impl FnOnce() -> T) -> T {
        let start = Instant::now();
        let out = f();
        self.seconds.set(self.seconds.get() + start.elapsed());
        self.bytes.set(self.bytes.get() + bytes as u64);
        self.calls.set(self.calls.get() + 1);
        out
    }

    pub fn take(&self) -> CommStats {
        CommStats { seconds: self.seconds.take().as_secs_f64(), bytes: self.bytes.take(), calls: self.calls.take() }
    }
}
