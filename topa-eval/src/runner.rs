//! Runs a batch of closed-model episodes under one policy: a settle period on a zero command, then a window in
//! which each env gets its own set-up (command, torso force) and per-step control, with the first fall of each
//! env recorded. The batch is stepped on all cores; the policy acts on all envs at once.

use indicatif::{ProgressBar, ProgressStyle};
use topa_env::{EnvConfig, RobotEnv, VecEnv};

use super::settings::EvalSettings;
use crate::error::Result;
use topa_env::policy_runner::PolicyRunner;

/// Per-env hooks of an experiment.
pub trait Experiment {
    /// Called once per env before the batch's first reset (e.g. to put it on a terrain tile).
    fn prepare(&mut self, _env: usize, _task: &mut RobotEnv) -> Result<()> {
        Ok(())
    }
    /// Called once per env when the window starts (after settling).
    fn setup(&mut self, env: usize, task: &mut RobotEnv);
    /// Called before every policy step of the window (`step` counts from 0) for envs still standing.
    fn control(&mut self, _step: usize, _env: usize, _task: &mut RobotEnv) {}
    /// Called after every policy step of the window, with the time since the window started: for envs still
    /// standing, or for every env (`fallen` says which) when the experiment continues after falls.
    fn observe(&mut self, _env: usize, _t: f64, _task: &RobotEnv, _fallen: bool) {}
    /// Keep measuring a robot that fell (its config must not end episodes on a fall) instead of dropping it.
    fn continue_after_fall(&self) -> bool {
        false
    }
}

/// Time of each env's first fall since the window started (0 for a fall while settling), None if it never fell.
pub fn run_batch(
    runner: &mut PolicyRunner,
    cfg: &EnvConfig,
    settings: &EvalSettings,
    n: usize,
    window_s: f64,
    exp: &mut dyn Experiment,
    label: &str,
) -> Result<Vec<Option<f64>>> {
    let mut batch = topa_env::vec_env::robot_batch(cfg, n, settings.seed, 0)?;
    for (i, t) in batch.tasks_mut().iter_mut().enumerate() {
        exp.prepare(i, t)?;
    }
    batch.reset()?;
    for t in batch.tasks_mut() {
        t.set_command_override(Some([0.0; 3]));
    }
    let dt = cfg.policy_dt();
    let settle = (settings.settle_s / dt).round() as usize;
    let window = (window_s / dt).round() as usize;
    let mut fell: Vec<Option<f64>> = vec![None; n];
    let mut actions = Vec::new();
    let bar = if n * (settle + window) > 20_000 && !label.is_empty() {
        let b = ProgressBar::new((settle + window) as u64);
        b.set_style(ProgressStyle::with_template("{msg} {bar:30} {pos}/{len} steps, ETA {eta}").unwrap());
        b.set_message(label.to_string());
        b
    } else {
        ProgressBar::hidden()
    };
    for k in 0..settle + window {
        if k == settle {
            for (i, t) in batch.tasks_mut().iter_mut().enumerate() {
                exp.setup(i, t);
            }
        }
        if k >= settle {
            for (i, t) in batch.tasks_mut().iter_mut().enumerate() {
                if fell[i].is_none() {
                    exp.control(k - settle, i, t);
                }
            }
        }
        runner.act(batch.obs(), &mut actions);
        batch.step(&actions)?;
        let t_window = if k >= settle { (k + 1 - settle) as f64 * dt } else { 0.0 };
        let go_on = exp.continue_after_fall();
        for i in 0..n {
            let task = &batch.tasks()[i];
            if fell[i].is_none() && (batch.dones()[i] > 0.5 || (go_on && task.has_fallen())) {
                fell[i] = Some(t_window);
                if !go_on {
                    continue;
                }
            }
            if k >= settle && (go_on || fell[i].is_none()) {
                exp.observe(i, t_window, task, fell[i].is_some());
            }
        }
        bar.inc(1);
        if !go_on && fell.iter().all(|f| f.is_some()) {
            break; // everyone is down: nothing left to measure
        }
    }
    bar.finish_and_clear();
    Ok(fell)
}
