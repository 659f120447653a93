//! Robustness to the simulator itself (`topa physics`, `topa eval physics`): the six tracking commands and the
//! push grid's centre cells under each case of a perturbation matrix (`matrix`) — contact model, solver,
//! integrator and timestep, friction, motors, torso, soles, latency — one at a time and in seeded random
//! combinations. A case is survived when the policy meets the bars there: no fall and no stand-still on any
//! command, every tracking component's MAE within `claims::MAX_COMPONENT_MAE`, no fall under the centre pushes. A
//! simulation that diverges is a case failed, with MuJoCo's reason. The score of a policy is the share of the
//! perturbed cases (all but nominal) it survives; the groups' scores and their intervals are in `report`.

pub mod flip;
pub mod fragility;
pub mod heatmap;
pub mod matrix;
pub mod render;
pub mod report;

use serde::{Deserialize, Serialize};
use topa_env::policy_runner::PolicyRunner;

use super::claims::{self, MAX_COMPONENT_MAE};
use super::results::TrackingRow;
use super::settings::EvalSettings;
use super::{push, tracking};
use crate::error::{Error, Result};
use matrix::{Matrix, Perturbation};

/// How much each case runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Protocol {
    /// Seconds per tracking command (after settling).
    pub tracking_window_s: f64,
    pub tracking_transient_s: f64,
    /// Initial states per tracking command.
    pub tracking_starts: usize,
    /// The push cells are (F_x, F_y) ∈ {−F, 0, F}², N.
    pub push_force_n: f64,
    pub push_window_s: f64,
}

impl Default for Protocol {
    fn default() -> Self {
        Protocol {
            tracking_window_s: 10.0,
            tracking_transient_s: 2.0,
            tracking_starts: 2,
            push_force_n: 10.0,
            push_window_s: 10.0,
        }
    }
}

impl Protocol {
    pub fn describe(&self) -> String {
        format!(
            "{} starts × {} s per tracking command, standing pushes of (F_x, F_y) ∈ {{−{f}, 0, {f}}}² N for {} s",
            self.tracking_starts,
            self.tracking_window_s,
            self.push_window_s,
            f = self.push_force_n
        )
    }
}

/// One case's outcome for one policy.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseResult {
    pub case: String,
    /// Tracking runs that fell, of `tracking_runs`.
    pub tracking_falls: usize,
    pub tracking_runs: usize,
    /// Tracking runs that stood still on their command.
    pub stand_stills: usize,
    /// The largest per-component MAE over the commands (whole window, as the ablation's bar).
    #[serde(deserialize_with = "crate::nan_json::f64")]
    pub worst_component_mae: f64,
    /// The command of the worst component.
    pub worst_command: String,
    /// Push cells that fell, of `push_cells`.
    pub push_falls: usize,
    pub push_cells: usize,
    /// The earliest fall in the push cells (the window where none fell), s.
    #[serde(deserialize_with = "crate::nan_json::f64")]
    pub push_min_t_fall_s: f64,
    /// Why the case could not be run to its end (a diverging simulation), if so.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

impl CaseResult {
    fn measured(case: &str, rows: &[TrackingRow], push_t_fall: &[f64], window_s: f64) -> CaseResult {
        let (worst_command, worst) = claims::worst_component(rows);
        CaseResult {
            case: case.into(),
            tracking_falls: rows.iter().map(TrackingRow::fall_count).sum(),
            tracking_runs: rows.iter().map(|r| r.starts).sum(),
            stand_stills: rows.iter().filter_map(|r| r.stood_still).sum(),
            worst_component_mae: worst,
            worst_command: worst_command.into(),
            push_falls: push_t_fall.iter().filter(|&&t| t < window_s).count(),
            push_cells: push_t_fall.len(),
            push_min_t_fall_s: push_t_fall.iter().cloned().fold(window_s, f64::min),
            failure: None,
        }
    }

    fn diverged(case: &str, why: String) -> CaseResult {
        CaseResult {
            case: case.into(),
            tracking_falls: 0,
            tracking_runs: 0,
            stand_stills: 0,
            worst_component_mae: f64::NAN,
            worst_command: String::new(),
            push_falls: 0,
            push_cells: 0,
            push_min_t_fall_s: f64::NAN,
            failure: Some(why),
        }
    }

    /// Whether the policy meets every bar in this case.
    pub fn survived(&self) -> bool {
        self.failure.is_none()
            && self.tracking_falls == 0
            && self.stand_stills == 0
            && self.worst_component_mae <= MAX_COMPONENT_MAE
            && self.push_falls == 0
    }

    /// Whether the policy stayed up: no tracking run and no push fell, and the simulation ran to its end (the
    /// tracking-precision and stand-still bars aside).
    pub fn no_fall(&self) -> bool {
        self.failure.is_none() && self.tracking_falls == 0 && self.push_falls == 0
    }

    /// The bars it misses, in words ("" when survived).
    pub fn missed(&self) -> String {
        if let Some(f) = &self.failure {
            return format!("diverged: {f}");
        }
        let mut out = Vec::new();
        if self.tracking_falls > 0 {
            out.push(format!("{}/{} tracking falls", self.tracking_falls, self.tracking_runs));
        }
        if self.stand_stills > 0 {
            out.push(format!("{} stand-stills", self.stand_stills));
        }
        if self.worst_component_mae > MAX_COMPONENT_MAE {
            out.push(format!("MAE {:.3} ({})", self.worst_component_mae, self.worst_command));
        }
        if self.push_falls > 0 {
            out.push(format!("{}/{} push falls", self.push_falls, self.push_cells));
        }
        out.join(", ")
    }
}

/// One policy through every case, in the matrix's order (nominal first).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhysicsResult {
    pub cases: Vec<CaseResult>,
}

impl PhysicsResult {
    /// The perturbed cases (all but nominal).
    pub fn perturbed(&self) -> &[CaseResult] {
        self.cases.get(1..).unwrap_or(&[])
    }

    /// Share of the perturbed cases survived, 0–1.
    pub fn score(&self) -> f64 {
        let p = self.perturbed();
        p.iter().filter(|c| c.survived()).count() as f64 / p.len().max(1) as f64
    }

    pub fn nominal(&self) -> Option<&CaseResult> {
        self.cases.first()
    }
}

/// Runs `runner`'s policy through every case of `m` on top of `base`.
pub fn run(runner: &mut PolicyRunner, base: &EvalSettings, m: &Matrix, p: &Protocol) -> Result<PhysicsResult> {
    let policy_dt = runner.policy.meta.policy_dt;
    m.check(base, policy_dt)?;
    let cases = m.expand();
    let mut out = Vec::with_capacity(cases.len());
    for (i, case) in cases.iter().enumerate() {
        eprintln!("  [{}/{}] {}", i + 1, cases.len(), case.name);
        out.push(run_case(runner, base, case, p)?);
    }
    Ok(PhysicsResult { cases: out })
}

fn run_case(runner: &mut PolicyRunner, base: &EvalSettings, case: &Perturbation, p: &Protocol) -> Result<CaseResult> {
    let s = case.settings(base, runner.policy.meta.policy_dt)?;
    let measured = (|| -> Result<CaseResult> {
        let rows = tracking::run(runner, &s, p.tracking_window_s, p.tracking_transient_s, p.tracking_starts)?;
        let f = p.push_force_n;
        let grid = push::run(runner, &s, f, f, p.push_window_s, [0.0; 3])?;
        Ok(CaseResult::measured(&case.name, &rows, &grid.t_fall, p.push_window_s))
    })();
    match measured {
        // A simulation that blows up under a perturbation is that perturbation's result, not the study's end.
        Err(Error::Simulation(e)) => Ok(CaseResult::diverged(&case.name, e.to_string())),
        other => other,
    }
}
