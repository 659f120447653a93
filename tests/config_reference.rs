//! The configuration reference: docs/configuration.md is the generator's output, every key is described, and
//! the reference lists exactly the keys a resolved config has; `topa config show` output loads back unchanged.

use std::collections::BTreeSet;
use std::path::Path;

use topa_tools::config_reference::{leaf_keys, reference, resolved_table, sections, show};
use topa_train::{load_config, with_resolved_env};

const PAPER: &str = "configs/paper.toml";

#[test]
fn docs_configuration_md_is_the_generated_reference() {
    let generated = reference(Path::new(PAPER)).unwrap();
    let committed = std::fs::read_to_string("docs/configuration.md").unwrap_or_default();
    assert!(
        committed == generated,
        "docs/configuration.md is not the reference the config types give: run \
         `topa config reference > docs/configuration.md` (first difference at line {})",
        committed.lines().zip(generated.lines()).take_while(|(a, b)| a == b).count() + 1
    );
}

#[test]
fn every_key_has_a_type_a_default_and_a_description() {
    let missing: Vec<String> = sections(Path::new(PAPER))
        .unwrap()
        .iter()
        .flat_map(|s| s.rows.iter().map(move |r| (s, r)))
        .filter(|(_, r)| r.description.trim().is_empty() || r.ty.is_empty() || r.default.is_empty())
        .map(|(s, r)| format!("{}.{}", s.table, r.key))
        .collect();
    assert!(missing.is_empty(), "keys without a doc comment (or type, default) in the config types: {missing:?}");
}

#[test]
fn the_reference_lists_exactly_the_keys_of_a_resolved_preset() {
    let (cfg, env) = load_config(Path::new("configs/cpu.toml")).unwrap();
    let resolved = leaf_keys(&resolved_table(&cfg, &env).unwrap());
    let all = sections(Path::new(PAPER)).unwrap();
    let listed: BTreeSet<String> = all.iter().flat_map(|s| s.resolved_keys()).collect();
    let unlisted: Vec<_> = resolved.difference(&listed).collect();
    assert!(unlisted.is_empty(), "keys configs/cpu.toml resolves to that the reference leaves out: {unlisted:?}");
    let invented: Vec<_> = listed.difference(&resolved).collect();
    assert!(invented.is_empty(), "keys in the reference that no config has: {invented:?}");
    // A key the preset writes is one of them (the learner's and the task's alike).
    for key in ["run.num_envs", "env.integrator", "env.rewards.sigma_yaw", "env.sim2sim.estimator.q_foot"] {
        assert!(listed.contains(key), "{key} missing from the reference");
    }
    // Optional keys (no value unless a config sets one) are listed too.
    let optional: Vec<String> = all.iter().flat_map(|s| s.dotted_keys()).filter(|k| !listed.contains(k)).collect();
    let physics = ["cone", "contact_solimp", "contact_solref", "foot_shape", "impratio", "solver"];
    let expected: Vec<String> = ["env.solver_iterations".to_string(), "env.solver_tolerance".to_string()]
        .into_iter()
        .chain(physics.iter().map(|k| format!("env.physics.{k}")))
        .collect();
    assert_eq!(optional, expected);
}

#[test]
fn the_paper_column_holds_what_the_paper_preset_sets() {
    let all = sections(Path::new(PAPER)).unwrap();
    let row = |table: &str, key: &str| {
        all.iter().find(|s| s.table == table).and_then(|s| s.rows.iter().find(|r| r.key == key)).unwrap().clone()
    };
    // Set in configs/paper.toml to a value other than the default.
    assert_eq!(row("run", "iterations").paper, "`3000`");
    // Set to the default: shown all the same (the preset confirms it).
    assert_eq!(row("ppo", "clip").paper, "`0.2`");
    // Not set and at the default: empty.
    assert_eq!(row("env.rewards", "sigma_v").paper, "");
    assert_eq!(row("env.sim2sim", "timestep").paper, "");
}

#[test]
fn a_shown_config_loads_back_to_the_same_config() {
    let dir = std::env::temp_dir().join(format!("topa-config-show-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // An experiment on top of a preset, as configs/experiments/ holds them: the base chain must be merged in.
    let cpu = std::fs::canonicalize("configs/cpu.toml").unwrap();
    let experiment = dir.join("experiment.toml");
    let text = format!("base = {:?}\n[env.rewards]\nsigma_yaw = 0.2\n[run]\nseed = 7\n", cpu.display().to_string());
    std::fs::write(&experiment, text).unwrap();
    let experiment = experiment.display().to_string();
    for preset in ["configs/cpu.toml", "configs/paper.toml", experiment.as_str()] {
        let text = show(Path::new(preset)).unwrap();
        let path = dir.join("shown.toml");
        std::fs::write(&path, &text).unwrap();
        let (cfg, env) = load_config(&path).unwrap();
        let (want_cfg, want_env) = load_config(Path::new(preset)).unwrap();
        assert_eq!(env, want_env, "{preset}: [env] differs after `config show`");
        assert_eq!(with_resolved_env(&cfg).unwrap(), with_resolved_env(&want_cfg).unwrap(), "{preset}");
        if preset == experiment {
            assert_eq!((cfg.run.seed, env.rewards.sigma_yaw, cfg.run.num_envs), (7, 0.2, want_cfg.run.num_envs));
        }
        // Every key is written out, the defaults included.
        let written: toml::Table = toml::from_str(&text).unwrap();
        assert_eq!(leaf_keys(&written), leaf_keys(&resolved_table(&cfg, &env).unwrap()), "{preset}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
