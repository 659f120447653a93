//! The physics report as Markdown (groups with intervals, each case × policy, the perturbations that break
//! several seeds, the fragility findings) and as files.

use std::fmt::Write as _;
use std::path::Path;

use super::report::{labels, scores, PhysicsReport, MEASURES, WHOLE};
use super::{fragility, heatmap, CaseResult, PhysicsResult};
use crate::claims::MAX_COMPONENT_MAE;
use crate::error::{Error, Result};
use crate::intervals;
use crate::results::Group;

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
fn cell(c: &CaseResult) -> String {
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
        s.push_str(&fragility::markdown(&r.fragility));
    }
    s
}

/// Writes physics.{md,json} and the case × policy heatmap (PNG, SVG) into `out`; returns the Markdown.
pub fn write(r: &PhysicsReport, out: &Path) -> Result<String> {
    std::fs::create_dir_all(out).map_err(Error::io("creating", out))?;
    let md = markdown(r);
    crate::report::write_text(out, "physics.md", &format!("# Robustness to the simulator\n\n{md}"))?;
    crate::report::write_json(out, "physics.json", r)?;
    heatmap::draw(r, &out.join("physics_heatmap.png"), &out.join("physics_heatmap.svg"))?;
    Ok(md)
}
