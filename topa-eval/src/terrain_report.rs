//! Terrain over groups of seeds (`topa terrain`): `eval terrain` per policy, grouped by the paper's group and by
//! the ground it was trained on (flat, or the terrain curriculum) and whether it sees a height scan. Per group:
//! mean success over every type × difficulty cell with its bootstrap 95 % interval (seeds resampled whole, each
//! cell's runs redrawn), and per type the hardest difficulty every seed crossed; where a group has seeds of both
//! grounds, terrain − flat, and of both senses on terrain, height scan − blind, each with its interval and the
//! probability of improvement.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use topa_env::policy_runner::PolicyRunner;

use super::intervals::{self, Resampling, Scores};
use super::results::Group;
use super::settings::EvalSettings;
use super::terrain::{self, TerrainResult};
use crate::error::{ensure, Result};
use crate::merge::Mergeable;

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TerrainEntry {
    pub group: Group,
    pub policy: PathBuf,
    /// CRC-32 of the weights measured (as in `PolicyResults`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weights_crc32: Option<u32>,
    /// Its training config had `[env.terrain]` on.
    pub trained_on_terrain: bool,
    /// Its observation has `[env.height_scan]` (absent in reports written before scans were told apart: blind).
    #[serde(default)]
    pub height_scan: bool,
    pub result: TerrainResult,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TerrainReport {
    pub levels: usize,
    pub runs: usize,
    pub window_s: f64,
    /// The evaluation settings (absent in reports written before they were recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settings: Option<EvalSettings>,
    pub entries: Vec<TerrainEntry>,
}

/// Runs the terrain evaluation of every (group, policy).
pub fn run(policies: &[(Group, PathBuf)], settings: &EvalSettings, p: &terrain::Protocol) -> Result<TerrainReport> {
    ensure!(!policies.is_empty(), "give at least one policy with --o, --c or --ca");
    let (levels, runs, window_s) = (p.levels, p.runs, p.window_s);
    let mut entries = Vec::new();
    for (group, path) in policies {
        let mut r = PolicyRunner::load(path, group.label())?;
        let (trained_on_terrain, height_scan) =
            (r.training_config().terrain.enabled, r.training_config().height_scan.enabled);
        let sense = if height_scan { ", with a height scan" } else { "" };
        eprintln!("{}: {} (trained on {}{sense})", group.label(), path.display(), ground(trained_on_terrain));
        let result = terrain::run(&mut r, settings, p)?;
        let weights_crc32 = Some(r.policy.meta.weights_crc32);
        let policy = path.clone();
        entries.push(TerrainEntry { group: *group, policy, weights_crc32, trained_on_terrain, height_scan, result });
    }
    Ok(TerrainReport { levels, runs, window_s, settings: Some(settings.clone()), entries })
}

fn ground(on_terrain: bool) -> &'static str {
    if on_terrain {
        "terrain"
    } else {
        "flat ground"
    }
}

/// Joins terrain reports of the same protocol and settings (`--merge`, the rule of every report:
/// `crate::merge`), e.g. one per policy.
pub fn merge(files: &[PathBuf]) -> Result<TerrainReport> {
    crate::merge::merge(files)
}

/// Reads a terrain.json (to attach to an ablation).
pub fn load(file: &Path) -> Result<TerrainReport> {
    crate::merge::read(file, "--terrain")
}

impl Mergeable for TerrainReport {
    const FILE: &'static str = "terrain.json";
    const COMMAND: &'static str = "topa terrain";

    fn protocol(&self) -> (serde_json::Value, String) {
        // The tiles are the terrain's, recorded in each result.
        let tiles = self.entries.first().map(|e| {
            let t = &e.result.terrain;
            (t.types.clone(), t.resolution, t.contacts)
        });
        let key = serde_json::json!([self.levels, self.runs, self.window_s, tiles]);
        let text = format!(
            "{} levels, {} runs, {} s; tiles {}",
            self.levels,
            self.runs,
            self.window_s,
            tiles.map_or("none".into(), |(types, r, c)| format!("{types:?} at {r} m, {c:?} contacts"))
        );
        (key, text)
    }

    fn settings(&self) -> Option<&EvalSettings> {
        self.settings.as_ref()
    }

    fn measured(&self) -> Vec<(PathBuf, Option<u32>)> {
        self.entries.iter().map(|e| (e.policy.clone(), e.weights_crc32)).collect()
    }

    fn absorb(&mut self, part: TerrainReport) -> Result<()> {
        self.entries.extend(part.entries);
        Ok(())
    }
}

/// One row of the report: a group's seeds of one ground and one sense.
pub struct GroupRow<'a> {
    pub group: Group,
    pub on_terrain: bool,
    pub height_scan: bool,
    pub seeds: Vec<&'a TerrainResult>,
}

impl GroupRow<'_> {
    pub fn label(&self) -> String {
        match (self.on_terrain, self.height_scan) {
            (false, false) => self.group.label().to_string(),
            (true, false) => format!("{} (terrain)", self.group.label()),
            (false, true) => format!("{} (height scan)", self.group.label()),
            (true, true) => format!("{} (terrain, height scan)", self.group.label()),
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

/// The rows, in the paper's group order, flat before terrain, blind before the height scan.
pub fn rows(r: &TerrainReport) -> Vec<GroupRow<'_>> {
    let mut out = Vec::new();
    for group in Group::ALL {
        for (on_terrain, height_scan) in [(false, false), (false, true), (true, false), (true, true)] {
            let seeds: Vec<&TerrainResult> = r
                .entries
                .iter()
                .filter(|e| e.group == group && e.trained_on_terrain == on_terrain && e.height_scan == height_scan)
                .map(|e| &e.result)
                .collect();
            if !seeds.is_empty() {
                out.push(GroupRow { group, on_terrain, height_scan, seeds });
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
        let of = |terrain: bool, scan: bool| {
            rows.iter().find(|x| x.group == group && x.on_terrain == terrain && x.height_scan == scan)
        };
        let pairs = [
            (of(true, false), of(false, false), "the terrain-trained seeds"),
            (of(true, true), of(true, false), "the seeds with the height scan"),
        ];
        for (better, base, who) in pairs {
            let (Some(better), Some(base)) = (better, base) else { continue };
            s.push_str(&comparison(better, base, who));
        }
    }
    s
}

/// `better − base` with its interval, the probability of improvement and the verdict (`who` succeed more often).
fn comparison(better: &GroupRow, base: &GroupRow, who: &str) -> String {
    let Some((d, p)) = intervals::compare(&better.scores(), &base.scores(), WHOLE) else { return String::new() };
    let verdict = if better.seeds.len().min(base.seeds.len()) < intervals::MIN_RUNS_FOR_VERDICT {
        "too few seeds to decide".to_string()
    } else {
        match d.sign() {
            Some(true) => format!("{who} succeed more often"),
            Some(false) => format!("{who} succeed less often"),
            None => "no difference the interval can tell".to_string(),
        }
    };
    format!(
        "\n{} − {}: {} percentage points, P(improvement) {} — {verdict}.\n",
        better.label(),
        base.label(),
        d.show(0),
        p.show(2)
    )
}

/// Writes terrain.{md,json} and each policy's success heatmap into `out`; returns the Markdown.
pub fn write(r: &TerrainReport, out: &Path) -> Result<String> {
    std::fs::create_dir_all(out).map_err(crate::error::Error::io("creating", out))?;
    let md = markdown(r);
    super::report::write_text(out, "terrain.md", &format!("# Terrain\n\n{md}"))?;
    super::report::write_json(out, "terrain.json", r)?;
    for e in &r.entries {
        let stem = format!(
            "{}{}{}-{}",
            e.group.key(),
            if e.trained_on_terrain { "-terrain" } else { "" },
            if e.height_scan { "-scan" } else { "" },
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_with_a_height_scan_form_their_own_row_and_are_compared_with_the_blind_ones() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/results/terrain/terrain.json");
        let mut r = merge(&[path]).unwrap();
        let blind: Vec<TerrainEntry> =
            r.entries.iter().filter(|e| e.group == Group::C && e.trained_on_terrain).cloned().collect();
        assert_eq!(blind.len(), 2, "the shipped report has two terrain C seeds");
        let before = markdown(&r);
        assert!(!before.contains("height scan"), "{before}");
        // The same results as if from scan policies: a row of their own, and a difference of zero.
        r.entries.extend(blind.into_iter().map(|mut e| {
            e.height_scan = true;
            e.policy = e.policy.with_file_name(format!("scan-{}", e.policy.file_name().unwrap().to_string_lossy()));
            e
        }));
        let rows = rows(&r);
        let scan = rows.iter().find(|x| x.height_scan).expect("a scan row");
        assert_eq!((scan.label().as_str(), scan.seeds.len()), ("C (terrain, height scan)", 2));
        let md = markdown(&r);
        let line = md.lines().find(|l| l.starts_with("C (terrain, height scan) − C (terrain):")).expect(&md);
        assert!(line.contains(": +0 [") || line.contains(": 0 [") || line.contains(": -0 ["), "{line}");
        assert!(line.contains("P(improvement) 0.50") && line.contains("too few seeds to decide"), "{line}");
    }
}
