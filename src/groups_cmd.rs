//! `topa ablate`, `topa terrain`, `topa field`: the paper's groups of seeds (O, C, C+A) through an experiment
//! suite, or earlier reports merged — run, print (Markdown or JSON), write the report to a folder.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

use crate::eval::ablate::{self, Extent};
use crate::eval::results::Group;
use crate::eval::settings::Sim2SimMode;
use crate::eval::{field, terrain_report};
use crate::eval_cmd::{print_json, Common};

/// Policy files of one group: files as given, folders expanded to their `*.json` policies in name order.
pub fn policy_files(group: &str, paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(p)
                .with_context(|| format!("reading {}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| f.extension().is_some_and(|x| x == "json"))
                .collect();
            found.sort();
            anyhow::ensure!(!found.is_empty(), "--{group} {}: no *.json policy in this folder", p.display());
            out.extend(found);
        } else {
            anyhow::ensure!(p.is_file(), "--{group} {}: no such policy file", p.display());
            out.push(p.clone());
        }
    }
    Ok(out)
}

/// The policies of the paper's three groups.
#[derive(Args, Clone, Debug)]
pub struct Groups {
    /// Policies trained on the open (serial) model: files, or folders whose *.json policies are all taken
    /// (several seeds: `--o a.json b.json` or `--o assets/policies/O`).
    #[arg(long, num_args = 1..)]
    pub o: Vec<PathBuf>,
    /// Policies trained on the closed model (files or folders, as --o).
    #[arg(long, num_args = 1..)]
    pub c: Vec<PathBuf>,
    /// Policies trained on the closed model with the cyclic adversary (files or folders, as --o).
    #[arg(long, num_args = 1..)]
    pub ca: Vec<PathBuf>,
}

impl Groups {
    /// The (group, file) list, folders expanded.
    pub fn policies(self) -> Result<Vec<(Group, PathBuf)>> {
        let mut policies: Vec<(Group, PathBuf)> = Vec::new();
        for (group, flag, paths) in [(Group::O, "o", self.o), (Group::C, "c", self.c), (Group::CA, "ca", self.ca)] {
            policies.extend(policy_files(flag, &paths)?.into_iter().map(|p| (group, p)));
        }
        Ok(policies)
    }
}

/// Reports attached to an ablation: the real-world test (field.json) and the terrain test (terrain.json).
type Attached<'a> = [Option<&'a std::path::Path>; 2];

fn attach(a: &mut ablate::Ablation, [field, terrain]: Attached) -> Result<()> {
    if let Some(f) = field {
        a.field = Some(field::load(f)?);
    }
    if let Some(t) = terrain {
        a.terrain = Some(terrain_report::merge(&[t.to_path_buf()])?);
    }
    Ok(())
}

pub fn run_ablate(groups: Groups, extent: Extent, attached: Attached, c: Common) -> Result<()> {
    let policies = groups.policies()?;
    extent.check()?;
    // Read the attachments first: a bad file fails before hours of evaluation.
    let mut a = ablate::Ablation {
        settings: c.settings()?,
        extent: extent.clone(),
        results: Vec::new(),
        field: None,
        terrain: None,
    };
    attach(&mut a, attached)?;
    // And their weights against the policies' files now, not after the evaluation (whose results would be lost).
    let weights = policies
        .iter()
        .map(|(_, p)| Ok((p.clone(), Some(trainer::policy_file::Policy::load(p)?.meta.weights_crc32))))
        .collect::<Result<Vec<_>>>()?;
    ablate::check_attached_weights(&a, &weights)?;
    let run = ablate::run(&policies, &c.settings()?, &extent)?;
    a.results = run.results;
    report_ablation(&a, &c)
}

/// `topa ablate --merge`: the report of several earlier ablations joined.
pub fn merge_ablations(files: &[PathBuf], attached: Attached, c: Common) -> Result<()> {
    let mut a = ablate::merge(files)?;
    attach(&mut a, attached)?;
    ablate::check_attached_weights(&a, &ablate::measured_weights(&a))?;
    report_ablation(&a, &c)
}

/// `topa terrain`: terrain.{md,json} and the heatmaps in the output folder.
pub fn report_terrain(r: &terrain_report::TerrainReport, c: &Common) -> Result<()> {
    let md = terrain_report::write(r, &c.out)?;
    if c.json {
        return print_json(r);
    }
    println!("{md}");
    println!("results: {} (terrain.md, terrain.json, one heatmap per policy)", c.out.display());
    Ok(())
}

/// A sim2sim mode in a comma-separated list.
#[derive(Clone, Debug)]
pub struct Sim2SimArg(pub Sim2SimMode);

impl std::str::FromStr for Sim2SimArg {
    type Err = std::convert::Infallible;
    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        Ok(Sim2SimArg(s.parse()?))
    }
}

/// `topa field`: the real-world test of each policy, written to field.{md,json}.
pub fn run_field(groups: Groups, extent: field::FieldExtent, c: Common) -> Result<()> {
    let policies = groups.policies()?;
    for v in &extent.speeds {
        anyhow::ensure!(*v > 0.0, "--speeds: {v} m/s is not a forward speed");
    }
    let f = field::run(&policies, &c.settings()?, &extent)?;
    report_field(&f, &c)
}

/// `topa field --merge`.
pub fn merge_field(files: &[PathBuf], c: Common) -> Result<()> {
    report_field(&field::merge(files)?, &c)
}

fn report_field(f: &field::Field, c: &Common) -> Result<()> {
    std::fs::create_dir_all(&c.out)?;
    let md = field::write(f, &c.out)?;
    if c.json {
        return print_json(f);
    }
    println!("{md}");
    println!("results: {} (field.md, field.json)", c.out.display());
    Ok(())
}

fn report_ablation(a: &ablate::Ablation, c: &Common) -> Result<()> {
    ablate::write(a, &c.out)?;
    if c.json {
        return print_json(a);
    }
    println!("{}", ablate::markdown(a)?);
    println!("results: {} (ablation.md, ablation.json, CSVs, heatmaps.png/svg)", c.out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn policy_folders_expand_to_their_json_files_and_missing_ones_are_named() {
        let dir = std::env::temp_dir().join(format!("topa-policy-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for f in ["seed2.json", "seed1.json", "seed1.safetensors", "README.md"] {
            std::fs::write(dir.join(f), "").unwrap();
        }
        let files = policy_files("c", std::slice::from_ref(&dir)).unwrap();
        assert_eq!(files, vec![dir.join("seed1.json"), dir.join("seed2.json")]);
        let err = policy_files("ca", &[dir.join("nope.json")]).unwrap_err().to_string();
        assert!(err.contains("--ca") && err.contains("nope.json"), "{err}");
        let empty = dir.join("empty");
        std::fs::create_dir_all(&empty).unwrap();
        assert!(policy_files("o", &[empty]).unwrap_err().to_string().contains("no *.json"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
