//! Robustness to command variability (paper, Table "Robustness evaluation under varying commanded velocity
//! noise"): walk forward at 0.5 m/s while the command is perturbed by Gaussian noise — σ_v on v_x and v_y,
//! σ_wz on w_z — at the paper's four (σ_v, σ_wz) pairs, `runs` seeded runs each; success = no fall over the run.
//! The noise is redrawn every `interval_s` (the paper does not say how often; 0.5 s is a user changing their
//! mind twice a second) and held in between.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use topa_env::RobotEnv;
use trainer::actor_critic::standard_normal;

use super::results::NoiseRow;
use super::runner::{run_batch, Experiment};
use super::settings::EvalSettings;
use crate::error::Result;
use topa_env::policy_runner::PolicyRunner;

pub const LEVELS: [(f64, f64); 4] = [(0.175, 0.5), (0.35, 1.0), (0.525, 1.5), (0.7, 2.0)];
pub const BASE_COMMAND: [f64; 3] = [0.5, 0.0, 0.0];

/// Success rate (%) of a list of falls.
pub fn success_pct(fell: &[Option<f64>]) -> (usize, f64) {
    let ok = fell.iter().filter(|f| f.is_none()).count();
    (ok, if fell.is_empty() { f64::NAN } else { 100.0 * ok as f64 / fell.len() as f64 })
}

struct Noise {
    /// (σ_v, σ_wz) per env.
    sigma: Vec<(f64, f64)>,
    rngs: Vec<ChaCha8Rng>,
    every: usize,
}

impl Noise {
    fn draw(&mut self, env: usize) -> [f64; 3] {
        let (sv, sw) = self.sigma[env];
        let r = &mut self.rngs[env];
        let (a, b, c) = (standard_normal(r), standard_normal(r), standard_normal(r));
        [BASE_COMMAND[0] + sv * a, BASE_COMMAND[1] + sv * b, BASE_COMMAND[2] + sw * c]
    }
}

impl Experiment for Noise {
    fn setup(&mut self, env: usize, task: &mut RobotEnv) {
        let c = self.draw(env);
        task.set_command_override(Some(c));
    }
    fn control(&mut self, step: usize, env: usize, task: &mut RobotEnv) {
        if step > 0 && step.is_multiple_of(self.every) {
            let c = self.draw(env);
            task.set_command_override(Some(c));
        }
    }
}

/// The per-run noise streams: run `r` of level `l` always draws the same sequence for a given seed.
pub fn stream(seed: u64, level: usize, run: usize) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed ^ 0x006e_6f69_7365);
    r.set_stream((level * 1_000_000 + run) as u64);
    r
}

pub fn run(
    runner: &mut PolicyRunner,
    settings: &EvalSettings,
    runs: usize,
    seconds: f64,
    interval_s: f64,
) -> Result<Vec<NoiseRow>> {
    let cfg = settings.env_config(runner)?;
    let every = ((interval_s / cfg.policy_dt()).round() as usize).max(1);
    let sigma: Vec<(f64, f64)> = LEVELS.iter().flat_map(|&l| std::iter::repeat_n(l, runs)).collect();
    let rngs = (0..LEVELS.len()).flat_map(|l| (0..runs).map(move |r| stream(settings.seed, l, r))).collect();
    let mut exp = Noise { sigma, rngs, every };
    let label = format!("command noise 4 × {runs} runs ({})", runner.name);
    let fell = run_batch(runner, &cfg, settings, LEVELS.len() * runs, seconds, &mut exp, &label)?;
    Ok(LEVELS
        .iter()
        .enumerate()
        .map(|(l, &(sigma_v, sigma_wz))| {
            let (successes, success_pct) = success_pct(&fell[l * runs..(l + 1) * runs]);
            NoiseRow { sigma_v, sigma_wz, runs, successes, success_pct }
        })
        .collect())
}
