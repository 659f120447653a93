//! A run's records (policy sidecar, checkpoint sidecar, config.toml) hold the full resolved config: every key of
//! the task's `EnvConfig`, the defaults included, even when the preset names only a few.

use std::path::{Path, PathBuf};

mod common;

use topa_env::{EnvConfig, TaskKind};
use topa_tools::config_reference::leaf_keys;
use trainer::TrainConfig;

/// A two-iteration cart-pole run whose `[env]` says only which task (and one σ, after `common::TINY_CARTPOLE`):
/// everything else is left to the defaults.
const RUN: &str = r#"
[run]
num_envs = 8
steps_per_env = 16
iterations = 2
threads = 1
checkpoint_every = 1
"#;
const SIGMA: &str = "\n[env.rewards]\nsigma_yaw = 0.3\n";

fn env_of_json(path: &Path, pointer: &str) -> toml::Table {
    let text = std::fs::read_to_string(path).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let config = v.pointer(pointer).unwrap_or_else(|| panic!("{}: no {pointer}", path.display()));
    TrainConfig::from_json(config).unwrap().env
}

fn assert_full(what: &str, env: &toml::Table) {
    let want = leaf_keys(&EnvConfig::default().to_table());
    let have = leaf_keys(env);
    let missing: Vec<_> = want.difference(&have).collect();
    assert!(missing.is_empty(), "{what}: env keys missing: {missing:?}");
    // The values are the run's: its own keys and the defaults of the rest.
    let e = EnvConfig::from_table(env).unwrap();
    let mut expected = EnvConfig { task: TaskKind::Cartpole, ..Default::default() };
    expected.rewards.sigma_yaw = 0.3;
    assert_eq!(e, expected, "{what}");
}

#[test]
fn a_freshly_trained_policy_records_every_env_key() {
    let dir: PathBuf = std::env::temp_dir().join(format!("topa-sidecar-config-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let config = dir.join("sparse.toml");
    std::fs::write(&config, format!("{RUN}{}{SIGMA}", common::TINY_CARTPOLE)).unwrap();
    let out = dir.join("run");
    common::cli_train(Some(&config), &out, false, None);

    assert_full("policy.json provenance", &env_of_json(&out.join("policy.json"), "/provenance/config"));
    let sidecar = trainer::checkpoint::latest(&out.join("checkpoints")).unwrap();
    assert_full("checkpoint sidecar", &env_of_json(&sidecar, "/config"));
    let written = TrainConfig::load(&out.join("config.toml")).unwrap();
    assert_full("config.toml", &written.env);
    std::fs::remove_dir_all(&dir).ok();
}
