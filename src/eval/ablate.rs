//! `topa ablate`: the paper's three experiments for O, C and C+A — each group one or several policies (seeds) —
//! and the push test while walking beside the paper's standing one; mean ± sd of every headline number with the
//! paper's beside (groups.rs), each policy's own numbers, the groups' mean heatmaps, all written to a folder.

use std::path::{Path, PathBuf};

use anyhow::{ensure, Context, Result};
use serde::Serialize;

use super::groups;
use super::noise::{self, NoiseRow};
use super::push::{self, PushGrid};
use super::report::{self, label};
use super::tracking::{self, TrackingRow};
use super::{EvalSettings, PolicyRunner};

/// How much of each experiment to run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Extent {
    pub tracking_window_s: f64,
    pub tracking_transient_s: f64,
    pub push_range_n: f64,
    pub push_step_n: f64,
    pub push_window_s: f64,
    pub noise_runs: usize,
    pub noise_seconds: f64,
    pub noise_interval_s: f64,
    /// The command held in the second push test (the paper does not say whether its robot stood or walked).
    pub walking_push_command: [f64; 3],
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
            walking_push_command: [0.5, 0.0, 0.0],
        }
    }
    /// A quick look (a few minutes for three policies on 2 cores): 7 × 7 push grid (10 N steps), 20 noise runs
    /// of 10 s per level.
    pub fn quick() -> Self {
        Extent { push_step_n: 10.0, noise_runs: 20, noise_seconds: 10.0, ..Extent::full() }
    }
    /// Refuses a grid that cannot be laid out (push::axis's rules), naming the flags, before any policy runs.
    pub fn check(&self) -> Result<()> {
        push::axis(self.push_range_n, self.push_step_n)
            .map(|_| ())
            .with_context(|| format!("--push-range {} N with --push-step {} N", self.push_range_n, self.push_step_n))
    }
    /// The paper's push grid (±30 N), whatever its step: its mean t_fall values are comparable with ours.
    pub fn paper_push_range(&self) -> bool {
        self.push_range_n == Extent::full().push_range_n
    }
    /// One line: grid, noise runs.
    pub fn describe(&self) -> String {
        let cells = push::axis(self.push_range_n, self.push_step_n).map_or(0, |a| a.len());
        format!(
            "{cells}×{cells} push grid to ±{} N, {} noise runs of {} s per level",
            self.push_range_n, self.noise_runs, self.noise_seconds
        )
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct PolicyResults {
    /// The group: O, C or CA.
    pub name: String,
    pub policy: PathBuf,
    pub trained_on: String,
    pub tracking: Vec<TrackingRow>,
    /// The paper's push test: standing (command 0).
    pub push: PushGrid,
    /// The same grid while walking at `Extent::walking_push_command`.
    pub push_walking: Option<PushGrid>,
    pub noise: Vec<NoiseRow>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Ablation {
    pub settings: EvalSettings,
    pub extent: Extent,
    pub results: Vec<PolicyResults>,
}

/// Runs every experiment for each (group, policy file).
pub fn run(policies: &[(String, PathBuf)], settings: &EvalSettings, extent: &Extent) -> Result<Ablation> {
    ensure!(!policies.is_empty(), "give at least one policy with --o, --c or --ca");
    let mut results = Vec::new();
    for (name, path) in policies {
        let mut runner = PolicyRunner::load(path, label(name))?;
        eprintln!("{}: {} (trained on the {} model)", label(name), path.display(), runner.trained_on());
        let tracking = tracking::run(&mut runner, settings, extent.tracking_window_s, extent.tracking_transient_s)?;
        let push =
            push::run(&mut runner, settings, extent.push_range_n, extent.push_step_n, extent.push_window_s, [0.0; 3])?;
        let (range, step, window) = (extent.push_range_n, extent.push_step_n, extent.push_window_s);
        let walking = push::run(&mut runner, settings, range, step, window, extent.walking_push_command)?;
        let noise =
            noise::run(&mut runner, settings, extent.noise_runs, extent.noise_seconds, extent.noise_interval_s)?;
        results.push(PolicyResults {
            name: name.clone(),
            policy: path.clone(),
            trained_on: runner.trained_on().into(),
            tracking,
            push,
            push_walking: Some(walking),
            noise,
        });
    }
    Ok(Ablation { settings: settings.clone(), extent: extent.clone(), results })
}

/// The Markdown report: the groups' headline numbers, tracking, gait, and every policy's own row.
pub fn markdown(a: &Ablation) -> Result<String> {
    let paper = report::paper()?;
    let g = groups::group(&a.results);
    let grid_note = if a.extent.paper_push_range() {
        String::new()
    } else {
        format!(
            "Push grid to ±{} N, not the paper's ±{} N: the paper's mean t_fall beside ours and the t_fall claims \
             below are for its grid, so read them as a comparison between our groups only.\n\n",
            a.extent.push_range_n,
            Extent::full().push_range_n
        )
    };
    Ok(format!(
        "## Headline numbers\n\n{grid_note}{}\n## The paper's claims and the bars, checked\n\n{}\n## Commanded velocity \
         tracking\n{}\n## Gait\n\n{}\n## Each policy\n\n{}",
        groups::headline_markdown(&g, &paper),
        super::claims::markdown(&super::claims::check(&g)),
        groups::tracking_markdown(&g, &paper),
        groups::gait_markdown(&g),
        groups::per_policy_markdown(&a.results),
    ))
}

/// Writes ablation.{md,json}, per-policy CSVs, and each group's mean heatmaps (standing and walking) into `out`.
pub fn write(a: &Ablation, out: &Path) -> Result<()> {
    std::fs::create_dir_all(out)?;
    report::write_text(out, "ablation.md", &markdown(a)?)?;
    report::write_json(out, "ablation.json", a)?;
    let mut seen: Vec<(String, usize)> = Vec::new();
    for r in &a.results {
        // The k-th policy of a group is NAME_k (NAME alone for the first), so that seeds never overwrite each other.
        let k = match seen.iter_mut().find(|(n, _)| *n == r.name) {
            Some((_, k)) => {
                *k += 1;
                *k
            }
            None => {
                seen.push((r.name.clone(), 1));
                1
            }
        };
        let stem = if k == 1 { r.name.clone() } else { format!("{}_{k}", r.name) };
        report::write_text(out, &format!("{stem}_tracking.csv"), &report::tracking_csv(&r.tracking))?;
        report::write_text(out, &format!("{stem}_push.csv"), &report::push_csv(&r.push))?;
        if let Some(w) = &r.push_walking {
            report::write_text(out, &format!("{stem}_push_walking.csv"), &report::push_csv(w))?;
        }
        report::write_text(out, &format!("{stem}_noise.csv"), &report::noise_csv(&r.noise))?;
    }
    let g = groups::group(&a.results);
    let mean = |walking: bool| -> Vec<(String, PushGrid)> {
        g.iter()
            .filter_map(|grp| {
                let grids =
                    grp.members.iter().filter_map(|r| if walking { r.push_walking.as_ref() } else { Some(&r.push) });
                let n = grp.members.len();
                let mut title = label(grp.name).to_string();
                if walking {
                    let c = a.extent.walking_push_command;
                    title += &format!(
                        ", walking {}",
                        if c[1] == 0.0 && c[2] == 0.0 { format!("{} m/s", c[0]) } else { format!("{c:?}") }
                    );
                }
                if n > 1 {
                    title += &format!(" (mean of {n})");
                }
                groups::mean_grid(grids).map(|m| (title, m))
            })
            .collect()
    };
    for (walking, stem) in [(false, "heatmaps"), (true, "heatmaps_walking")] {
        let grids = mean(walking);
        if grids.is_empty() {
            continue;
        }
        let refs: Vec<(String, &PushGrid)> = grids.iter().map(|(n, g)| (n.clone(), g)).collect();
        crate::plots::push_heatmaps(&refs, &out.join(format!("{stem}.png")), &out.join(format!("{stem}.svg")))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_grid_flags_are_checked_and_described() {
        let full = Extent::full();
        full.check().unwrap();
        assert!(full.paper_push_range());
        assert_eq!(full.describe(), "13×13 push grid to ±30 N, 100 noise runs of 20 s per level");
        assert!(Extent::quick().describe().starts_with("7×7 push grid to ±30 N"));
        let strong = Extent { push_range_n: 60.0, push_step_n: 10.0, ..Extent::full() };
        assert!(!strong.paper_push_range());
        assert!(strong.describe().starts_with("13×13 push grid to ±60 N"));
        let zero_step = Extent { push_step_n: 0.0, ..Extent::full() };
        assert!(zero_step.check().unwrap_err().to_string().contains("--push-step"));
        let negative = Extent { push_range_n: -1.0, ..Extent::full() };
        assert!(negative.check().unwrap_err().to_string().contains("--push-range"));
        let uneven = Extent { push_range_n: 25.0, push_step_n: 10.0, ..Extent::full() };
        assert!(format!("{:#}", uneven.check().unwrap_err()).contains("not a multiple"));
    }
}
