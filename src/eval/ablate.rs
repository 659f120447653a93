//! `topa ablate`: the paper's three experiments for O, C and C+A, our numbers beside the paper's, the three push
//! heatmaps side by side, everything written to an output folder.

use std::path::{Path, PathBuf};

use anyhow::{ensure, Result};
use serde::Serialize;

use super::noise::{self, NoiseRow};
use super::push::{self, PushGrid};
use super::report::{self, label};
use super::tracking::{self, TrackingRow};
use super::{EvalSettings, PolicyRunner};

/// How much of each experiment to run.
#[derive(Debug, Clone, Serialize)]
pub struct Extent {
    pub tracking_window_s: f64,
    pub tracking_transient_s: f64,
    pub push_range_n: f64,
    pub push_step_n: f64,
    pub push_window_s: f64,
    pub noise_runs: usize,
    pub noise_seconds: f64,
    pub noise_interval_s: f64,
}

impl Extent {
    /// The paper's protocol: 13 × 13 push grid, 100 noise runs per level.
    pub fn full() -> Self {
        Extent {
            tracking_window_s: 10.0,
            tracking_transient_s: 2.0,
            push_range_n: 30.0,
            push_step_n: 5.0,
            push_window_s: 10.0,
            noise_runs: 100,
            noise_seconds: 20.0,
            noise_interval_s: 0.5,
        }
    }
    /// A quick look (a few minutes for three policies on 2 cores): 7 × 7 push grid (10 N steps), 20 noise runs
    /// of 10 s per level.
    pub fn quick() -> Self {
        Extent { push_step_n: 10.0, noise_runs: 20, noise_seconds: 10.0, ..Extent::full() }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct PolicyResults {
    pub name: String,
    pub policy: PathBuf,
    pub trained_on: String,
    pub tracking: Vec<TrackingRow>,
    pub push: PushGrid,
    pub noise: Vec<NoiseRow>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Ablation {
    pub settings: EvalSettings,
    pub extent: Extent,
    pub results: Vec<PolicyResults>,
}

/// Runs every experiment for each (name, policy file).
pub fn run(policies: &[(String, PathBuf)], settings: &EvalSettings, extent: &Extent) -> Result<Ablation> {
    ensure!(!policies.is_empty(), "give at least one of --o, --c, --ca");
    let mut results = Vec::new();
    for (name, path) in policies {
        let mut runner = PolicyRunner::load(path, label(name))?;
        eprintln!("{}: {} (trained on the {} model)", label(name), path.display(), runner.trained_on().name());
        let tracking = tracking::run(&mut runner, settings, extent.tracking_window_s, extent.tracking_transient_s)?;
        let push =
            push::run(&mut runner, settings, extent.push_range_n, extent.push_step_n, extent.push_window_s, [0.0; 3])?;
        let noise =
            noise::run(&mut runner, settings, extent.noise_runs, extent.noise_seconds, extent.noise_interval_s)?;
        results.push(PolicyResults {
            name: name.clone(),
            policy: path.clone(),
            trained_on: runner.trained_on().name().into(),
            tracking,
            push,
            noise,
        });
    }
    Ok(Ablation { settings: settings.clone(), extent: extent.clone(), results })
}

/// The three Markdown tables with the paper's numbers beside ours.
pub fn markdown(a: &Ablation) -> Result<String> {
    let paper = report::paper()?;
    let tr: Vec<(&str, &[TrackingRow])> = a.results.iter().map(|r| (r.name.as_str(), r.tracking.as_slice())).collect();
    let pu: Vec<(&str, &PushGrid)> = a.results.iter().map(|r| (r.name.as_str(), &r.push)).collect();
    let no: Vec<(&str, &[NoiseRow])> = a.results.iter().map(|r| (r.name.as_str(), r.noise.as_slice())).collect();
    Ok(format!(
        "## Commanded velocity tracking\n{}\n## Gait\n\n{}\n## Time to fall under a constant torso force\n\n{}\n## Command noise\n\n{}",
        report::tracking_markdown(&tr, Some(&paper)),
        report::gait_markdown(&tr),
        report::push_markdown(&pu, Some(&paper)),
        report::noise_markdown(&no, Some(&paper)),
    ))
}

/// Writes ablation.{md,json}, per-policy CSVs, and the heatmaps into `out`.
pub fn write(a: &Ablation, out: &Path) -> Result<()> {
    std::fs::create_dir_all(out)?;
    report::write_text(out, "ablation.md", &markdown(a)?)?;
    report::write_json(out, "ablation.json", a)?;
    for r in &a.results {
        report::write_text(out, &format!("{}_tracking.csv", r.name), &report::tracking_csv(&r.tracking))?;
        report::write_text(out, &format!("{}_push.csv", r.name), &report::push_csv(&r.push))?;
        report::write_text(out, &format!("{}_noise.csv", r.name), &report::noise_csv(&r.noise))?;
    }
    let grids: Vec<(String, &PushGrid)> = a.results.iter().map(|r| (label(&r.name).to_string(), &r.push)).collect();
    crate::plots::push_heatmaps(&grids, &out.join("heatmaps.png"), &out.join("heatmaps.svg"))
}
