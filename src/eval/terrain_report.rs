//! Terrain over groups of seeds (`topa terrain`): `eval terrain` per policy, grouped by the paper's group and by
//! the ground it was trained on (flat, or the terrain curriculum). Per group: mean success over every type ×
//! difficulty cell with its bootstrap 95 % interval (seeds resampled whole, each cell's runs redrawn), and per type
//! the hardest difficulty every seed crossed; where a group has seeds of both grounds, terrain − flat with its
//! interval and the probability of improvement.

use std::path::{Path, PathBuf};

use anyhow::{ensure, Result};
use serde::{Deserialize, Serialize};
use topa_env::policy_runner::PolicyRunner;

use super::intervals::{self, Resampling, Scores};
use super::results::Group;
use super::settings::EvalSettings;
use super::terrain::{self, TerrainResult};

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TerrainEntry {
    pub group: Group,
    pub policy: PathBuf,
    /// Its training config had `[env.terrain]` on.
    pub trained_on_terrain: bool,
    pub result: TerrainResult,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TerrainReport {
    pub levels: usize,
    pub runs: usize,
    pub window_s: f64,
    pub entries: Vec<TerrainEntry>,
}

/// Runs the terrain evaluation of every (group, policy).
pub fn run(policies: &[(Group, PathBuf)], settings: &EvalSettings, p: &terrain::Protocol) -> Result<TerrainReport> {
    ensure!(!policies.is_empty(), "give at least one policy with --o, --c or --ca");
    let (levels, runs, window_s) = (p.levels, p.runs, p.window_s);
    let mut entries = Vec::new();
    for (group, path) in policies {
        let mut r = PolicyRunner::load(path, group.label())?;
        let trained_on_terrain = r.training_config().terrain.enabled;
        eprintln!("{}: {} (trained on {})", group.label(), path.display(), ground(trained_on_terrain));
        let result = terrain::run(&mut r, settings, p)?;
        entries.push(TerrainEntry { group: *group, policy: path.clone(), trained_on_terrain, result });
    }
    Ok(TerrainReport { levels, runs, window_s, entries })
}

fn ground(on_terrain: bool) -> &'static str {
    if on_terrain {
        "terrain"
    } else {
        "flat ground"
    }
}

/// Joins reports of the same protocol (e.g. one per policy); the same policy twice is refused.
pub fn merge(files: &[PathBuf]) -> Result<TerrainReport> {
    ensure!(!files.is_empty(), "give terrain.json files to merge");
    let mut out: Option<TerrainReport> = None;
    for f in files {
        let text = std::fs::read_to_string(f).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", f.display()))?;
        let r: TerrainReport = serde_json::from_str(&text)
            .map_err(|e| anyhow::anyhow!("{} is not a terrain report (topa terrain writes one): {e}", f.display()))?;
        match &mut out {
            None => out = Some(r),
            Some(o) => {
                ensure!(
                    (o.levels, o.runs, o.window_s) == (r.levels, r.runs, r.window_s),
                    "{} was made with another protocol (levels, runs, seconds) than the first file",
                    f.display()
                );
                let tiles = |x: &TerrainReport| {
                    x.entries.first().map(|e| (e.result.terrain.types.clone(), e.result.terrain.resolution))
                };
                ensure!(
                    tiles(o) == tiles(&r) || r.entries.is_empty(),
                    "{} was made on other tiles (types or resolution) than the first file",
                    f.display()
                );
                for e in r.entries {
                    ensure!(
                        !o.entries.iter().any(|x| x.policy == e.policy),
                        "{} appears twice ({})",
                        e.policy.display(),
                        f.display()
                    );
                    o.entries.push(e);
                }
            }
        }
    }
    Ok(out.expect("at least one file"))
}

/// One row of the report: a group's seeds of one ground.
pub struct GroupRow<'a> {
    pub group: Group,
    pub on_terrain: bool,
    pub seeds: Vec<&'a TerrainResult>,
}

impl GroupRow<'_> {
    pub fn label(&self) -> String {
        if self.on_terrain {
            format!("{} (terrain)", self.group.label())
        } else {
            self.group.label().to_string()
        }
    }

    /// Success per seed and cell (type × difficulty), %, with the runs behind each.
    pub fn scores(&self) -> Scores {
        let runs = self.seeds.iter().map(|r| r.success_grid().iter().map(|c| 100.0 * c.2).collect()).collect();
        let per_cell = |r: &TerrainResult| r.cells.first().map_or(0, |c| c.runs) * terrain::COMMANDS.len();
        let trials = self.seeds.iter().map(|r| vec![per_cell(r); r.success_grid().len()]).collect();
        Scores { runs, trials: Some(trials) }
    }
}

/// The rows, in the paper's group order, flat before terrain.
pub fn rows(r: &TerrainReport) -> Vec<GroupRow<'_>> {
    let mut out = Vec::new();
    for group in Group::ALL {
        for on_terrain in [false, true] {
            let seeds: Vec<&TerrainResult> = r
                .entries
                .iter()
                .filter(|e| e.group == group && e.trained_on_terrain == on_terrain)
                .map(|e| &e.result)
                .collect();
            if !seeds.is_empty() {
                out.push(GroupRow { group, on_terrain, seeds });
            }
        }
    }
    out
}

const WHOLE: Resampling = Resampling { tasks: false };

/// The group table, then terrain − flat per group where both exist.
pub fn markdown(r: &TerrainReport) -> String {
    let rows = rows(r);
    let Some(first) = r.entries.first() else { return String::new() };
    let types = &first.result.terrain.types;
    let mut s = format!(
        "Each seed on {} terrain types × {} difficulties, walking (0.5 m/s) and turning (0.5 m/s, 0.5 rad/s) for \
         {:.0} s from each tile's centre, {} run(s) each; success = no fall. Per type: the hardest difficulty every \
         seed of the group crossed in every run (– none).\n\n| group | seeds | mean success, % [95 % CI] |",
        types.len(),
        r.levels,
        r.window_s,
        r.runs
    );
    for t in types {
        s.push_str(&format!(" {} |", t.name()));
    }
    s.push_str(&format!("\n|---|---:|---:|{}\n", "---:|".repeat(types.len())));
    for row in &rows {
        let ci = intervals::interval(&row.scores(), WHOLE, intervals::mean);
        s.push_str(&format!("| {} | {} | {} |", row.label(), row.seeds.len(), ci.show(0)));
        for &t in types {
            let hardest = row.seeds.iter().map(|r| r.hardest_walked(t)).collect::<Option<Vec<f64>>>();
            let cell = hardest.and_then(|h| h.into_iter().reduce(f64::min)).map_or("–".into(), |d| format!("{d:.2}"));
            s.push_str(&format!(" {cell} |"));
        }
        s.push('\n');
    }
    for group in Group::ALL {
        let of = |t: bool| rows.iter().find(|x| x.group == group && x.on_terrain == t);
        if let (Some(flat), Some(ter)) = (of(false), of(true)) {
            if let Some((d, p)) = intervals::compare(&ter.scores(), &flat.scores(), WHOLE) {
                let verdict = if ter.seeds.len().min(flat.seeds.len()) < intervals::MIN_RUNS_FOR_VERDICT {
                    "too few seeds to decide"
                } else {
                    match d.sign() {
                        Some(true) => "the terrain-trained seeds succeed more often",
                        Some(false) => "the terrain-trained seeds succeed less often",
                        None => "no difference the interval can tell",
                    }
                };
                s.push_str(&format!(
                    "\n{} − {}: {} percentage points, P(improvement) {} — {verdict}.\n",
                    ter.label(),
                    flat.label(),
                    d.show(0),
                    p.show(2)
                ));
            }
        }
    }
    s
}

/// Writes terrain.{md,json} and each policy's success heatmap into `out`; returns the Markdown.
pub fn write(r: &TerrainReport, out: &Path) -> Result<String> {
    std::fs::create_dir_all(out)?;
    let md = markdown(r);
    super::report::write_text(out, "terrain.md", &format!("# Terrain\n\n{md}"))?;
    super::report::write_json(out, "terrain.json", r)?;
    for e in &r.entries {
        let stem = format!(
            "{}{}-{}",
            e.group.key(),
            if e.trained_on_terrain { "-terrain" } else { "" },
            e.policy.file_stem().map_or("policy".into(), |s| s.to_string_lossy().into_owned())
        );
        let title = format!("{} {}", e.group.label(), e.policy.display());
        super::terrain_map::success_map(
            &e.result,
            &title,
            &out.join(format!("{stem}.png")),
            &out.join(format!("{stem}.svg")),
        )?;
    }
    Ok(md)
}
