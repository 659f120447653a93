//! Where the bundled robots live, and constructors for batches of envs of the robot a config names.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use mujoco_sys::Model;

use crate::config::EnvConfig;
use crate::env::TopaEnv;
use crate::error::Result;
use crate::indices::RobotIndices;
use crate::robot::ModelKind;
use crate::spec::RobotSpec;
use crate::vec_env::BatchEnv;

/// The repository root (where `assets/` lives), or `$TOPA_ASSETS/..` if set (an installed copy elsewhere).
pub fn repo_dir() -> PathBuf {
    match std::env::var_os("TOPA_ASSETS") {
        Some(p) => PathBuf::from(p).join(".."),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(".."),
    }
}

/// `assets/mjcf/` of this repository, or `$TOPA_ASSETS` if set.
pub fn mjcf_dir() -> PathBuf {
    match std::env::var_os("TOPA_ASSETS") {
        Some(p) => PathBuf::from(p),
        None => repo_dir().join("assets/mjcf"),
    }
}

pub fn model_path(kind: ModelKind) -> PathBuf {
    mjcf_dir().join(kind.file_name())
}

/// Loads the bundled closed or open TopA model.
pub fn load_model(kind: ModelKind) -> Result<Arc<Model>> {
    Ok(Arc::new(Model::from_xml_path(model_path(kind))?))
}

/// Where a config's robot spec is: an absolute path, a path from the working folder, or from the repository root.
pub fn robot_path(robot: &str) -> PathBuf {
    let p = Path::new(robot);
    if p.is_absolute() || p.exists() {
        p.to_path_buf()
    } else {
        repo_dir().join(p)
    }
}

/// The robot a config names: its spec, checked against its compiled MJCF.
pub fn load_robot(cfg: &EnvConfig) -> Result<(Arc<RobotSpec>, Arc<Model>)> {
    let (spec, model) = RobotSpec::load(&robot_path(&cfg.robot))?;
    Ok((Arc::new(spec), Arc::new(model)))
}

/// `n` envs of the robot `cfg.robot` names, env `i` seeded with (`seed`, stream `i`), stepped on `threads`
/// threads (0 = rayon's global pool). The model is compiled once and checked against the spec once.
pub fn topa_batch(cfg: &EnvConfig, n: usize, seed: u64, threads: usize) -> Result<BatchEnv<TopaEnv>> {
    let (spec, model) = load_robot(cfg)?;
    topa_batch_from(model, &spec, cfg, 0, n, seed, threads)
}

/// As `topa_batch`, on an already loaded model of the robot (e.g. a variant of its MJCF).
pub fn topa_batch_on(
    model: Arc<Model>,
    cfg: &EnvConfig,
    n: usize,
    seed: u64,
    threads: usize,
) -> Result<BatchEnv<TopaEnv>> {
    let (spec, _) = load_robot(cfg)?;
    topa_batch_from(model, &spec, cfg, 0, n, seed, threads)
}

/// `n` envs seeded as envs `first`, `first + 1`, … of a larger batch (one MPI rank's share of a run).
pub fn topa_batch_from(
    model: Arc<Model>,
    spec: &Arc<RobotSpec>,
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
    let idx = Arc::new(RobotIndices::resolve(&model, spec)?);
    let envs = (0..n)
        .map(|i| TopaEnv::with_indices(model.clone(), cfg.clone(), idx.clone(), seed, first + i as u64))
        .collect::<Result<Vec<_>>>()?;
    BatchEnv::new(envs, threads)
}
