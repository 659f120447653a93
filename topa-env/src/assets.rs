//! Where robots are found: the repository's `assets/` (or an installed copy named by `$TOPA_ASSETS`), a config's
//! robot spec by path, TopA's bundled MJCF by model.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use mujoco::Model;

use crate::config::EnvConfig;
use crate::error::Result;
use crate::spec::RobotSpec;
use crate::topa::ModelKind;

/// The repository root (where `assets/` lives), or `$TOPA_ASSETS/..` if set (an installed copy elsewhere).
pub fn repo_dir() -> PathBuf {
    match std::env::var_os("TOPA_ASSETS") {
        Some(p) => PathBuf::from(p).join(".."),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).parent().map_or_else(|| PathBuf::from(".."), Path::to_path_buf),
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

/// Where a file a config or a command names is (a robot spec, a course, a log): an absolute path, a path from the
/// working folder, or from the repository root.
pub fn resolve_path(file: &str) -> PathBuf {
    let p = Path::new(file);
    if p.is_absolute() || p.exists() {
        p.to_path_buf()
    } else {
        repo_dir().join(p)
    }
}

/// The robot a config names: its spec, checked against its compiled MJCF; on the config's terrain when it has one.
pub fn load_robot(cfg: &EnvConfig) -> Result<(Arc<RobotSpec>, Arc<Model>)> {
    let (spec, model) = RobotSpec::load(&resolve_path(&cfg.robot))?;
    if cfg.terrain.enabled {
        let (model, _) = crate::terrain::Terrain::shared(&cfg.terrain)?.compile(&spec)?;
        return Ok((Arc::new(spec), model));
    }
    Ok((Arc::new(spec), Arc::new(model)))
}
