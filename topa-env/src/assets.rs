//! Where the bundled MJCF lives, and constructors for batches of TopA envs.

use std::path::PathBuf;
use std::sync::Arc;

use mujoco_sys::Model;

use crate::config::EnvConfig;
use crate::env::TopaEnv;
use crate::error::Result;
use crate::indices::RobotIndices;
use crate::robot::ModelKind;
use crate::vec_env::BatchEnv;

/// `assets/mjcf/` of this repository, or `$TOPA_ASSETS` if set (an installed copy elsewhere).
pub fn mjcf_dir() -> PathBuf {
    match std::env::var_os("TOPA_ASSETS") {
        Some(p) => PathBuf::from(p),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/mjcf"),
    }
}

pub fn model_path(kind: ModelKind) -> PathBuf {
    mjcf_dir().join(kind.file_name())
}

/// Loads the bundled closed or open TopA model.
pub fn load_model(kind: ModelKind) -> Result<Arc<Model>> {
    Ok(Arc::new(Model::from_xml_path(model_path(kind))?))
}

/// `n` TopA envs on `cfg.model`, env `i` seeded with (`seed`, stream `i`), stepped on `threads` threads
/// (0 = rayon's global pool). The model is compiled once and checked against the spec once.
pub fn topa_batch(cfg: &EnvConfig, n: usize, seed: u64, threads: usize) -> Result<BatchEnv<TopaEnv>> {
    topa_batch_on(load_model(cfg.model)?, cfg, n, seed, threads)
}

/// As `topa_batch`, on an already loaded model.
pub fn topa_batch_on(
    model: Arc<Model>,
    cfg: &EnvConfig,
    n: usize,
    seed: u64,
    threads: usize,
) -> Result<BatchEnv<TopaEnv>> {
    topa_batch_from(model, cfg, 0, n, seed, threads)
}

/// `n` envs seeded as envs `first`, `first + 1`, … of a larger batch (one MPI rank's share of a run).
pub fn topa_batch_from(
    model: Arc<Model>,
    cfg: &EnvConfig,
    first: u64,
    n: usize,
    seed: u64,
    threads: usize,
) -> Result<BatchEnv<TopaEnv>> {
    cfg.validate()?;
    // Apply the timestep and integrator once, so the envs share one model until randomisation copies it.
    let mut model = model;
    if let Some(i) = cfg.integrator() {
        Arc::make_mut(&mut model).set_integrator(i);
    }
    Arc::make_mut(&mut model).set_timestep(cfg.timestep)?;
    Arc::make_mut(&mut model).set_sensors_enabled(cfg.needs_sensors());
    let cfg = Arc::new(cfg.clone());
    let idx = Arc::new(RobotIndices::resolve(&model, cfg.model)?);
    let envs = (0..n)
        .map(|i| TopaEnv::with_indices(model.clone(), cfg.clone(), idx.clone(), seed, first + i as u64))
        .collect::<Result<Vec<_>>>()?;
    BatchEnv::new(envs, threads)
}
