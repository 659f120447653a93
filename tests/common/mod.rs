//! The cart-pole set-up shared by the PPO and adversary tests: small networks and batches so a run takes seconds.
// Each test binary uses its own part of these helpers.
#![allow(dead_code)]

pub mod view;

use topa_env::tasks::{cartpole, CartPole};
use topa_env::{BatchEnv, EnvConfig, TaskKind};
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
    let model = cartpole::model().unwrap();
    let bound = EnvConfig::from_table(&cfg.env).unwrap().adversary.generic_bound;
    let tasks = (0..cfg.run.num_envs)
        .map(|i| CartPole::new(model.clone(), cfg.run.seed, i as u64, 200, bound).unwrap())
        .collect();
    Trainer::new(cfg.clone(), Box::new(BatchEnv::new(tasks, 1).unwrap()), with_adversary).unwrap()
}

/// `topa train` as the CLI runs it: a new run from `config` into `out`, or (`resume`) the run in `out` continued.
pub fn cli_train(config: Option<&std::path::Path>, out: &std::path::Path, resume: bool, iterations: Option<usize>) {
    topa::train_cmd::run(topa::train_cmd::TrainArgs {
        config: config.map(std::path::Path::to_path_buf),
        model: None,
        robot: None,
        seed: None,
        out: (!resume).then(|| out.to_path_buf()),
        adversary: false,
        threads: None,
        iterations,
        resume: resume.then(|| out.to_path_buf()),
        init_from: None,
        quiet: true,
    })
    .unwrap();
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
