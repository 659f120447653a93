//! The base velocity as the robot's computer knows it, against the simulator's truth, on one walk: the learned
//! estimator's (a velocity-free policy's, `[env.observation] base_velocity = "estimated"`) and the contact-aided
//! Kalman filter's (with the realistic sim2sim, which runs the filter whether or not the policy reads it). The
//! walk is the command cycle of estimator tuning — forward, curving, backward, sideways, a fast turn, standing —
//! each command held for `command_s`. All three in the torso frame, once per control period.
//!
//! A velocity-free policy does not read the filter, so its walk is the same whatever the filter's parameters: with a
//! second sim2sim file (a tuned filter) the walk runs again and the two filters are compared on one walk — checked
//! by the walk's checksum, which a policy that reads the filter breaks.

use std::path::PathBuf;

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

/// Several policies' walks (the seeds of a group), each with the sim2sim mode's filter and, where given, a
/// second filter on the same walk.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VelocityReport {
    /// The sim2sim mode of the walks, and the file of the second filter.
    pub sim2sim: String,
    pub second_filter: Option<PathBuf>,
    pub rows: Vec<VelocityRow>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VelocityRow {
    pub policy: PathBuf,
    pub walk: VelocityResult,
    /// The second filter's error on the same walk.
    pub second: Option<VelocityError>,
}

/// Walks each policy (`runner_of` loads one) under `settings` and, with `second`, again under the second filter's
/// settings: a walk that differs is refused, since its filters would not be compared on one walk.
pub fn run_policies(
    policies: &[PathBuf],
    mut runner_of: impl FnMut(&PathBuf) -> Result<PolicyRunner>,
    settings: &EvalSettings,
    second: Option<(&PathBuf, &EvalSettings)>,
    seconds: f64,
    command_s: f64,
) -> Result<VelocityReport> {
    let mut rows = Vec::new();
    for p in policies {
        let walk = run(&mut runner_of(p)?, settings, seconds, command_s)?;
        let second = match second {
            Some((file, s2)) => {
                let again = run(&mut runner_of(p)?, s2, seconds, command_s)?;
                ensure!(
                    again.walk_checksum == walk.walk_checksum,
                    "{}: the walk under --tuned-filter {} is not the walk under --sim2sim {}: the policy reads the                      filter's estimate (or the file changes more than the filter), so the two filters would not be                      compared on one walk; use a velocity-free policy and a file that differs in [estimator] only",
                    p.display(),
                    file.display(),
                    settings.sim2sim_mode
                );
                ensure!(again.filter.is_some(), "--tuned-filter {}: its [estimator] is not enabled", file.display());
                again.filter
            }
            None => None,
        };
        rows.push(VelocityRow { policy: p.clone(), walk, second });
    }
    Ok(VelocityReport {
        sim2sim: settings.sim2sim_mode.to_string(),
        second_filter: second.map(|(f, _)| f.clone()),
        rows,
    })
}

/// The report: one policy without a second filter as its own table (`markdown`); otherwise one row per policy
/// (horizontal RMSE) and the mean ± sd over them.
pub fn report_markdown(r: &VelocityReport) -> String {
    if let ([one], None) = (r.rows.as_slice(), &r.second_filter) {
        return markdown(&one.walk);
    }
    let second = r.second_filter.as_ref().map(|f| format!(" Kalman filter, {} |", f.display()));
    let mut s = format!(
        "Horizontal base velocity (v_x, v_y) against the simulator's truth, torso frame, RMSE in m/s over each \
         policy's walk through the command cycle (sim2sim: {}).\n\n| policy | learned estimator | Kalman filter ({}) |{} \
         zero (the truth's RMS) | fell |\n|---|---:|---:|{}---:|---|\n",
        r.sim2sim,
        r.sim2sim,
        second.as_deref().unwrap_or(""),
        if second.is_some() { "---:|" } else { "" }
    );
    let cell = |e: Option<f64>| e.map_or("–".into(), |x| format!("{x:.4}"));
    let columns = |w: &VelocityRow| {
        let mut c = vec![w.walk.learned.map(|e| e.horizontal), w.walk.filter.map(|e| e.horizontal)];
        if r.second_filter.is_some() {
            c.push(w.second.map(|e| e.horizontal));
        }
        c.push(Some(w.walk.truth_rms.horizontal));
        c
    };
    for w in &r.rows {
        let cells: Vec<String> = columns(w).into_iter().map(cell).collect();
        let fell = if w.walk.fell { "yes" } else { "no" };
        s.push_str(&format!("| {} | {} | {fell} |\n", w.policy.display(), cells.join(" | ")));
    }
    if r.rows.len() > 1 {
        let n = columns(&r.rows[0]).len();
        let stats: Vec<String> = (0..n)
            .map(|i| {
                let xs: Vec<f64> = r.rows.iter().filter_map(|w| columns(w)[i]).collect();
                crate::groups::Stat::of(&xs).show(4)
            })
            .collect();
        s.push_str(&format!("| mean ± sd | {} | |\n", stats.join(" | ")));
    }
    s
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
