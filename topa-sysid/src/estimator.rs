//! Estimator tuning, the paper's second data-fitting step: the contact-aided Kalman filter's noise parameters chosen
//! to minimise its velocity error against ground truth, on recordings of the filter's own inputs beside the truth
//! (the realistic sim2sim records them; a real robot's log with motion capture has the same columns).
//!
//! The filter's mean depends only on the ratios of its noise parameters, so `q_position` stays as the scale and the
//! others are fitted, in log space within ×/÷ 1000 of their defaults, by Levenberg–Marquardt on the horizontal
//! velocity errors of a replay.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use topa_env::policy_runner::PolicyRunner;
use topa_env::sim2sim::estimator::{ContactKf, EstimatorConfig, EstimatorInput};
use topa_env::sim2sim::FilterSample;
use topa_env::VecEnv;

use super::lm::{self, DMatrix, Residuals};
use crate::error::{ensure, ensure_file, Error, Result};
use topa_eval::settings::EvalSettings;

/// The commands the recording walks through, each held for `COMMAND_S`: forward, curving, backward, sideways,
/// a fast turn, standing (vx, vy, yaw rate).
const COMMANDS: [[f64; 3]; 6] =
    [[0.5, 0.0, 0.0], [0.3, 0.0, 0.5], [-0.3, 0.0, 0.0], [0.0, 0.2, 0.0], [0.6, 0.0, -0.4], [0.0, 0.0, 0.0]];
const COMMAND_S: f64 = 4.0;

/// The fitted parameters (q_position is the scale).
const TUNED: [&str; 5] = ["q_velocity", "q_foot", "r_foot_position", "r_foot_velocity", "r_foot_height"];

/// Each parameter stays within this factor of its default either way (a measurement the data says to ignore
/// gets the largest noise, not an overflowing one).
const RANGE: f64 = 1e3;

fn get(c: &EstimatorConfig, k: usize) -> f64 {
    [c.q_velocity, c.q_foot, c.r_foot_position, c.r_foot_velocity, c.r_foot_height][k]
}

fn set(c: &mut EstimatorConfig, k: usize, v: f64) {
    *[&mut c.q_velocity, &mut c.q_foot, &mut c.r_foot_position, &mut c.r_foot_velocity, &mut c.r_foot_height][k] = v;
}

/// Drives `runner`'s policy through the command cycle for `seconds` under `settings` (realistic sim2sim, with the
/// estimator on) and returns every filter step with its truth.
pub fn record(runner: &mut PolicyRunner, settings: &EvalSettings, seconds: f64) -> Result<Vec<FilterSample>> {
    let cfg = settings.env_config(runner)?;
    ensure!(cfg.sim2sim.estimator.enabled, "recording the estimator needs a sim2sim mode with the estimator on");
    let mut batch = topa_env::vec_env::robot_batch(&cfg, 1, settings.seed, 1)?;
    batch.tasks_mut()[0].sim2sim_mut().ok_or_else(|| Error::Invalid("no sim2sim state".into()))?.recording =
        Some(Vec::new());
    batch.reset()?;
    let dt = cfg.policy_dt();
    let mut actions = Vec::new();
    for k in 0..(seconds / dt).round() as usize {
        let c = COMMANDS[((k as f64 * dt / COMMAND_S) as usize) % COMMANDS.len()];
        batch.tasks_mut()[0].set_command_override(Some(c));
        runner.act(batch.obs(), &mut actions);
        batch.step(&actions)?;
    }
    Ok(batch.tasks_mut()[0].sim2sim_mut().and_then(|s| s.recording.take()).unwrap_or_default())
}

/// The filter run over a recording with `cfg`: its velocity after each step.
pub fn replay(cfg: &EstimatorConfig, samples: &[FilterSample]) -> Vec<Vector3<f64>> {
    let feet = samples.first().map_or(2, |s| s.input.foot_rel.len());
    let mut kf = ContactKf::new(cfg.clone(), feet);
    samples
        .iter()
        .map(|s| {
            if let Some((h, f)) = &s.restart {
                kf.reset(*h, f);
            }
            kf.step(s.dt, &s.input);
            kf.velocity()
        })
        .collect()
}

/// Horizontal velocity RMSE of estimates against the recording's truth, m/s.
pub fn rmse(estimates: &[Vector3<f64>], samples: &[FilterSample]) -> f64 {
    let sq: f64 = estimates.iter().zip(samples).map(|(e, s)| (e - s.truth).xy().norm_squared()).sum();
    (sq / samples.len().max(1) as f64).sqrt()
}

struct Problem<'a> {
    base: EstimatorConfig,
    samples: &'a [FilterSample],
}

impl Problem<'_> {
    /// ln θ = ln θ₀ + ln(RANGE)·sin z: every z maps into the box, z = 0 is the default.
    fn config(&self, z: &[f64]) -> EstimatorConfig {
        let mut c = self.base.clone();
        for (k, v) in z.iter().enumerate() {
            set(&mut c, k, get(&self.base, k) * RANGE.powf(v.sin()));
        }
        c
    }

    fn residuals_at(&self, z: &[f64]) -> Vec<f64> {
        let e = replay(&self.config(z), self.samples);
        e.iter().zip(self.samples).flat_map(|(e, s)| [e.x - s.truth.x, e.y - s.truth.y]).collect()
    }
}

impl Residuals for Problem<'_> {
    fn residuals(&self, z: &[f64]) -> Option<Vec<f64>> {
        Some(self.residuals_at(z))
    }

    fn jacobian(&self, z: &[f64]) -> Option<DMatrix<f64>> {
        let r0 = self.residuals_at(z);
        const H: f64 = 1e-3; // about 0.7 % of the parameter
        let cols: Vec<Vec<f64>> = (0..z.len())
            .into_par_iter()
            .map(|j| {
                let mut zj = z.to_vec();
                zj[j] += H;
                self.residuals_at(&zj)
            })
            .collect();
        Some(DMatrix::from_fn(r0.len(), z.len(), |i, j| (cols[j][i] - r0[i]) / H))
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Tuning {
    pub default: EstimatorConfig,
    pub tuned: EstimatorConfig,
    pub converged: bool,
    pub termination: String,
    /// Horizontal velocity RMSE, m/s, of a replay over the fitted recording: default, tuned.
    pub fit_rmse: [f64; 2],
    /// The same over the held-out recording.
    pub held_out_rmse: [f64; 2],
    /// Seconds of recording fitted and held out.
    pub fitted_s: f64,
    pub held_out_s: f64,
}

/// Fits the filter's noise ratios on `fit`, checks them on `held_out`.
pub fn tune(default: &EstimatorConfig, fit: &[FilterSample], held_out: &[FilterSample]) -> Result<Tuning> {
    ensure!(fit.len() > 100 && !held_out.is_empty(), "the recordings are too short to tune on");
    let problem = Problem { base: default.clone(), samples: fit };
    let min = lm::minimize(&problem, vec![0.0; TUNED.len()], 30);
    let tuned = problem.config(&min.z);
    let seconds = |s: &[FilterSample]| s.iter().map(|x| x.dt).sum::<f64>();
    Ok(Tuning {
        fit_rmse: [rmse(&replay(default, fit), fit), rmse(&replay(&tuned, fit), fit)],
        held_out_rmse: [rmse(&replay(default, held_out), held_out), rmse(&replay(&tuned, held_out), held_out)],
        default: default.clone(),
        tuned,
        converged: min.converged,
        termination: min.termination,
        fitted_s: seconds(fit),
        held_out_s: seconds(held_out),
    })
}

/// The filter's columns, the format a real robot's log with motion capture can be written in.
pub fn to_csv(samples: &[FilterSample]) -> String {
    let feet = samples.first().map_or(2, |s| s.input.foot_rel.len());
    let mut s = String::from("dt,accel_x,accel_y,accel_z");
    for i in 0..feet {
        let _ =
            write!(s, ",foot{i}_x,foot{i}_y,foot{i}_z,foot{i}_vx,foot{i}_vy,foot{i}_vz,foot{i}_contact,foot{i}_spin");
    }
    s.push_str(",true_vx,true_vy,true_vz,restart_height\n");
    for x in samples {
        let u = &x.input;
        let _ = write!(s, "{},{},{},{}", x.dt, u.accel.x, u.accel.y, u.accel.z);
        for i in 0..feet {
            let (r, v) = (u.foot_rel[i], u.foot_vel[i]);
            let _ =
                write!(s, ",{},{},{},{},{},{},{},{}", r.x, r.y, r.z, v.x, v.y, v.z, u.contact[i] as u8, u.foot_spin[i]);
        }
        let restart = x.restart.as_ref().map_or(String::new(), |(h, _)| h.to_string());
        let _ = writeln!(s, ",{},{},{},{restart}", x.truth.x, x.truth.y, x.truth.z);
    }
    s
}

/// Reads a recording written by [`to_csv`] (or by a robot in its columns); an empty `restart_height` means no
/// restart, and a restart starts the feet where that row's kinematics puts them.
pub fn read_csv(path: &Path) -> Result<Vec<FilterSample>> {
    let text = std::fs::read_to_string(path).map_err(Error::io("cannot read the recording", path))?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty() && !l.starts_with('#'));
    let header: Vec<&str> = lines.next().ok_or_else(|| Error::bad_file("empty recording"))?.split(',').collect();
    let feet = header.iter().filter(|h| h.ends_with("_contact")).count();
    let expected = 4 + 8 * feet + 4;
    ensure_file!(
        feet > 0 && header.len() == expected && header[0] == "dt" && header[expected - 1] == "restart_height",
        "recording {}: expected the columns dt, accel_x..z, per foot foot<i>_x..z, foot<i>_vx..vz, foot<i>_contact, \
         foot<i>_spin, then true_vx..vz and restart_height (docs/sysid.md)",
        path.display()
    );
    let mut out = Vec::new();
    for (row, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        ensure_file!(
            f.len() == expected,
            "recording {}: row {} has {} fields, not {expected}",
            path.display(),
            row + 1,
            f.len()
        );
        let num = |i: usize| -> Result<f64> {
            let v: f64 = f[i].trim().parse().map_err(|e| {
                Error::file(
                    format!(
                        "recording {}: row {}, column {}: {:?} is not a number",
                        path.display(),
                        row + 1,
                        header[i],
                        f[i]
                    ),
                    e,
                )
            })?;
            ensure_file!(v.is_finite(), "recording {}: row {}, column {}: {v}", path.display(), row + 1, header[i]);
            Ok(v)
        };
        let v3 = |i: usize| -> Result<Vector3<f64>> { Ok(Vector3::new(num(i)?, num(i + 1)?, num(i + 2)?)) };
        let mut input = EstimatorInput { accel: v3(1)?, ..Default::default() };
        for k in 0..feet {
            let b = 4 + 8 * k;
            input.foot_rel.push(v3(b)?);
            input.foot_vel.push(v3(b + 3)?);
            input.contact.push(num(b + 6)? > 0.5);
            input.foot_spin.push(num(b + 7)?);
        }
        let dt = num(0)?;
        ensure_file!(dt > 0.0, "recording {}: row {}: dt {dt} must be positive", path.display(), row + 1);
        let restart = match f[expected - 1].trim() {
            "" => None,
            _ => Some((num(expected - 1)?, input.foot_rel.clone())),
        };
        let truth = v3(4 + 8 * feet)?;
        out.push(FilterSample { dt, input, truth, estimate: Vector3::zeros(), restart });
    }
    ensure_file!(!out.is_empty(), "recording {}: no rows", path.display());
    if out[0].restart.is_none() {
        let h = -out[0].input.foot_rel.iter().map(|r| r.z).sum::<f64>() / feet as f64;
        out[0].restart = Some((h, out[0].input.foot_rel.clone()));
    }
    Ok(out)
}

/// The report.
pub fn markdown(t: &Tuning, closed_loop: Option<[f64; 2]>) -> String {
    let mut s = format!(
        "# Estimator tuning\n\n{} ({}). Horizontal velocity RMSE, m/s (default → tuned):\n\n\
         | | default | tuned |\n|---|---:|---:|\n| replay, fitted recording ({:.0} s) | {:.4} | {:.4} |\n\
         | replay, held-out recording ({:.0} s) | {:.4} | {:.4} |\n",
        if t.converged { "Converged" } else { "**Did not converge**: the best values found" },
        t.termination,
        t.fitted_s,
        t.fit_rmse[0],
        t.fit_rmse[1],
        t.held_out_s,
        t.held_out_rmse[0],
        t.held_out_rmse[1]
    );
    if let Some([a, b]) = closed_loop {
        let _ = writeln!(s, "| closed loop, the policy walking on the estimate (held-out seed) | {a:.4} | {b:.4} |");
    }
    s.push_str("\n| parameter | default | tuned |\n|---|---:|---:|\n");
    let _ = writeln!(s, "| q_position (the scale, kept) | {} | {} |", t.default.q_position, t.tuned.q_position);
    for (k, name) in TUNED.iter().enumerate() {
        let _ = writeln!(s, "| {name} | {:.3e} | {:.3e} |", get(&t.default, k), get(&t.tuned, k));
    }
    s
}
