//! The processes of a run: MPI's ranks when launched by `mpirun`/`srun` with the `mpi` feature, else one; each
//! rank's share of the envs, and the check that every rank holds the same weights.

use std::rc::Rc;

use topa_env::EnvConfig;
use trainer::comm::{Comm, Single};
use trainer::{TrainConfig, Trainer, VecEnv};

use crate::error::{Error, Result};

/// The ranks of this run: MPI's when launched by `mpirun`/`srun` with the `mpi` feature, else one process.
pub fn ranks() -> Result<Rc<dyn Comm>> {
    let launched = ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_STEP_NUM_TASKS"]
        .iter()
        .find_map(|k| std::env::var(k).ok()?.parse::<usize>().ok())
        .filter(|&n| n > 1);
    match launched {
        None => Ok(Rc::new(Single)),
        #[cfg(feature = "mpi")]
        Some(_) => Ok(Rc::new(crate::mpi_comm::MpiComm::init()?)),
        #[cfg(not(feature = "mpi"))]
        Some(n) => Err(Error::Ranks(format!(
            "started as one of {n} MPI ranks, but this topa was built without MPI: build it with \
             `cargo build --release --features mpi` (scripts/setup.sh installs Open MPI when TOPA_MPI=1)"
        ))),
    }
}

/// This rank's share of the run's envs: `run.num_envs / ranks` of them, env `i` seeded as env
/// `rank · share + i` of a one-process run, so a seed names the same env streams whatever the rank layout.
pub fn rank_env(cfg: &TrainConfig, env: &EnvConfig, comm: &dyn Comm) -> Result<Box<dyn VecEnv>> {
    let (size, rank) = (comm.size(), comm.rank());
    let n = cfg.run.num_envs;
    if !n.is_multiple_of(size) {
        return Err(Error::Ranks(format!(
            "run.num_envs = {n} does not split over {size} MPI ranks: choose a multiple of {size}"
        )));
    }
    let share = n / size;
    Ok(topa_env::vec_env::task_batch(env, (rank * share) as u64, share, cfg.run.seed, 0)?)
}

/// Checks that every MPI rank holds the same policy weights (they should, bit for bit): rank 0 errors otherwise.
/// Returns this rank's digest.
pub fn check_ranks_agree(t: &Trainer) -> Result<u32> {
    let mut bytes = Vec::new();
    for v in t.policy.ac.vars() {
        for x in v.as_tensor().flatten_all()?.to_vec1::<f32>()? {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
    }
    let crc = trainer::tensorfile::checksum(&bytes);
    let all = t.comm.gather_bytes(&crc.to_le_bytes());
    if t.comm.rank() == 0 && all.iter().any(|b| b[..] != crc.to_le_bytes()) {
        return Err(Error::Ranks(format!(
            "the MPI ranks' policy weights differ at iteration {} (a bug: please report it)",
            t.iteration
        )));
    }
    Ok(crc)
}
