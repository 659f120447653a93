//! Several policies per group (the seeds of O, C, C+A): every headline number as mean ± sd over the group's
//! policies, with the paper's value beside, and a per-policy table so that no seed hides behind a mean.

use std::fmt::Write as _;

use serde::Serialize;

use super::intervals::{self, Resampling, Scores};
use super::report::PaperTables;
use super::results::{Group, PolicyResults, PushGrid, RunCounts, COMMANDS};

/// Mean and sample standard deviation (n − 1) of the finite values among `xs` (a policy that never steps has no
/// air time: it is left out of that mean, not counted as 0); sd is 0 for a single value.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct Stat {
    pub mean: f64,
    pub sd: f64,
    pub n: usize,
}

impl Stat {
    pub fn of(xs: &[f64]) -> Stat {
        let xs: Vec<f64> = xs.iter().copied().filter(|x| x.is_finite()).collect();
        let n = xs.len();
        if n == 0 {
            return Stat { mean: f64::NAN, sd: f64::NAN, n };
        }
        let mean = xs.iter().sum::<f64>() / n as f64;
        let sd = if n > 1 { (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt() } else { 0.0 };
        Stat { mean, sd, n }
    }

    /// "m ± sd" with `digits` decimals ("m" alone for one value).
    pub fn show(&self, digits: usize) -> String {
        if !self.mean.is_finite() {
            "–".into()
        } else if self.n > 1 {
            format!("{:.digits$} ± {:.digits$}", self.mean, self.sd)
        } else {
            format!("{:.digits$}", self.mean)
        }
    }
}

/// One group's policies, in the order they were given.
pub struct GroupResults<'a> {
    pub name: Group,
    pub members: Vec<&'a PolicyResults>,
}

/// Groups in first-appearance order of their names.
pub fn group(results: &[PolicyResults]) -> Vec<GroupResults<'_>> {
    let mut out: Vec<GroupResults> = Vec::new();
    for r in results {
        match out.iter_mut().find(|g| g.name == r.name) {
            Some(g) => g.members.push(r),
            None => out.push(GroupResults { name: r.name, members: vec![r] }),
        }
    }
    out
}

impl GroupResults<'_> {
    fn stat(&self, f: impl Fn(&PolicyResults) -> f64) -> Stat {
        Stat::of(&self.members.iter().map(|r| f(r)).collect::<Vec<_>>())
    }
    pub fn t_fall_standing(&self) -> Stat {
        self.stat(|r| r.push.mean_t_fall())
    }
    pub fn noise(&self, level: usize) -> Stat {
        self.stat(|r| r.noise.get(level).map_or(f64::NAN, |n| n.success_pct))
    }
    /// Tracking runs, falls and stand-stills over all commands and policies of the group.
    pub fn tracking_counts(&self) -> RunCounts {
        RunCounts::of(self.members.iter().flat_map(|r| &r.tracking))
    }
    /// The largest per-component whole-window MAE of any command, per policy.
    pub fn worst_component(&self) -> Stat {
        self.stat(worst_component)
    }
    /// Time to fall per push-grid cell (the tasks), one row per policy; standing or walking.
    pub fn push_scores(&self, walking: bool) -> Scores {
        let grid = |r: &PolicyResults| if walking { r.push_walking.clone() } else { Some(r.push.clone()) };
        Scores { runs: self.members.iter().filter_map(|r| grid(r)).map(|g| g.t_fall).collect(), trials: None }
    }
    /// Success rate at one command-noise level, one row per policy, with the runs it counts.
    pub fn noise_scores(&self, level: usize) -> Scores {
        let rows: Vec<_> = self.members.iter().filter_map(|r| r.noise.get(level)).collect();
        Scores {
            runs: rows.iter().map(|n| vec![n.success_pct]).collect(),
            trials: Some(rows.iter().map(|n| vec![n.runs]).collect()),
        }
    }
    pub fn worst_component_scores(&self) -> Scores {
        Scores::per_run(&self.members.iter().map(|r| worst_component(r)).collect::<Vec<_>>())
    }
}

fn worst_component(r: &PolicyResults) -> f64 {
    r.tracking.iter().flat_map(|t| t.mae_whole).fold(0.0, f64::max)
}

fn paper_cell(ours: String, paper: Option<String>) -> String {
    match paper {
        Some(p) => format!("{ours} ({p})"),
        None => ours,
    }
}

/// The headline table: push (standing, walking), command noise, tracking falls, worst tracking component — each
/// as the group's mean with its bootstrap 95 % interval (`intervals`), the paper's value beside.
pub fn headline_markdown(groups: &[GroupResults], paper: Option<&PaperTables>, how: Resampling) -> String {
    let levels = groups.iter().flat_map(|g| g.members.iter().map(|r| r.noise.len())).max().unwrap_or(0);
    let mut s = String::from("| Group | policies | mean t_fall standing (s) | mean t_fall walking v_x = 0.5 (s) |");
    for i in 0..levels {
        let _ = write!(s, " noise level {} success (%) |", i + 1);
    }
    s.push_str(" tracking falls | tracking stand-stills | worst component MAE |\n|---|---:|---:|---:|");
    s.push_str(&"---:|".repeat(levels + 3));
    s.push('\n');
    let per_seed = Resampling { tasks: false };
    for g in groups {
        let p = paper.and_then(|t| t.push_mean_t_fall.get(g.name.key())).map(|x| format!("{x:.2}"));
        let _ = write!(
            s,
            "| {} | {} | {} | {} |",
            g.name.label(),
            g.members.len(),
            paper_cell(intervals::interval(&g.push_scores(false), how, intervals::mean).show(2), p),
            intervals::interval(&g.push_scores(true), how, intervals::mean).show(2)
        );
        for i in 0..levels {
            let p =
                paper.and_then(|t| t.noise_success.get(g.name.key())).and_then(|v| v.get(i)).map(|x| format!("{x:.0}"));
            let ours = intervals::interval(&g.noise_scores(i), per_seed, intervals::mean).show(0);
            let _ = write!(s, " {} |", paper_cell(ours, p));
        }
        let n = g.tracking_counts();
        let worst = intervals::interval(&g.worst_component_scores(), per_seed, intervals::mean).show(3);
        let _ = writeln!(s, " {} | {} | {worst} |", n.falls_cell(), n.still_cell());
    }
    let _ = writeln!(
        s,
        "\nmean over each group's policies [95 % confidence interval: bootstrap over the group's seeds{}, {} \
         replicates; noise success redrawn from its runs]{}. Tracking falls and stand-stills: runs (each of the six commands from \
         each initial state) that fell, or whose mean velocity along the command stayed below a quarter of it, over \
         all the group's policies; worst component MAE: the largest of the three per-component errors (whole \
         window, mean over the starts) over the six commands, per policy.",
        if how.tasks { " and the grid's cells (a sample of the paper's grid)" } else { "" },
        intervals::REPLICATES,
        if paper.is_some() { "; cells: ours (paper)" } else { "" }
    );
    s
}

/// Each group's mean and interquartile mean (IQM) of every score, with their 95 % intervals: the IQM discounts
/// the best and worst quarter of the seed × cell scores (rliable's robust aggregate).
pub fn intervals_markdown(groups: &[GroupResults], how: Resampling) -> String {
    let mut s = String::from("| Group | measure | mean [95 % CI] | IQM [95 % CI] |\n|---|---|---:|---:|\n");
    let per_seed = Resampling { tasks: false };
    for g in groups {
        let levels = g.members.iter().map(|r| r.noise.len()).min().unwrap_or(0);
        let mut rows = vec![
            ("t_fall standing (s)", g.push_scores(false), how, 2),
            ("t_fall walking (s)", g.push_scores(true), how, 2),
        ];
        rows.extend((0..levels).map(|i| ("", g.noise_scores(i), per_seed, 0)));
        for (k, (name, scores, h, d)) in rows.into_iter().enumerate() {
            let name = if name.is_empty() { format!("noise level {} success (%)", k - 1) } else { name.into() };
            let _ = writeln!(
                s,
                "| {} | {name} | {} | {} |",
                g.name.label(),
                intervals::interval(&scores, h, intervals::mean).show(d),
                intervals::interval(&scores, h, intervals::iqm).show(d)
            );
        }
    }
    s
}

/// Tracking per command and group: per-component MAE, their sum (the paper's column), falls, τ̄, roll, pitch.
pub fn tracking_markdown(groups: &[GroupResults], paper: Option<&PaperTables>) -> String {
    let mut s = String::new();
    for (ci, (key, title, _)) in COMMANDS.iter().enumerate() {
        let _ = writeln!(s, "\n**{title}**\n");
        s.push_str(
            "| Group | MAE v_x | MAE v_y | MAE w_z | MAE sum | falls | stood still | τ̄ (N·m) | θ̄_roll (rad) | θ̄_pitch (rad) |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        for g in groups {
            let row = |f: &dyn Fn(&super::results::TrackingRow) -> f64| g.stat(|r| f(&r.tracking[ci]));
            let p = paper.and_then(|t| t.tracking.get(*key)).and_then(|m| m.get(g.name.key()));
            let pf =
                |i: usize, d: usize| p.map(|p| format!("{:.d$}{}", p[i], if i == 0 && p[4] > 0.5 { "*" } else { "" }));
            let n = RunCounts::of(g.members.iter().map(|r| &r.tracking[ci]));
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                g.name.label(),
                row(&|t| t.mae_whole[0]).show(3),
                row(&|t| t.mae_whole[1]).show(3),
                row(&|t| t.mae_whole[2]).show(3),
                paper_cell(row(&|t| t.mae_paper).show(2), pf(0, 2)),
                n.falls_cell(),
                n.still_cell(),
                paper_cell(row(&|t| t.mean_torque).show(1), pf(1, 2)),
                paper_cell(row(&|t| t.mean_roll).show(2), pf(2, 2)),
                paper_cell(row(&|t| t.mean_pitch).show(2), pf(3, 2)),
            );
        }
    }
    let _ = writeln!(
        s,
        "\nWhole window from the command's start, continuing after a fall (the paper-comparable definition), mean \
         over each policy's starts; MAE sum = |v_x| + |v_y| + |w_z| errors, the paper's column (* there: fell). \
         mean ± sd over the group; falls and stand-stills counted over the group's runs (policies × starts)."
    );
    s
}

/// The gait of each group on each command, mean ± sd over its policies.
pub fn gait_markdown(groups: &[GroupResults]) -> String {
    let mut s = String::from(
        "| Group | command | steps/s per foot | air time (s) | clearance (cm) | slip (cm per stance) | double support | base height (m) |\n\
         |---|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for g in groups {
        for (ci, (key, _, _)) in COMMANDS.iter().enumerate() {
            let st = |f: &dyn Fn(&super::gait::GaitStats) -> f64| g.stat(|r| f(&r.tracking[ci].gait));
            let _ = writeln!(
                s,
                "| {} | {key} | {} | {} | {} | {} | {} | {} |",
                g.name.label(),
                st(&|x| x.steps_per_s).show(2),
                st(&|x| x.air_time_s).show(3),
                st(&|x| 100.0 * x.clearance_m).show(1),
                st(&|x| 100.0 * x.slip_per_stance_m).show(2),
                st(&|x| x.double_support).show(2),
                st(&|x| x.base_height_m).show(3),
            );
        }
    }
    let _ = writeln!(
        s,
        "\nAfter the first 2 s of each command, up to a fall; mean ± sd over the group (a policy that never steps \
         has no air time or clearance and is left out of those two means)."
    );
    s
}

/// Every policy's headline numbers, one row each.
pub fn per_policy_markdown(results: &[PolicyResults]) -> String {
    let mut s = String::from(
        "| Group | policy | t_fall standing (s) | t_fall walking (s) | noise success (%) | tracking falls | stand-stills | worst component MAE | gait at 0.5 m/s: steps/s, air (s), clearance (cm) |\n\
         |---|---|---:|---:|---|---:|---:|---:|---|\n",
    );
    for r in results {
        let noise: Vec<String> = r.noise.iter().map(|n| format!("{:.0}", n.success_pct)).collect();
        let fwd = r.tracking.iter().find(|t| t.key == "walk_forward").map(|t| &t.gait);
        let n = RunCounts::of(&r.tracking);
        let gait = fwd.map_or("–".into(), |g| {
            format!("{:.2}, {:.3}, {:.1}", g.steps_per_s, g.air_time_s, 100.0 * g.clearance_m)
        });
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {} | {} | {} | {} | {:.3} | {gait} |",
            r.name.label(),
            r.policy.display(),
            r.push.mean_t_fall(),
            r.push_walking.as_ref().map_or("–".into(), |p| format!("{:.2}", p.mean_t_fall())),
            noise.join(" / "),
            n.falls_cell(),
            n.still_cell(),
            worst_component(r),
        );
    }
    s
}

/// The cell-wise mean of a group's push grids (for one heatmap per group).
pub fn mean_grid<'a>(grids: impl Iterator<Item = &'a PushGrid>) -> Option<PushGrid> {
    let grids: Vec<&PushGrid> = grids.collect();
    let first = *grids.first()?;
    let mut t = vec![0.0; first.t_fall.len()];
    for g in &grids {
        if g.axis != first.axis {
            return None;
        }
        for (a, b) in t.iter_mut().zip(&g.t_fall) {
            *a += b / grids.len() as f64;
        }
    }
    Some(PushGrid { t_fall: t, ..first.clone() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stat_is_the_mean_and_sample_sd() {
        let s = Stat::of(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]);
        assert!((s.mean - 5.0).abs() < 1e-12);
        assert!((s.sd - (32.0f64 / 7.0).sqrt()).abs() < 1e-12);
        assert_eq!(s.show(1), "5.0 ± 2.1");
        assert_eq!(Stat::of(&[3.0]).show(2), "3.00");
        assert_eq!(Stat::of(&[]).show(2), "–");
        assert_eq!(Stat::of(&[f64::NAN, 1.0, 3.0]), Stat { mean: 2.0, sd: 2f64.sqrt(), n: 2 });
    }

    #[test]
    fn mean_grid_averages_cells_and_refuses_other_axes() {
        let g = |t: Vec<f64>, axis: Vec<f64>| PushGrid { axis, t_fall: t, window_s: 10.0, command: [0.0; 3] };
        let a = g(vec![10.0, 2.0, 4.0, 6.0], vec![-1.0, 1.0]);
        let b = g(vec![0.0, 4.0, 4.0, 10.0], vec![-1.0, 1.0]);
        assert_eq!(mean_grid([&a, &b].into_iter()).unwrap().t_fall, vec![5.0, 3.0, 4.0, 8.0]);
        let c = g(vec![0.0; 4], vec![-2.0, 2.0]);
        assert!(mean_grid([&a, &c].into_iter()).is_none());
    }
}
