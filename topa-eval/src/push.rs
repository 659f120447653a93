//! Stability under external perturbations (paper, Fig. "Average time to fall"): a constant force on the torso in
//! its own frame, (F_x, F_y) on a grid from −30 to 30 N in 5 N steps (13 × 13), applied after settling for a
//! 10 s window; the time to fall (the env's fall test) per cell, `window` where it never falls.

use topa_env::RobotEnv;

use super::runner::{run_batch, Experiment};
use super::settings::EvalSettings;
use topa_env::policy_runner::PolicyRunner;

use super::results::PushGrid;
use crate::error::{ensure, Result};

/// Force values from −range to +range in `step` increments.
pub fn axis(range: f64, step: f64) -> Result<Vec<f64>> {
    ensure!(range >= 0.0 && step > 0.0, "push grid: range must be ≥ 0 and step > 0");
    let k = (range / step).round() as i64;
    ensure!(((k as f64) * step - range).abs() < 1e-9, "push grid: range {range} is not a multiple of step {step}");
    Ok((-k..=k).map(|i| i as f64 * step).collect())
}

/// The (F_x, F_y) of every cell, F_x fastest.
pub fn cells(axis: &[f64]) -> Vec<[f64; 2]> {
    axis.iter().flat_map(|&fy| axis.iter().map(move |&fx| [fx, fy])).collect()
}

struct Push {
    forces: Vec<[f64; 2]>,
    command: [f64; 3],
}

impl Experiment for Push {
    fn setup(&mut self, env: usize, task: &mut RobotEnv) {
        task.set_command_override(Some(self.command));
        let mut p = *task.perturbation();
        p.torso_force_local = [self.forces[env][0], self.forces[env][1], 0.0];
        task.set_perturbation_struct(p);
    }
}

pub fn run(
    runner: &mut PolicyRunner,
    settings: &EvalSettings,
    range: f64,
    step: f64,
    window_s: f64,
    command: [f64; 3],
) -> Result<PushGrid> {
    let cfg = settings.env_config(runner)?;
    let ax = axis(range, step)?;
    let forces = cells(&ax);
    let label = format!("push grid {} × {} ({})", ax.len(), ax.len(), runner.name);
    let mut exp = Push { forces: forces.clone(), command };
    let fell = run_batch(runner, &cfg, settings, forces.len(), window_s, &mut exp, &label)?;
    Ok(PushGrid { axis: ax, t_fall: fell.iter().map(|f| f.unwrap_or(window_s)).collect(), window_s, command })
}
