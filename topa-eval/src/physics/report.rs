//! The perturbation report over groups of seeds: every policy through the matrix, each group's score (share of
//! the perturbed cases survived) with its bootstrap 95 % interval (seeds resampled whole), the paper's ordering
//! O < C < C+A checked on it, the case × policy table and the cases that break more than one seed.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use topa_env::policy_runner::PolicyRunner;

use super::matrix::Matrix;
use super::{CaseResult, PhysicsResult, Protocol};
use crate::claims::MAX_COMPONENT_MAE;
use crate::error::{ensure, Error, Result};
use crate::intervals::{self, Resampling, Scores};
use crate::merge::Mergeable;
use crate::results::Group;
use crate::settings::EvalSettings;

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhysicsEntry {
    pub group: Group,
    pub policy: PathBuf,
    /// CRC-32 of the weights measured (as in `PolicyResults`).
    pub weights_crc32: Option<u32>,
    pub result: PhysicsResult,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhysicsReport {
    pub protocol: Protocol,
    pub matrix: Matrix,
    pub settings: EvalSettings,
    pub entries: Vec<PhysicsEntry>,
    /// The smallest perturbation that flips each failed case (`--fragility`), if searched.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fragility: Vec<super::fragility::Flip>,
}

/// Runs every (group, policy) through the matrix; every policy is checked against the matrix first, so that a
/// case that cannot run on one of them fails before any runs.
pub fn run(policies: &[(Group, PathBuf)], s: &EvalSettings, m: &Matrix, p: &Protocol) -> Result<PhysicsReport> {
    ensure!(!policies.is_empty(), "give at least one policy with --o, --c or --ca");
    let mut runners = Vec::new();
    for (group, path) in policies {
        let r = PolicyRunner::load(path, group.label())?;
        m.check(s, r.policy.meta.policy_dt).map_err(|e| Error::file(format!("policy {}", path.display()), e))?;
        runners.push(r);
    }
    let mut entries = Vec::new();
    for ((group, path), mut r) in policies.iter().zip(runners) {
        eprintln!("{}: {}", group.label(), path.display());
        let result = super::run(&mut r, s, m, p)?;
        let weights_crc32 = Some(r.policy.meta.weights_crc32);
        entries.push(PhysicsEntry { group: *group, policy: path.clone(), weights_crc32, result });
    }
    Ok(PhysicsReport { protocol: p.clone(), matrix: m.clone(), settings: s.clone(), entries, fragility: Vec::new() })
}

/// Joins physics reports of the same protocol, matrix and settings (`--merge`, the rule of every report:
/// `crate::merge`), e.g. one per policy.
pub fn merge(files: &[PathBuf]) -> Result<PhysicsReport> {
    crate::merge::merge(files)
}

/// Reads a physics.json (to attach to an ablation).
pub fn load(file: &Path) -> Result<PhysicsReport> {
    crate::merge::read(file, "--physics")
}

impl Mergeable for PhysicsReport {
    const FILE: &'static str = "physics.json";
    const COMMAND: &'static str = "topa physics";

    fn protocol(&self) -> (serde_json::Value, String) {
        let key = serde_json::json!([self.protocol, self.matrix.expand()]);
        (key, format!("{}; matrix {}", self.protocol.describe(), self.matrix.source))
    }

    fn settings(&self) -> Option<&EvalSettings> {
        Some(&self.settings)
    }

    fn measured(&self) -> Vec<(PathBuf, Option<u32>)> {
        self.entries.iter().map(|e| (e.policy.clone(), e.weights_crc32)).collect()
    }

    fn absorb(&mut self, part: PhysicsReport) -> Result<()> {
        self.entries.extend(part.entries);
        self.fragility.extend(part.fragility);
        Ok(())
    }

    fn finish(&mut self) {
        self.entries.sort_by_key(|e| e.group);
    }
}

const WHOLE: Resampling = Resampling { tasks: false };

/// Each seed of `group`: 100 where a perturbed case meets `held`, else 0.
pub fn scores(r: &PhysicsReport, group: Group, held: fn(&CaseResult) -> bool) -> Scores {
    let runs = r
        .entries
        .iter()
        .filter(|e| e.group == group)
        .map(|e| e.result.perturbed().iter().map(|c| if held(c) { 100.0 } else { 0.0 }).collect())
        .collect();
    Scores { runs, trials: None }
}

/// A measure of the report: its name and whether a case meets it.
type Measure = (&'static str, fn(&CaseResult) -> bool);

/// The two measures of the report: every bar met, and no fall.
const MEASURES: [Measure; 2] =
    [("perturbations survived", CaseResult::survived), ("perturbations without a fall", CaseResult::no_fall)];

/// Short labels of the entries, "C+A 2" for the group's second seed.
pub fn labels(r: &PhysicsReport) -> Vec<String> {
    let mut seen: Vec<Group> = Vec::new();
    r.entries
        .iter()
        .map(|e| {
            seen.push(e.group);
            format!("{} {}", e.group.label(), seen.iter().filter(|&&g| g == e.group).count())
        })
        .collect()
}

/// The groups' scores with their intervals and the ordering C − O, C+A − C (the table `topa ablate` shows).
pub fn groups_markdown(r: &PhysicsReport) -> String {
    let mut s = String::from(
        "| group | seeds | perturbations survived, % [95 % CI] | without a fall, % [95 % CI] | seeds meeting the \
         bars at nominal |\n|---|---:|---:|---:|---:|\n",
    );
    for g in Group::ALL {
        let seeds: Vec<&PhysicsResult> = r.entries.iter().filter(|e| e.group == g).map(|e| &e.result).collect();
        if seeds.is_empty() {
            continue;
        }
        let ci = MEASURES.map(|(_, held)| intervals::interval(&scores(r, g, held), WHOLE, intervals::mean).show(0));
        let nominal = seeds.iter().filter(|x| x.nominal().is_some_and(|c| c.survived())).count();
        let _ = writeln!(s, "| {} | {} | {} | {} | {nominal}/{} |", g.label(), seeds.len(), ci[0], ci[1], seeds.len());
    }
    for ((better, base), (what, held)) in
        [(Group::C, Group::O), (Group::CA, Group::C)].into_iter().flat_map(|p| MEASURES.map(|m| (p, m)))
    {
        let (x, y) = (scores(r, better, held), scores(r, base, held));
        if x.is_empty() || y.is_empty() {
            continue;
        }
        let Some((d, p)) = intervals::compare(&x, &y, WHOLE) else { continue };
        let verdict = if x.len().min(y.len()) < intervals::MIN_RUNS_FOR_VERDICT {
            "too few seeds to decide".to_string()
        } else {
            match d.sign() {
                Some(true) => format!("{} ahead (the paper's order)", better.label()),
                Some(false) => format!("{} behind (against the paper's order)", better.label()),
                None => "no difference the interval can tell".to_string(),
            }
        };
        let _ = write!(
            s,
            "\n{} − {}, {what}: {} percentage points, P(improvement) {} — {verdict}.\n",
            better.label(),
            base.label(),
            d.show(0),
            p.show(2)
        );
    }
    s
}

/// One cell of the case table: ✓ and the worst MAE, or ✗ and what was missed.
fn cell(c: &super::CaseResult) -> String {
    if c.survived() {
        format!("✓ {:.3}", c.worst_component_mae)
    } else {
        format!("✗ {}", c.missed())
    }
}

/// The whole report.
pub fn markdown(r: &PhysicsReport) -> String {
    let Some(first) = r.entries.first() else { return String::from("No policies.\n") };
    let cases = &first.result.cases;
    let one_at_a_time = r.matrix.cases.len();
    let mut s = format!(
        "Each policy under {} perturbations of the simulator ({one_at_a_time} one at a time from {}, {} random \
         combinations of {}), and nominal: {}. A perturbation is survived when the policy meets every bar there: no \
         fall and no stand-still on the six tracking commands, each component's MAE ≤ {MAX_COMPONENT_MAE}, no fall \
         under the pushes. Score = share of the perturbations survived; beside it the share without a fall (tracking \
         precision and stand-stills aside).\n\n",
        cases.len() - 1,
        r.matrix.source,
        cases.len() - 1 - one_at_a_time,
        r.matrix.combination_size,
        r.protocol.describe(),
    );
    s.push_str(&groups_markdown(r));
    let labels = labels(r);
    s.push_str("\n## Each perturbation\n\n✓ survived, with the worst component MAE; ✗ the bars missed.\n\n| case |");
    for l in &labels {
        let _ = write!(s, " {l} |");
    }
    let _ = write!(s, "\n|---|{}\n", "---|".repeat(labels.len()));
    for (i, c) in cases.iter().enumerate() {
        let _ = write!(s, "| {} |", c.case);
        for e in &r.entries {
            let _ = write!(s, " {} |", e.result.cases.get(i).map_or("–".into(), cell));
        }
        s.push('\n');
    }
    s.push_str("\n## Each policy\n\n| policy | seed | score, % | without a fall, % |\n|---|---|---:|---:|\n");
    for (e, l) in r.entries.iter().zip(&labels) {
        let p = e.result.perturbed();
        let no_fall = 100.0 * p.iter().filter(|c| c.no_fall()).count() as f64 / p.len().max(1) as f64;
        let _ = writeln!(s, "| {} | {l} | {:.0} | {no_fall:.0} |", e.policy.display(), 100.0 * e.result.score());
    }
    let breaking: Vec<String> = (1..cases.len())
        .filter_map(|i| {
            let failed: Vec<&str> = r
                .entries
                .iter()
                .zip(&labels)
                .filter(|(e, _)| e.result.cases.get(i).is_some_and(|c| !c.survived()))
                .map(|(_, l)| l.as_str())
                .collect();
            (failed.len() >= 2).then(|| format!("- {}: {}", cases[i].case, failed.join(", ")))
        })
        .collect();
    s.push_str("\n## Perturbations that break more than one seed\n\n");
    if breaking.is_empty() {
        s.push_str("None.\n");
    } else {
        s.push_str(&breaking.join("\n"));
        s.push('\n');
    }
    if !r.fragility.is_empty() {
        s.push('\n');
        s.push_str(&super::fragility::markdown(&r.fragility));
    }
    s
}

/// Writes physics.{md,json} and the case × policy heatmap (PNG, SVG) into `out`; returns the Markdown.
pub fn write(r: &PhysicsReport, out: &Path) -> Result<String> {
    std::fs::create_dir_all(out).map_err(Error::io("creating", out))?;
    let md = markdown(r);
    crate::report::write_text(out, "physics.md", &format!("# Robustness to the simulator\n\n{md}"))?;
    crate::report::write_json(out, "physics.json", r)?;
    super::heatmap::draw(r, &out.join("physics_heatmap.png"), &out.join("physics_heatmap.svg"))?;
    Ok(md)
}
