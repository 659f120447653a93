//! Constructors for batches of envs of the robot a config names (and, re-exported, where robots are found).

use std::sync::Arc;

use mujoco_sys::Model;

use crate::config::EnvConfig;
use crate::env::RobotEnv;
use crate::error::Result;
use crate::indices::RobotIndices;
use crate::spec::RobotSpec;
use crate::vec_env::BatchEnv;

pub use crate::robots::{load_model, load_robot, mjcf_dir, model_path, repo_dir, robot_path};

/// `n` envs of the robot `cfg.robot` names, env `i` seeded with (`seed`, stream `i`), stepped on `threads`
/// threads (0 = rayon's global pool). The model is compiled once and checked against the spec once.
pub fn robot_batch(cfg: &EnvConfig, n: usize, seed: u64, threads: usize) -> Result<BatchEnv<RobotEnv>> {
    let (spec, model) = load_robot(cfg)?;
    robot_batch_from(model, &spec, cfg, 0, n, seed, threads)
}

/// As `robot_batch`, on an already loaded model of the robot (e.g. a variant of its MJCF).
pub fn topa_batch_on(
    model: Arc<Model>,
    cfg: &EnvConfig,
    n: usize,
    seed: u64,
    threads: usize,
) -> Result<BatchEnv<RobotEnv>> {
    let (spec, _) = load_robot(cfg)?;
    robot_batch_from(model, &spec, cfg, 0, n, seed, threads)
}

/// `n` envs seeded as envs `first`, `first + 1`, … of a larger batch (one MPI rank's share of a run).
pub fn robot_batch_from(
    model: Arc<Model>,
    spec: &Arc<RobotSpec>,
    cfg: &EnvConfig,
    first: u64,
    n: usize,
    seed: u64,
    threads: usize,
) -> Result<BatchEnv<RobotEnv>> {
    cfg.validate()?;
    // Apply the timestep and integrator once, so the envs share one model until randomisation copies it.
    let mut model = model;
    if let Some(i) = cfg.integrator() {
        Arc::make_mut(&mut model).set_integrator(i);
    }
    if let Some(n) = cfg.solver_iterations {
        Arc::make_mut(&mut model).set_solver_iterations(n);
    }
    if let Some(t) = cfg.solver_tolerance {
        Arc::make_mut(&mut model).set_solver_tolerance(t);
    }
    Arc::make_mut(&mut model).set_timestep(cfg.timestep)?;
    Arc::make_mut(&mut model).set_sensors_enabled(cfg.needs_sensors());
    let cfg = Arc::new(cfg.clone());
    let idx = Arc::new(RobotIndices::resolve(&model, spec)?);
    let envs = (0..n)
        .map(|i| RobotEnv::with_indices(model.clone(), cfg.clone(), idx.clone(), seed, first + i as u64))
        .collect::<Result<Vec<_>>>()?;
    BatchEnv::new(envs, threads)
}
