//! The perturbation report over groups of seeds: every policy through the matrix, each group's score (share of
//! the perturbed cases survived) with its bootstrap 95 % interval (seeds resampled whole), the paper's ordering
//! O < C < C+A checked on it, the case × policy table and the cases that break more than one seed.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use topa_env::policy_runner::PolicyRunner;

use super::flip::Flip;
use super::matrix::Matrix;
use super::{CaseResult, PhysicsResult, Protocol};
use crate::error::{ensure, Error, Result};
use crate::intervals::{Resampling, Scores};
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
    pub fragility: Vec<Flip>,
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

pub(super) const WHOLE: Resampling = Resampling { tasks: false };

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
pub(super) type Measure = (&'static str, fn(&CaseResult) -> bool);

/// The two measures of the report: every bar met, and no fall.
pub(super) const MEASURES: [Measure; 2] =
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
