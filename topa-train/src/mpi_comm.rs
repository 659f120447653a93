//! The learner's `Comm` over MPI (the `mpi` feature): `mpirun -np N topa train …` spreads one run over N ranks.
//! Sums are reduced on rank 0 and broadcast, so every rank gets the same bits whatever MPI's allreduce algorithm
//! would do; gathers move data without arithmetic.

use mpi::collective::SystemOperation;
use mpi::datatype::PartitionMut;
use mpi::environment::Universe;
use mpi::topology::{Communicator, SimpleCommunicator};
use mpi::traits::{CommunicatorCollectives, Equivalence, Root};
use mpi::Count;
use trainer::comm::{Comm, CommStats, StatsCell};

pub struct MpiComm {
    // Dropping the universe finalises MPI: it lives as long as the communicator.
    _universe: Universe,
    world: SimpleCommunicator,
    stats: StatsCell,
}

impl MpiComm {
    /// Initialises MPI (threads other than the main one never call it: rayon's workers only step envs).
    pub fn init() -> crate::error::Result<MpiComm> {
        let (universe, _) = mpi::initialize_with_threading(mpi::Threading::Funneled)
            .ok_or_else(|| crate::error::Error::Ranks("MPI was already initialised in this process".into()))?;
        let world = universe.world();
        Ok(MpiComm { _universe: universe, world, stats: StatsCell::default() })
    }

    fn sum<T: Equivalence + Copy + Default>(&self, buf: &mut [T]) {
        let root = self.world.process_at_rank(0);
        // A reduce sends the buffer up and a broadcast sends it back down: two buffers of traffic per rank.
        self.stats.record(2 * std::mem::size_of_val(buf), || {
            if self.world.rank() == 0 {
                let mut out = vec![T::default(); buf.len()];
                root.reduce_into_root(&*buf, &mut out[..], SystemOperation::sum());
                buf.copy_from_slice(&out);
            } else {
                root.reduce_into(&*buf, SystemOperation::sum());
            }
            root.broadcast_into(buf);
        })
    }
}

impl Comm for MpiComm {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    fn size(&self) -> usize {
        self.world.size() as usize
    }

    fn sum_f32(&self, buf: &mut [f32]) {
        self.sum(buf)
    }

    fn sum_f64(&self, buf: &mut [f64]) {
        self.sum(buf)
    }

    fn all_gather_f64(&self, local: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; local.len() * self.size()];
        self.stats.record(8 * (local.len() + out.len()), || self.world.all_gather_into(local, &mut out[..]));
        out
    }

    fn gather_bytes(&self, local: &[u8]) -> Vec<Vec<u8>> {
        let root = self.world.process_at_rank(0);
        let size = self.size();
        let len = local.len() as Count;
        self.stats.record(local.len(), || {
            if self.rank() != 0 {
                root.gather_into(&len);
                root.gather_varcount_into(local);
                return Vec::new();
            }
            let mut counts = vec![0 as Count; size];
            root.gather_into_root(&len, &mut counts[..]);
            let displs: Vec<Count> = counts.iter().scan(0, |at, &c| Some(std::mem::replace(at, *at + c))).collect();
            let mut all = vec![0u8; counts.iter().map(|&c| c as usize).sum()];
            let mut part = PartitionMut::new(&mut all[..], counts.clone(), &displs[..]);
            root.gather_varcount_into_root(local, &mut part);
            counts.iter().zip(&displs).map(|(&c, &d)| all[d as usize..(d + c) as usize].to_vec()).collect()
        })
    }

    fn take_stats(&self) -> CommStats {
        self.stats.take()
    }
}
