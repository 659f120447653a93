//! `topa ablate`, `topa terrain`, `topa field`, `topa compare`: the paper's groups of seeds (O, C, C+A) through an
//! experiment suite, earlier reports merged, or two reports compared — run, print (Markdown or JSON), write the
//! report to a folder.

use std::path::{Path, PathBuf};

use anyhow::Result;

use crate::cli::{Common, Groups};
use crate::print::print_json;
use topa_eval::ablate::{self, Extent};
use topa_eval::{field, physics, terrain_report};

/// Reports attached to an ablation: the real-world test (field.json), the terrain test (terrain.json) and the
/// simulator-perturbation test (physics.json).
type Attached<'a> = [Option<&'a std::path::Path>; 3];

fn attach(a: &mut ablate::Ablation, [field, terrain, physics]: Attached) -> Result<()> {
    if let Some(p) = physics {
        a.physics = Some(physics::report::load(p)?);
    }
    if let Some(f) = field {
        a.field = Some(field::load(f)?);
    }
    if let Some(t) = terrain {
        a.terrain = Some(terrain_report::load(t)?);
    }
    Ok(())
}

pub(crate) fn run_ablate(groups: Groups, extent: Extent, attached: Attached, c: Common) -> Result<()> {
    let policies = groups.policies()?;
    extent.check()?;
    // Read the attachments first: a bad file fails before hours of evaluation.
    let mut a = ablate::Ablation {
        settings: c.settings()?,
        extent: extent.clone(),
        results: Vec::new(),
        field: None,
        terrain: None,
        physics: None,
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
pub(crate) fn merge_ablations(files: &[PathBuf], attached: Attached, c: Common) -> Result<()> {
    let mut a = ablate::merge(files)?;
    attach(&mut a, attached)?;
    ablate::check_attached_weights(&a, &ablate::measured_weights(&a))?;
    report_ablation(&a, &c)
}

/// `topa compare`: compare.{md,json} in the output folder, the Markdown (or the JSON) printed.
pub(crate) fn compare(baseline: &Path, variant: &Path, json: bool, out: &Path) -> Result<()> {
    let c = topa_eval::compare::load_and_compare(baseline, variant)?;
    let md = topa_eval::compare::write(&c, out)?;
    if json {
        return print_json(&c);
    }
    println!("{md}");
    println!("results: {} (compare.md, compare.json)", out.display());
    Ok(())
}

/// `topa terrain`: terrain.{md,json} and the heatmaps in the output folder.
pub(crate) fn report_terrain(r: &terrain_report::TerrainReport, c: &Common) -> Result<()> {
    let md = terrain_report::write(r, &c.out)?;
    if c.json {
        return print_json(r);
    }
    println!("{md}");
    println!("results: {} (terrain.md, terrain.json, one heatmap per policy)", c.out.display());
    Ok(())
}

/// `topa physics`: physics.{md,json} and the heatmap in the output folder.
/// Writes a physics report, after the fragility search when asked for (and not already in a merged report).
pub(crate) fn report_physics(mut r: physics::report::PhysicsReport, fragility: bool, c: &Common) -> Result<()> {
    if fragility && r.fragility.is_empty() {
        r.fragility = physics::fragility::search(&r)?;
    }
    let md = physics::render::write(&r, &c.out)?;
    if c.json {
        return print_json(&r);
    }
    println!("{md}");
    println!("results: {} (physics.md, physics.json, physics_heatmap.png/svg)", c.out.display());
    Ok(())
}

/// `topa field`: the real-world test of each policy, written to field.{md,json}.
pub(crate) fn run_field(groups: Groups, extent: field::FieldExtent, c: Common) -> Result<()> {
    let policies = groups.policies()?;
    for v in &extent.speeds {
        anyhow::ensure!(*v > 0.0, "--speeds: {v} m/s is not a forward speed");
    }
    let f = field::run(&policies, &c.settings()?, &extent)?;
    report_field(&f, &c)
}

/// `topa field --merge`.
pub(crate) fn merge_field(files: &[PathBuf], c: Common) -> Result<()> {
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
