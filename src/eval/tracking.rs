//! Commanded-velocity tracking (paper, Table "Commanded velocity tracking performance"): the six commands, each
//! after settling, for a fixed window; per command the tracking MAE over (v_x, v_y, w_z), the mean total motor
//! torque, the mean roll and pitch, and whether the robot fell.
//!
//! Definitions (the paper does not spell them out): MAE = mean over the window's policy steps and over the three
//! components of |measured − commanded|, velocities in the torso frame; τ̄ = mean over time of Σ_motors |τ|
//! (N·m); θ̄_roll, θ̄_pitch = signed means (rad). The first `transient_s` of the window (accelerating to the
//! command) are excluded from the averages, not from the fall check.

use anyhow::Result;
use serde::Serialize;
use topa_env::state::RobotState;
use topa_env::TopaEnv;

use super::runner::{run_batch, Experiment};
use super::{EvalSettings, PolicyRunner};

/// The paper's six commands: (key in paper_tables.toml, title, (v_x, v_y, w_z)).
pub const COMMANDS: [(&str, &str, [f64; 3]); 6] = [
    ("walk_forward", "Walk forward: v_x = 0.5 m/s", [0.5, 0.0, 0.0]),
    ("walk_backward", "Walk backwards: v_x = −0.35 m/s", [-0.35, 0.0, 0.0]),
    ("walk_right", "Walk right: v_y = 0.5 m/s", [0.0, 0.5, 0.0]),
    ("walk_left", "Walk left: v_y = −0.5 m/s", [0.0, -0.5, 0.0]),
    ("rotate_ccw", "Rotate counterclockwise: w_z = 1.0 rad/s", [0.0, 0.0, 1.0]),
    ("rotate_cw", "Rotate clockwise: w_z = −1.0 rad/s", [0.0, 0.0, -1.0]),
];

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TrackingRow {
    pub key: String,
    pub command: [f64; 3],
    pub mae: f64,
    pub mean_torque: f64,
    pub mean_roll: f64,
    pub mean_pitch: f64,
    pub fell: bool,
    /// Seconds into the window when it fell.
    pub fell_at: Option<f64>,
}

/// Running sums of the tracking metrics.
#[derive(Debug, Clone, Default)]
pub struct TrackingAccumulator {
    n: usize,
    abs_err: f64,
    torque: f64,
    roll: f64,
    pitch: f64,
}

impl TrackingAccumulator {
    pub fn add(
        &mut self,
        command: [f64; 3],
        lin_vel: [f64; 3],
        ang_vel: [f64; 3],
        motor_torque: &[f64],
        roll: f64,
        pitch: f64,
    ) {
        self.n += 1;
        self.abs_err +=
            ((lin_vel[0] - command[0]).abs() + (lin_vel[1] - command[1]).abs() + (ang_vel[2] - command[2]).abs()) / 3.0;
        self.torque += motor_torque.iter().map(|t| t.abs()).sum::<f64>();
        self.roll += roll;
        self.pitch += pitch;
    }

    pub fn add_state(&mut self, command: [f64; 3], s: &RobotState) {
        self.add(command, s.lin_vel, s.ang_vel, &s.motor_torque, s.roll, s.pitch);
    }

    /// (MAE, mean torque, mean roll, mean pitch); NaN when nothing was recorded.
    pub fn finish(&self) -> (f64, f64, f64, f64) {
        let n = self.n as f64;
        if self.n == 0 {
            return (f64::NAN, f64::NAN, f64::NAN, f64::NAN);
        }
        (self.abs_err / n, self.torque / n, self.roll / n, self.pitch / n)
    }
}

struct Tracking {
    commands: Vec<[f64; 3]>,
    transient_s: f64,
    acc: Vec<TrackingAccumulator>,
}

impl Experiment for Tracking {
    fn setup(&mut self, env: usize, task: &mut TopaEnv) {
        task.set_command_override(Some(self.commands[env]));
    }
    fn observe(&mut self, env: usize, t: f64, task: &TopaEnv) {
        if t > self.transient_s {
            self.acc[env].add_state(self.commands[env], task.robot_state());
        }
    }
}

/// Runs the six commands (one env each, in parallel) for `window_s` each.
pub fn run(
    runner: &mut PolicyRunner,
    settings: &EvalSettings,
    window_s: f64,
    transient_s: f64,
) -> Result<Vec<TrackingRow>> {
    let cfg = runner.eval_config(settings)?;
    let commands: Vec<[f64; 3]> = COMMANDS.iter().map(|c| c.2).collect();
    let mut exp =
        Tracking { commands: commands.clone(), transient_s, acc: vec![TrackingAccumulator::default(); commands.len()] };
    let fell = run_batch(runner, &cfg, settings, commands.len(), window_s, &mut exp, "")?;
    Ok(COMMANDS
        .iter()
        .enumerate()
        .map(|(i, (key, _, cmd))| {
            let (mae, mean_torque, mean_roll, mean_pitch) = exp.acc[i].finish();
            TrackingRow {
                key: key.to_string(),
                command: *cmd,
                mae,
                mean_torque,
                mean_roll,
                mean_pitch,
                fell: fell[i].is_some(),
                fell_at: fell[i],
            }
        })
        .collect())
}
