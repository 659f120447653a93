//! The paper's published numbers (data/paper_tables.toml, typed in from the paper) and the Markdown tables that
//! put ours beside them; result files (JSON, CSV) written atomically.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use super::results::{Group, NoiseRow, PushGrid, RunCounts, TrackingRow, COMMANDS};
use crate::error::{Error, Result};

const PAPER_TOML: &str = include_str!("../../data/paper_tables.toml");

/// A group's paper name for its key ("CA" → "C+A"); other names as they are.
fn label(p: &str) -> &str {
    match Group::from_key(p) {
        Some(g) => g.label(),
        None => p,
    }
}

#[derive(Debug, Clone, Default)]
pub struct PaperTables {
    /// command key → policy → [MAE, τ̄, roll, pitch, fell (0/1)].
    pub tracking: BTreeMap<String, BTreeMap<String, [f64; 5]>>,
    pub push_mean_t_fall: BTreeMap<String, f64>,
    pub noise_success: BTreeMap<String, Vec<f64>>,
    /// The real robot's course time per group, minutes (O did not finish).
    pub course_minutes: BTreeMap<String, f64>,
    /// Minutes C+A ran without an intervention in public demonstrations.
    pub continuous_minutes_ca: f64,
}

/// The paper's tables for a report on policies trained on `robots` (spec names): TopA's numbers belong beside
/// TopA's policies only (O on its serial model, C and C+A on its closed chain); beside another robot's they would
/// read as that robot's targets. None for any other robot.
pub fn paper_for<'a>(robots: impl IntoIterator<Item = &'a str>) -> Result<Option<PaperTables>> {
    if robots.into_iter().all(|r| matches!(r, "topa_closed" | "topa_open")) {
        paper().map(Some)
    } else {
        Ok(None)
    }
}

pub fn paper() -> Result<PaperTables> {
    let v: toml::Value = toml::from_str(PAPER_TOML).map_err(|e| Error::file("data/paper_tables.toml", e))?;
    // The table is compiled in and checked by the tests: a missing entry is a broken build, named by its key.
    let missing = |key: &str| Error::bad_file(format!("data/paper_tables.toml: {key} is missing"));
    let mut t = PaperTables::default();
    for (key, _, _) in COMMANDS {
        let row = &v["tracking"][key];
        let mut per = BTreeMap::new();
        for p in Group::ALL.map(Group::key) {
            let a = row[p].as_array().ok_or_else(|| missing("tracking row"))?;
            let num = |i: usize| a[i].as_float().or_else(|| a[i].as_integer().map(|x| x as f64)).unwrap_or(f64::NAN);
            per.insert(
                p.to_string(),
                [num(0), num(1), num(2), num(3), if a[4].as_bool() == Some(true) { 1.0 } else { 0.0 }],
            );
        }
        t.tracking.insert(key.to_string(), per);
    }
    for (p, x) in v["push"]["mean_time_to_fall_s"].as_table().ok_or_else(|| missing("push"))? {
        t.push_mean_t_fall.insert(p.clone(), x.as_float().unwrap_or(f64::NAN));
    }
    for (p, x) in v["command_noise"]["success_pct"].as_table().ok_or_else(|| missing("noise"))? {
        let vals = x
            .as_array()
            .ok_or_else(|| missing("noise row"))?
            .iter()
            .map(|y| y.as_integer().map_or(f64::NAN, |i| i as f64))
            .collect();
        t.noise_success.insert(p.clone(), vals);
    }
    let rw = &v["real_world"];
    for (p, x) in rw["course_minutes"].as_table().ok_or_else(|| missing("real_world.course_minutes"))? {
        t.course_minutes.insert(p.clone(), x.as_float().unwrap_or(f64::NAN));
    }
    t.continuous_minutes_ca = rw["continuous_operation_min_CA"]
        .as_integer()
        .ok_or_else(|| missing("real_world.continuous_operation_min_CA"))? as f64;
    Ok(t)
}

fn fmt(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "–".into()
    }
}

fn with_paper(ours: String, paper: Option<String>) -> String {
    match paper {
        Some(p) => format!("{ours} ({p})"),
        None => ours,
    }
}

/// The tracking table for one or more policies. Cells read "ours (paper)" where the paper has the column; the
/// summed MAE is the paper-comparable definition (see `tracking.rs`); a fall is marked with *, as in the paper.
pub fn tracking_markdown(results: &[(&str, &[TrackingRow])], paper: Option<&PaperTables>) -> String {
    let mut s = String::new();
    for (ci, (key, title, _)) in COMMANDS.iter().enumerate() {
        let _ = writeln!(s, "\n**{title}**\n");
        let _ = writeln!(
            s,
            "| Policy | MAE v_x / v_y / w_z | v_x,y, w_z MAE (sum) | steady MAE (ours) | falls | stood still | τ̄ (N·m) | θ̄_roll (rad) | θ̄_pitch (rad) |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|---:|");
        for (name, rows) in results {
            let r = &rows[ci];
            let p = paper.and_then(|t| t.tracking.get(*key)).and_then(|m| m.get(*name));
            let star = if r.fell { "*" } else { "" };
            let pstar = |p: &[f64; 5]| if p[4] > 0.5 { "*" } else { "" };
            let w = r.mae_whole;
            let n = RunCounts::of([r]);
            let _ = writeln!(
                s,
                "| {}{star} | {} / {} / {} | {} | {} | {} | {} | {} | {} | {} |",
                label(name),
                fmt(w[0], 2),
                fmt(w[1], 2),
                fmt(w[2], 2),
                with_paper(fmt(r.mae_paper, 2), p.map(|p| format!("{}{}", fmt(p[0], 2), pstar(p)))),
                fmt(r.mae, 3),
                n.falls_cell(),
                n.still_cell(),
                with_paper(fmt(r.mean_torque, 2), p.map(|p| fmt(p[1], 2))),
                with_paper(fmt(r.mean_roll, 2), p.map(|p| fmt(p[2], 2))),
                with_paper(fmt(r.mean_pitch, 2), p.map(|p| fmt(p[3], 2))),
            );
        }
    }
    let _ = writeln!(
        s,
        "\n\\* fell (from at least one start). Cells: ours (paper). Per-component MAE, their sum, τ̄ and θ̄ over the \
         whole window from the command's start, continuing after a fall (the paper-comparable definition); steady \
         MAE: the mean of the three components after 2 s, up to a fall; each the mean over the command's starts \
         (initial states). Stood still: starts whose mean velocity along the command stayed below a quarter of it."
    );
    s
}

/// The gait of every policy on every tracking command.
pub fn gait_markdown(results: &[(&str, &[TrackingRow])]) -> String {
    let mut s = String::from(
        "| Policy | command | steps/s per foot | air time (s) | clearance (cm) | slip (cm per stance) | double support | base height (m) |\n|---|---|---:|---:|---:|---:|---:|---:|\n",
    );
    for (name, rows) in results {
        for r in rows.iter() {
            let g = &r.gait;
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} |",
                label(name),
                r.key,
                fmt(g.steps_per_s, 2),
                fmt(g.air_time_s, 3),
                fmt(100.0 * g.clearance_m, 1),
                fmt(100.0 * g.slip_per_stance_m, 2),
                fmt(g.double_support, 2),
                fmt(g.base_height_m, 3),
            );
        }
    }
    let _ = writeln!(
        s,
        "\nAfter the first 2 s of each command, up to a fall. A step is a touchdown after ≥ 1 policy step in the \
         air; clearance is the sole centre's highest point in a swing; slip the sole centre's horizontal travel \
         while in contact."
    );
    s
}

pub fn push_markdown(results: &[(&str, &PushGrid)], paper: Option<&PaperTables>) -> String {
    let mut s = String::from("| Policy | mean t_fall (s) | cells without a fall |\n|---|---:|---:|\n");
    for (name, g) in results {
        let p = paper.and_then(|t| t.push_mean_t_fall.get(*name)).map(|x| fmt(*x, 2));
        let standing = g.t_fall.iter().filter(|&&t| t >= g.window_s).count();
        let _ =
            writeln!(s, "| {} | {} | {standing}/{} |", label(name), with_paper(fmt(g.mean_t_fall(), 2), p), g.cells());
    }
    let _ = writeln!(
        s,
        "\nConstant torso force in the torso frame, window {} s. Cells: ours (paper).",
        results.first().map_or(10.0, |r| r.1.window_s)
    );
    s
}

pub fn noise_markdown(results: &[(&str, &[NoiseRow])], paper: Option<&PaperTables>) -> String {
    let mut s = String::from("| Policy | σ_v (m/s) | σ_wz (rad/s) | success (%) |\n|---|---:|---:|---:|\n");
    for (name, rows) in results {
        for (i, r) in rows.iter().enumerate() {
            let p = paper.and_then(|t| t.noise_success.get(*name)).and_then(|v| v.get(i)).map(|x| fmt(*x, 0));
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} |",
                label(name),
                r.sigma_v,
                r.sigma_wz,
                with_paper(fmt(r.success_pct, 0), p)
            );
        }
    }
    let runs = results.first().and_then(|r| r.1.first()).map_or(0, |r| r.runs);
    let _ =
        writeln!(s, "\nWalk forward at 0.5 m/s with Gaussian command noise, {runs} runs per row. Cells: ours (paper).");
    s
}

/// Writes `value` as pretty JSON to `dir/name`.
pub fn write_json<T: Serialize>(dir: &Path, name: &str, value: &T) -> Result<()> {
    Ok(trainer::tensorfile::write_atomic(&dir.join(name), serde_json::to_string_pretty(value)?.as_bytes())?)
}

pub fn tracking_csv(rows: &[TrackingRow]) -> String {
    let mut s = String::from(
        "command,v_x,v_y,w_z,mae_vx,mae_vy,mae_wz,mae_paper,mae_steady,mae_steady_vx,mae_steady_vy,mae_steady_wz,\
         mean_torque,mean_roll,mean_pitch,fell,fell_at_s,steps_per_s,air_time_s,clearance_m,slip_per_stance_m,\
         double_support,base_height_m,starts,falls,stood_still\n",
    );
    for r in rows {
        let (w, c, g) = (r.mae_whole, r.mae_components, &r.gait);
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.key,
            r.command[0],
            r.command[1],
            r.command[2],
            w[0],
            w[1],
            w[2],
            r.mae_paper,
            r.mae,
            c[0],
            c[1],
            c[2],
            r.mean_torque,
            r.mean_roll,
            r.mean_pitch,
            r.fell,
            r.fell_at.map_or(String::new(), |t| t.to_string()),
            g.steps_per_s,
            g.air_time_s,
            g.clearance_m,
            g.slip_per_stance_m,
            g.double_support,
            g.base_height_m,
            r.starts,
            r.fall_count(),
            r.stood_still.map_or(String::new(), |n| n.to_string())
        );
    }
    s
}

pub fn push_csv(g: &PushGrid) -> String {
    let mut s = String::from("f_x_n,f_y_n,t_fall_s\n");
    for c in 0..g.cells() {
        let f = g.force(c);
        let _ = writeln!(s, "{},{},{}", f[0], f[1], g.t_fall[c]);
    }
    s
}

pub fn noise_csv(rows: &[NoiseRow]) -> String {
    let mut s = String::from("sigma_v,sigma_wz,runs,successes,success_pct\n");
    for r in rows {
        let _ = writeln!(s, "{},{},{},{},{}", r.sigma_v, r.sigma_wz, r.runs, r.successes, r.success_pct);
    }
    s
}

pub fn write_text(dir: &Path, name: &str, text: &str) -> Result<()> {
    Ok(trainer::tensorfile::write_atomic(&dir.join(name), text.as_bytes())?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_tables_parse_with_the_published_values() {
        let p = paper().unwrap();
        assert_eq!(p.tracking["walk_forward"]["CA"], [0.34, 27.04, 0.0, 0.12, 0.0]);
        assert_eq!(p.tracking["rotate_ccw"]["O"][4], 1.0);
        assert_eq!(p.push_mean_t_fall["CA"], 9.71);
        assert_eq!(p.noise_success["C"], vec![100.0, 79.0, 34.0, 12.0]);
    }
}
