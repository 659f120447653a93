//! Training configuration: one TOML file (`configs/paper.toml`, `configs/cpu.toml`) with the run, PPO, network,
//! robustness losses and adversary settings, and the task's own `[env]` table, which the learner keeps without
//! reading it (the task validates it). Unknown keys are rejected with the key's name.

use std::path::Path;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
    /// How long, how parallel, how often to save.
    pub run: RunConfig,
    /// The task's settings (robot, rewards, randomisation, perturbation bounds …): opaque to the learner, so it
    /// is no part of the learner's schema (the task's `EnvConfig` has its own).
    #[schemars(skip)]
    pub env: toml::Table,
    /// PPO's hyper-parameters (paper: Table "PPO Parameters").
    pub ppo: PpoConfig,
    /// The actor's and critic's networks.
    pub network: NetworkConfig,
    /// The robustness losses added to PPO's (symmetry, last-layer decay).
    pub losses: LossConfig,
    /// The cyclic adversary's schedule and learner (used with `topa train --adversary`).
    pub adversary: AdversaryConfig,
}

/// How long, how parallel, how often to save.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct RunConfig {
    /// Seed of every random stream of the run (envs, policy sampling, minibatches).
    pub seed: u64,
    /// Parallel environments (paper: 4096).
    pub num_envs: usize,
    /// Policy steps per environment per iteration (paper: 24).
    pub steps_per_env: usize,
    /// PPO iterations (phase 1 only, when the adversary schedule is off).
    pub iterations: usize,
    /// Worker threads for the environments and the networks (0 = all cores).
    pub threads: usize,
    /// Save a checkpoint every this many iterations (and at the end).
    pub checkpoint_every: usize,
    /// Keep only the newest this many checkpoints (0 = keep all).
    pub keep_checkpoints: usize,
}

impl Default for RunConfig {
    fn default() -> Self {
        RunConfig {
            seed: 1,
            num_envs: 4096,
            steps_per_env: 24,
            iterations: 1000,
            threads: 0,
            checkpoint_every: 50,
            keep_checkpoints: 3,
        }
    }
}

/// The paper's PPO table, plus rsl_rl's defaults where the paper is silent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PpoConfig {
    /// Clip range ε of the policy ratio (paper: 0.2).
    pub clip: f64,
    /// λ of generalised advantage estimation (paper: 0.95).
    pub gae_lambda: f64,
    /// Reward discount factor γ (paper: 0.99).
    pub gamma: f64,
    /// Initial learning rate of the actor-critic's Adam (paper: 3e-5).
    pub learning_rate: f64,
    /// Gradients are clipped to this global norm (paper: 0.5).
    pub max_grad_norm: f64,
    /// KL divergence per update that the adaptive learning rate aims at (paper: 0.02).
    pub desired_kl: f64,
    /// Passes over each iteration's samples (paper: 5).
    pub epochs: usize,
    /// Minibatches each pass is split into (paper: 4).
    pub minibatches: usize,
    /// Weight of the value loss (rsl_rl's default; not in the paper's table).
    pub value_loss_coef: f64,
    /// Weight of the policy's entropy bonus (rsl_rl's default; not in the paper's table); with
    /// `entropy_decay_iterations`, its weight at iteration 0.
    pub entropy_coef: f64,
    /// The entropy bonus's weight from iteration `entropy_decay_iterations` on (ours; used only with a decay).
    pub entropy_coef_end: f64,
    /// Iterations over which the entropy bonus's weight falls linearly from `entropy_coef` to `entropy_coef_end`
    /// (ours; 0: `entropy_coef` throughout, as rsl_rl). Counted from the run's first iteration, so a resumed or
    /// extended run follows the same schedule.
    pub entropy_decay_iterations: usize,
    /// Clip the value function's change like the policy ratio (rsl_rl's default; not in the paper's table).
    pub clip_value_loss: bool,
    /// Lower bound of the adaptive learning rate.
    pub lr_min: f64,
    /// Upper bound of the adaptive learning rate.
    pub lr_max: f64,
    /// Adaptive learning rate from the KL (rsl_rl "adaptive" schedule); false keeps it fixed.
    pub adaptive_lr: bool,
}

impl PpoConfig {
    /// The entropy bonus's weight at `iteration` (0-based) of the run.
    pub fn entropy_coef_at(&self, iteration: usize) -> f64 {
        if self.entropy_decay_iterations == 0 {
            return self.entropy_coef;
        }
        let f = (iteration as f64 / self.entropy_decay_iterations as f64).min(1.0);
        self.entropy_coef + f * (self.entropy_coef_end - self.entropy_coef)
    }
}

impl Default for PpoConfig {
    fn default() -> Self {
        PpoConfig {
            clip: 0.2,
            gae_lambda: 0.95,
            gamma: 0.99,
            learning_rate: 3e-5,
            max_grad_norm: 0.5,
            desired_kl: 0.02,
            epochs: 5,
            minibatches: 4,
            value_loss_coef: 1.0,
            entropy_coef: 0.01,
            entropy_coef_end: 0.0,
            entropy_decay_iterations: 0,
            clip_value_loss: true,
            lr_min: 1e-5,
            lr_max: 1e-2,
            adaptive_lr: true,
        }
    }
}

/// The actor's and critic's networks (paper: Table "PPO Parameters").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct NetworkConfig {
    /// Widths of the actor's hidden layers (paper: [512, 256, 128]).
    pub actor_hidden: Vec<usize>,
    /// Widths of the critic's hidden layers (paper: [512, 256, 128]).
    pub critic_hidden: Vec<usize>,
    /// The hidden layers' activation (the paper's ELU; the only one the fused kernels implement).
    pub activation: HiddenActivation,
    /// Initial standard deviation of the Gaussian policy (rsl_rl: 1.0).
    pub init_noise_std: f64,
    /// Widths of the concurrent estimator's hidden layers (used when the task's observation has estimated values,
    /// e.g. `[env.observation] base_velocity = "estimated"`; Ji et al. 2022: [256, 128]).
    pub estimator_hidden: Vec<usize>,
    /// The estimator's Adam learning rate (fixed: the policy's adaptive rate follows the policy's KL).
    pub estimator_learning_rate: f64,
}

impl Default for NetworkConfig {
    fn default() -> Self {
        NetworkConfig {
            actor_hidden: vec![512, 256, 128],
            critic_hidden: vec![512, 256, 128],
            activation: HiddenActivation::Elu,
            init_noise_std: 1.0,
            estimator_hidden: vec![256, 128],
            estimator_learning_rate: 1e-3,
        }
    }
}

/// Activation of the hidden layers, as configs and policy files name it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum HiddenActivation {
    #[default]
    Elu,
}

/// The paper's robustness terms (their coefficients are not published; ours are documented here).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct LossConfig {
    /// Weight of L_symmetry = MSE(S_a(π(o)), π(S_o(o))) (paper: added with weight 1).
    pub symmetry_coef: f64,
    /// λ of L_decay = λ‖θ_last‖² on the actor's output layer (weights and bias).
    pub decay_coef: f64,
    /// Symmetry by data: each PPO minibatch is learned from together with its mirror image (S_o(o), S_a(a), the
    /// same advantage, return and old log-probability), as rsl_rl's `use_data_augmentation`; L_symmetry is then
    /// taken on the two halves. Not in the paper (off): it doubles the update's batch.
    pub symmetry_augmentation: bool,
}

impl Default for LossConfig {
    fn default() -> Self {
        LossConfig { symmetry_coef: 1.0, decay_coef: 1e-3, symmetry_augmentation: false }
    }
}

/// The cyclic adversary (paper: C+A). Off unless `topa train --adversary`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct AdversaryConfig {
    /// Phase 1: iterations of the policy alone before the first cycle (paper: 1000).
    pub phase1_policy_iters: usize,
    /// Phase 2 of each cycle: iterations of the adversary against the frozen policy (paper: 200).
    pub phase2_adversary_iters: usize,
    /// Phase 3 of each cycle: iterations of the policy against the frozen adversary (paper: 200).
    pub phase3_policy_iters: usize,
    /// Cycles of phases 2 and 3 (paper: 5).
    pub cycles: usize,
    /// Widths of the adversary's hidden layers, actor and critic alike (paper: [512, 256, 128]).
    pub hidden: Vec<usize>,
    /// Cost on perturbation magnitude in the adversary's reward (0 = pure −task reward). What it perturbs and
    /// how far is the task's (its perturbation channels and their bounds).
    pub magnitude_cost: f64,
    /// Adversary PPO learning rate (its own optimizer).
    pub learning_rate: f64,
    /// Adversary entropy bonus. Its outputs are tanh-bounded, so a bonus on the Gaussian's entropy has no limit
    /// and inflates the std until every perturbation is a random ±bound (measured: entropy 19 → 40 in 5 cycles).
    pub entropy_coef: f64,
    /// In phase 3 the frozen adversary samples its actions (true) or applies its mean perturbation (false).
    pub sample_when_frozen: bool,
    /// Share of the envs the frozen adversary perturbs in phase 3 (the first ⌈share·N⌉); the rest run
    /// unperturbed, so the policy keeps seeing the undisturbed robot it will meet in evaluation.
    pub attack_share: f64,
    /// The locomotion policy's entropy bonus in phase 3, in place of `ppo`'s schedule (ours; rsl_rl's 0.01 by
    /// default): a schedule that decays to none by the end of phase 1 would leave the policy's exploration
    /// shrinking through every cycle against the adversary.
    pub policy_entropy_coef: f64,
    /// Every other env (the odd ones) is attacked through the mirror: the adversary sees the mirror image of
    /// its observation and the env gets the mirror image of its perturbation (ours), so the attacks a policy
    /// meets are left↔right symmetric while the adversary keeps one consistent view of the world.
    pub mirror_attacks: bool,
    /// Symmetry by data (as `losses.symmetry_augmentation`) in phase 3 only, where the policy learns under
    /// attack (ours): the attacks let the policy's left↔right asymmetry through (its turns in place failed one
    /// way), and a C+A forked from a C keeps the C's arithmetic. Either key on augments phase 3.
    pub policy_symmetry_augmentation: bool,
}

impl AdversaryConfig {
    /// The schedule these settings describe: phase 1, then the cycles of phases 2 and 3.
    pub fn schedule(&self) -> crate::schedule::Schedule {
        crate::schedule::Schedule::cyclic(
            self.phase1_policy_iters,
            self.phase2_adversary_iters,
            self.phase3_policy_iters,
            self.cycles,
        )
    }
}

impl Default for AdversaryConfig {
    fn default() -> Self {
        AdversaryConfig {
            phase1_policy_iters: 1000,
            phase2_adversary_iters: 200,
            phase3_policy_iters: 200,
            cycles: 5,
            hidden: vec![512, 256, 128],
            magnitude_cost: 0.0,
            learning_rate: 3e-5,
            entropy_coef: 0.0,
            sample_when_frozen: true,
            attack_share: 1.0,
            policy_entropy_coef: 0.01,
            mirror_attacks: false,
            policy_symmetry_augmentation: false,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("cannot read config {path}")]
    Io { path: String, source: std::io::Error },
    #[error("config {path}: {message}")]
    Parse { path: String, message: String },
    #[error("config {path}: {message}")]
    Invalid { path: String, message: String },
    /// A setting out of its range (the message names the key); `load` adds the file.
    #[error("{0}")]
    Setting(String),
    /// A config saved in a checkpoint or policy sidecar that does not parse.
    #[error("{0}")]
    Saved(String),
}

impl TrainConfig {
    /// Reads and validates a TOML config; every problem names the key and the file.
    ///
    /// A file may start from another: `base = "cpu.toml"` (relative to the file) loads that one first and applies
    /// this file's keys on top, table by table, so an experiment config holds only what it changes.
    pub fn load(path: &Path) -> Result<TrainConfig, ConfigError> {
        let p = path.display().to_string();
        let table = load_table(path, 0)?;
        let cfg: TrainConfig = toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| ConfigError::Parse { path: p.clone(), message: toml_message(&e) })?;
        cfg.validate().map_err(|e| ConfigError::Invalid { path: p, message: e.to_string() })?;
        Ok(cfg)
    }

    /// A config saved in a checkpoint or policy sidecar (JSON).
    pub fn from_json(v: &serde_json::Value) -> Result<TrainConfig, ConfigError> {
        let table: toml::Table = serde_json::from_value(v.clone()).map_err(|e| ConfigError::Saved(e.to_string()))?;
        toml::Value::Table(table).try_into().map_err(|e: toml::de::Error| ConfigError::Saved(toml_message(&e)))
    }

    /// The learner's own keys (the task checks `env`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let r = &self.run;
        if r.num_envs == 0 || r.steps_per_env == 0 {
            return Err(ConfigError::Setting("run.num_envs and run.steps_per_env must be at least 1".into()));
        }
        if r.checkpoint_every == 0 {
            return Err(ConfigError::Setting("run.checkpoint_every must be at least 1".into()));
        }
        let p = &self.ppo;
        if p.epochs == 0 || p.minibatches == 0 {
            return Err(ConfigError::Setting("ppo.epochs and ppo.minibatches must be at least 1".into()));
        }
        if p.minibatches > r.num_envs * r.steps_per_env {
            return Err(ConfigError::Setting("ppo.minibatches exceeds the number of samples per iteration".into()));
        }
        for (k, v) in [("ppo.gamma", p.gamma), ("ppo.gae_lambda", p.gae_lambda)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(ConfigError::Setting(format!("{k} must be in [0, 1], got {v}")));
            }
        }
        for (k, v) in [
            ("ppo.clip", p.clip),
            ("ppo.learning_rate", p.learning_rate),
            ("ppo.max_grad_norm", p.max_grad_norm),
            ("ppo.desired_kl", p.desired_kl),
            ("network.init_noise_std", self.network.init_noise_std),
            ("network.estimator_learning_rate", self.network.estimator_learning_rate),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ConfigError::Setting(format!("{k} must be positive, got {v}")));
            }
        }
        if self.network.actor_hidden.is_empty() || self.network.critic_hidden.is_empty() {
            return Err(ConfigError::Setting("network hidden layer lists must not be empty".into()));
        }
        let a = &self.adversary;
        if !(0.0..=1.0).contains(&a.attack_share) {
            return Err(ConfigError::Setting(format!(
                "adversary.attack_share must be in [0, 1], got {}",
                a.attack_share
            )));
        }
        for (k, v) in [
            ("ppo.entropy_coef", p.entropy_coef),
            ("ppo.entropy_coef_end", p.entropy_coef_end),
            ("adversary.entropy_coef", a.entropy_coef),
            ("adversary.policy_entropy_coef", a.policy_entropy_coef),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ConfigError::Setting(format!("{k} must be ≥ 0, got {v}")));
            }
        }
        if self.losses.symmetry_coef < 0.0 || self.losses.decay_coef < 0.0 {
            return Err(ConfigError::Setting("losses.symmetry_coef and losses.decay_coef must be ≥ 0".into()));
        }
        Ok(())
    }
}

/// toml's message as toml lays it out (excerpt and caret on their own lines), without its trailing newline.
fn toml_message(e: &toml::de::Error) -> String {
    e.to_string().trim_end().to_string()
}

/// A config file's table with its `base` chain merged in (at most 8 levels, so a cycle is an error).
pub fn load_table(path: &Path, depth: usize) -> Result<toml::Table, ConfigError> {
    let p = path.display().to_string();
    if depth > 8 {
        return Err(ConfigError::Invalid { path: p, message: "`base` chain deeper than 8 files (a cycle?)".into() });
    }
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io { path: p.clone(), source })?;
    let mut table: toml::Table =
        toml::from_str(&text).map_err(|e| ConfigError::Parse { path: p.clone(), message: toml_message(&e) })?;
    let Some(base) = table.remove("base") else { return Ok(table) };
    let Some(base) = base.as_str() else {
        return Err(ConfigError::Invalid { path: p, message: "`base` must be a file name (a string)".into() });
    };
    let base_path = path.parent().unwrap_or(Path::new(".")).join(base);
    let mut merged = load_table(&base_path, depth + 1)?;
    merge(&mut merged, table);
    Ok(merged)
}

/// Applies `over` on top of `base`: tables merge key by key, anything else replaces.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sidecar_config_reads_back_and_unknown_keys_are_named() {
        let c = TrainConfig::from_json(&serde_json::json!({
            "run": {"seed": 4},
            "adversary": {"cycles": 2},
            "env": {"timestep": 0.004},
        }))
        .unwrap();
        assert_eq!((c.run.seed, c.adversary.cycles), (4, 2));
        assert_eq!(c.env["timestep"].as_float(), Some(0.004));
        // Settings that belong to the task are refused in the learner's tables, by name.
        let bad = serde_json::json!({"adversary": {"task_bound": 12.0}});
        assert!(TrainConfig::from_json(&bad).unwrap_err().to_string().contains("task_bound"));
        let bad = serde_json::json!({"adversary": {"cylces": 2}});
        assert!(TrainConfig::from_json(&bad).unwrap_err().to_string().contains("cylces"));
    }
}
