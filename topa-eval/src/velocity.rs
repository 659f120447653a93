//! The base velocity as the robot's computer knows it, against the simulator's truth, on one walk: the learned
//! estimator's (a velocity-free policy's, `[env.observation] base_velocity = "estimated"`) and the contact-aided
//! Kalman filter's (with the realistic sim2sim, which runs the filter whether or not the policy reads it). The
//! walk is the command cycle of estimator tuning — forward, curving, backward, sideways, a fast turn, standing —
//! each command held for `command_s`. All three in the torso frame, once per control period.
//!
//! A velocity-free policy does not read the filter, so its walk is the same whatever the filter's parameters: run
//! twice with two sim2sim files (the default filter, a tuned one) and the two filters are compared on one walk.

use serde::{Deserialize, Serialize};
use topa_env::policy_runner::PolicyRunner;
use topa_env::VecEnv;

use crate::error::{ensure, Result};
use crate::settings::EvalSettings;

/// The commands of the walk (vx, vy, yaw rate), each held for `command_s` (estimator tuning's cycle).
pub const COMMANDS: [[f64; 3]; 6] =
    [[0.5, 0.0, 0.0], [0.3, 0.0, 0.5], [-0.3, 0.0, 0.0], [0.0, 0.2, 0.0], [0.6, 0.0, -0.4], [0.0, 0.0, 0.0]];

/// Root mean squared errors of one estimate against the truth, m/s.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct VelocityError {
    /// Over v_x and v_y (the commanded components).
    pub horizontal: f64,
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl VelocityError {
    fn of(sq: &[f64; 3], n: usize) -> Self {
        let k = n.max(1) as f64;
        VelocityError {
            horizontal: ((sq[0] + sq[1]) / (2.0 * k)).sqrt(),
            x: (sq[0] / k).sqrt(),
            y: (sq[1] / k).sqrt(),
            z: (sq[2] / k).sqrt(),
        }
    }
}

/// One walk's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VelocityResult {
    pub seconds: f64,
    pub command_s: f64,
    pub policy_dt: f64,
    /// Control periods compared (until the walk ended or the robot fell).
    pub steps: usize,
    pub fell: bool,
    /// The learned estimator's error (None: the policy has none).
    pub learned: Option<VelocityError>,
    /// The Kalman filter's error (None: the sim2sim mode runs no filter).
    pub filter: Option<VelocityError>,
    /// The RMS of the true velocity itself (what an estimate of zero would score).
    pub truth_rms: VelocityError,
    /// A checksum of the true velocities (bit patterns): equal on two walks that were the same.
    pub walk_checksum: u64,
}

/// Walks `runner`'s policy through the command cycle for `seconds` under `settings`.
pub fn run(runner: &mut PolicyRunner, settings: &EvalSettings, seconds: f64, command_s: f64) -> Result<VelocityResult> {
    ensure!(seconds > 0.0 && command_s > 0.0, "the walk and each command need a positive duration");
    let cfg = settings.env_config(runner)?;
    let mut batch = topa_env::vec_env::robot_batch(&cfg, 1, settings.seed, 1)?;
    batch.reset()?;
    let dt = cfg.policy_dt();
    let with_filter = cfg.sim2sim.estimator.enabled;
    let mut actions = Vec::new();
    let (mut learned, mut filter, mut truth) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
    let (mut steps, mut fell, mut has_learned) = (0, false, false);
    let mut checksum = 0xcbf2_9ce4_8422_2325u64;
    for k in 0..(seconds / dt).round() as usize {
        let c = COMMANDS[((k as f64 * dt / command_s) as usize) % COMMANDS.len()];
        batch.tasks_mut()[0].set_command_override(Some(c));
        runner.act(batch.obs(), &mut actions);
        let estimate = runner.policy.estimate();
        let env = &batch.tasks()[0];
        let v = env.robot_state().lin_vel;
        for i in 0..3 {
            truth[i] += v[i] * v[i];
            checksum = (checksum ^ v[i].to_bits()).wrapping_mul(0x100_0000_01b3);
            if let Some(e) = &estimate {
                learned[i] += (e[i] - v[i]).powi(2);
            }
            if let Some(s) = env.sim2sim().filter(|_| with_filter) {
                filter[i] += (s.latest().lin_vel[i] - v[i]).powi(2);
            }
        }
        has_learned = estimate.is_some();
        steps += 1;
        batch.step(&actions)?;
        if batch.dones()[0] > 0.5 {
            fell = batch.time_outs()[0] < 0.5;
            break;
        }
    }
    Ok(VelocityResult {
        seconds,
        command_s,
        policy_dt: dt,
        steps,
        fell,
        learned: has_learned.then(|| VelocityError::of(&learned, steps)),
        filter: with_filter.then(|| VelocityError::of(&filter, steps)),
        truth_rms: VelocityError::of(&truth, steps),
        walk_checksum: checksum,
    })
}

/// The result as a Markdown table.
pub fn markdown(r: &VelocityResult) -> String {
    let row = |name: &str, e: &Option<VelocityError>| match e {
        Some(e) => format!("| {name} | {:.4} | {:.4} | {:.4} | {:.4} |\n", e.horizontal, e.x, e.y, e.z),
        None => format!("| {name} | – | – | – | – |\n"),
    };
    let mut s = format!(
        "Base velocity against the simulator's truth, torso frame, RMSE in m/s over {} control periods ({:.1} s of \
         the command cycle, {} s per command{}).\n\n| estimate | horizontal | v_x | v_y | v_z |\n|---|---:|---:|---:|---:|\n",
        r.steps,
        r.steps as f64 * r.policy_dt,
        r.command_s,
        if r.fell { "; the robot fell" } else { "" }
    );
    s.push_str(&row("learned estimator", &r.learned));
    s.push_str(&row("Kalman filter", &r.filter));
    s.push_str(&row("zero (the truth's RMS)", &Some(r.truth_rms)));
    s
}
