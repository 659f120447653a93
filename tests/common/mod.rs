//! The cart-pole set-up shared by the PPO and adversary tests: small networks and batches so a run takes seconds.
// Each test binary uses its own part of these helpers.
#![allow(dead_code)]

pub mod view;

use topa_env::{EnvConfig, TaskKind};
use trainer::config::TrainConfig;
use trainer::Trainer;

pub fn cartpole_config(seed: u64, iterations: usize) -> TrainConfig {
    let mut c = TrainConfig::default();
    c.run.seed = seed;
    c.run.num_envs = 16;
    c.run.steps_per_env = 64;
    c.run.iterations = iterations;
    c.run.threads = 1;
    c.ppo.learning_rate = 1e-3;
    c.ppo.desired_kl = 0.01;
    c.ppo.entropy_coef = 0.0;
    c.network.actor_hidden = vec![32, 32];
    c.network.critic_hidden = vec![32, 32];
    c.losses.decay_coef = 0.0;
    c.env = EnvConfig { task: TaskKind::Cartpole, ..EnvConfig::default() }.to_table();
    c
}

/// Sets the bound of the adversary's push on the pole, N.
pub fn set_push_bound(cfg: &mut TrainConfig, newtons: f64) {
    let mut env = EnvConfig::from_table(&cfg.env).unwrap();
    env.adversary.generic_bound = newtons;
    cfg.env = env.to_table();
}

pub fn cartpole_trainer(cfg: &TrainConfig, with_adversary: bool) -> Trainer {
    let env = EnvConfig::from_table(&cfg.env).unwrap();
    let envs = topa_env::vec_env::task_batch(&env, 0, cfg.run.num_envs, cfg.run.seed, 1).unwrap();
    Trainer::new(cfg.clone(), envs, with_adversary).unwrap()
}

/// A training run as `topa train` opens it: a new run from `config` into `out`, or (`resume`) the run in `out` continued.
pub fn cli_train(config: Option<&std::path::Path>, out: &std::path::Path, resume: bool, iterations: Option<usize>) {
    let start = topa_train::Start {
        config: config.map(std::path::Path::to_path_buf),
        out: (!resume).then(|| out.to_path_buf()),
        iterations,
        resume: resume.then(|| out.to_path_buf()),
        command: "topa train (test)".into(),
        ..Default::default()
    };
    topa_train::Run::open(&start).unwrap().train(|_| {}).unwrap();
}

/// A 12-iteration run that keeps a checkpoint every 5 iterations, all of them (a config file's `[run]` table).
pub const KEEP_ALL_RUN: &str = r#"
[run]
num_envs = 8
steps_per_env = 16
iterations = 12
threads = 1
checkpoint_every = 5
keep_checkpoints = 0
"#;

/// A cart-pole run small enough for seconds, as a config file's text (`[run]` left to the caller's additions).
pub const TINY_CARTPOLE: &str = r#"
[ppo]
minibatches = 2

[network]
actor_hidden = [8]
critic_hidden = [8]

[env]
task = "cartpole"
"#;
