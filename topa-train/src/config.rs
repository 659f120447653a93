//! A run's config: the learner's tables and the task's `[env]` table, checked together and resolved, so that what
//! a run records is every key it ran with.

use std::path::Path;

use topa_env::EnvConfig;
use trainer::checkpoint;
use trainer::TrainConfig;

use crate::error::{Error, Result};

/// A training config file with its `[env]` table checked by the task: every problem names the file and the key.
pub fn load_config(path: &Path) -> Result<(TrainConfig, EnvConfig)> {
    let cfg = TrainConfig::load(path)?;
    let env = EnvConfig::from_table(&cfg.env)
        .map_err(|source| Error::EnvConfig { what: format!("config {}", path.display()), source })?;
    Ok((cfg, env))
}

/// The task's config of a learner's config (its `[env]` table, which the learner keeps as it was written): the
/// one place where that table is parsed.
pub fn env_config(cfg: &TrainConfig) -> Result<EnvConfig> {
    Ok(EnvConfig::from_table(&cfg.env)?)
}

/// `cfg` with its `[env]` table resolved: every key of the task's config, the defaults included, so a record of
/// the run says exactly what it ran with (and keeps saying it when a later build changes a default).
pub fn with_resolved_env(cfg: &TrainConfig) -> Result<TrainConfig> {
    Ok(with_env(cfg, &env_config(cfg)?))
}

/// `cfg` with the task's config `env` as its `[env]` table, every key written.
pub fn with_env(cfg: &TrainConfig, env: &EnvConfig) -> TrainConfig {
    TrainConfig { env: env.to_table(), ..cfg.clone() }
}

/// Observation values a run adds to the policy it starts from: a height scan turned on (its values come after the
/// paper's, so the forked policy starts blind to it and learns to use it); nothing else may change the size.
pub fn added_inputs(side: &checkpoint::Sidecar, env: &EnvConfig) -> Result<usize> {
    let source = EnvConfig::from_table(&side.config.env).map_err(|source| Error::EnvConfig {
        what: "the checkpoint's own [env] config does not parse with this build".into(),
        source,
    })?;
    let (nx, ny) = env.height_scan.grid();
    Ok(if env.height_scan.enabled && !source.height_scan.enabled { nx * ny } else { 0 })
}
