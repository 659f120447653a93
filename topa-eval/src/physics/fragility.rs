//! What fragility comes from (`topa physics --fragility`): for each case a policy fails, the smallest
//! perturbation that flips it. A graded case (factors, offsets, latency) is searched by bisection between nominal
//! and the case, on eighths of its departure or on whole physics steps of latency, assuming the outcome changes
//! once along that line; a switch (cone, solver, integrator, sole shape, contact parameters, timestep, iterations)
//! is its own smallest form; a combination is explained by its members that fail alone, else by its smallest
//! failing subset.

use topa_env::policy_runner::PolicyRunner;

use super::flip::{Finding, Flip};
use super::matrix::Perturbation;
use super::report::{labels, PhysicsReport};
use super::{run_case, CaseResult, Protocol};
use crate::error::Result;
use crate::settings::EvalSettings;

/// Searches every failed case of every policy whose nominal case passes; the search runs with the report's
/// protocol and settings.
pub fn search(r: &PhysicsReport) -> Result<Vec<Flip>> {
    let labels = labels(r);
    let expanded = r.matrix.expand();
    let picks = r.matrix.combination_picks();
    let singles = 1 + r.matrix.cases.len();
    let mut flips = Vec::new();
    for (e, label) in r.entries.iter().zip(&labels) {
        if !e.result.nominal().is_some_and(CaseResult::survived) {
            continue; // nothing flips a policy that misses the bars unperturbed
        }
        let mut runner = PolicyRunner::load(&e.policy, e.group.label())?;
        let dt = r.settings.timestep();
        for (i, (case, res)) in expanded.iter().zip(&e.result.cases).enumerate().skip(1) {
            if res.survived() {
                continue;
            }
            eprintln!("  {label}: {}", case.name);
            let finding = if i >= singles {
                let members = &picks[i - singles];
                let alone: Vec<String> = members
                    .iter()
                    .filter(|&&m| !e.result.cases[1 + m].survived())
                    .map(|&m| r.matrix.cases[m].name.clone())
                    .collect();
                if alone.is_empty() {
                    smallest_subset(&mut runner, r, members)?
                } else {
                    Finding::Members { failing: alone }
                }
            } else {
                match case.levels(dt) {
                    None => Finding::Switch,
                    Some(levels) => bisect(&mut runner, &r.settings, &r.protocol, case, levels, dt, res)?,
                }
            };
            flips.push(Flip { seed: label.clone(), policy: e.policy.clone(), case: case.name.clone(), finding });
        }
    }
    Ok(flips)
}

/// Bisection on the levels between nominal (survived) and the case (failed).
fn bisect(
    runner: &mut PolicyRunner,
    s: &EvalSettings,
    p: &Protocol,
    case: &Perturbation,
    levels: usize,
    dt: f64,
    failed: &CaseResult,
) -> Result<Finding> {
    let (mut lo, mut hi, mut missed) = (0, levels, failed.missed());
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        let r = run_case(runner, s, &case.graded(mid, levels, dt), p)?;
        if r.survived() {
            lo = mid;
        } else {
            (hi, missed) = (mid, r.missed());
        }
    }
    Ok(Finding::Threshold {
        survives: case.graded(lo, levels, dt).name,
        fails: case.graded(hi, levels, dt).name,
        missed,
        survives_at: lo as f64 / levels as f64,
        fails_at: hi as f64 / levels as f64,
    })
}

/// The smallest subsets of a combination whose members all survive alone: pairs first, then larger.
fn smallest_subset(runner: &mut PolicyRunner, r: &PhysicsReport, members: &[usize]) -> Result<Finding> {
    for size in 2..members.len() {
        for subset in subsets(members, size) {
            let case = r.matrix.combine(&subset);
            if !run_case(runner, &r.settings, &case, &r.protocol)?.survived() {
                return Ok(Finding::Members {
                    failing: subset.iter().map(|&m| r.matrix.cases[m].name.clone()).collect(),
                });
            }
        }
    }
    Ok(Finding::Members { failing: members.iter().map(|&m| r.matrix.cases[m].name.clone()).collect() })
}

/// The subsets of `of` with `size` elements, in order.
fn subsets(of: &[usize], size: usize) -> Vec<Vec<usize>> {
    if size == 0 {
        return vec![Vec::new()];
    }
    (0..of.len())
        .flat_map(|i| {
            subsets(&of[i + 1..], size - 1).into_iter().map(move |mut rest| {
                rest.insert(0, of[i]);
                rest
            })
        })
        .collect()
}

/// The fragility section of the report.
pub fn markdown(flips: &[Flip]) -> String {
    let mut s = String::from(
        "## What flips each failed case\n\nThe smallest perturbation found to fail (bisection between nominal and \
         the case, assuming one change along the way; a switch is its own smallest form; a combination is explained \
         by a part that fails by itself).\n\n",
    );
    if flips.is_empty() {
        s.push_str("No failed case to search.\n");
        return s;
    }
    s.push_str("| seed | case | smallest that fails |\n|---|---|---|\n");
    for f in flips {
        s.push_str(&format!("| {} | {} | {} |\n", f.seed, f.case, f.finding.describe()));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::super::matrix::Matrix;
    use super::*;

    #[test]
    fn subsets_are_every_choice_of_that_many_in_order() {
        assert_eq!(subsets(&[4, 7, 9], 2), vec![vec![4, 7], vec![4, 9], vec![7, 9]]);
        assert_eq!(subsets(&[4, 7, 9], 3), vec![vec![4, 7, 9]]);
        assert_eq!(subsets(&[1, 2, 3, 4], 2).len(), 6);
    }

    #[test]
    fn graded_cases_step_from_nominal_to_the_case_and_switches_do_not() {
        let m = Matrix::parse(
            "[[case]]\nname = \"late\"\nlatency_s = 0.02\n[[case]]\nname = \"slip\"\nfriction_scale = 0.5\n\
             torso_com_offset = [0.02, 0.0, 0.0]\n[[case]]\nname = \"pgs\"\nsolver = \"pgs\"\n",
            "m.toml",
        )
        .unwrap();
        let dt = 0.0025;
        let (late, slip, pgs) = (&m.cases[0], &m.cases[1], &m.cases[2]);
        assert_eq!(late.levels(dt), Some(8), "20 ms in 2.5 ms steps");
        assert_eq!(late.graded(3, 8, dt).latency_s, Some(0.0075));
        assert_eq!(late.graded(0, 8, dt).latency_s, None);
        assert_eq!(late.graded(8, 8, dt).latency_s, Some(0.02));
        assert_eq!(slip.levels(dt), Some(8));
        let half = slip.graded(4, 8, dt);
        assert!((half.physics.friction_scale - 0.75).abs() < 1e-12);
        assert!((half.physics.torso_com_offset[0] - 0.01).abs() < 1e-12);
        assert_eq!(half.name, "friction x0.750, torso CoM (+1.00, +0.00, +0.00) cm");
        assert_eq!(slip.graded(8, 8, dt).physics, slip.physics);
        assert!(slip.graded(0, 8, dt).physics.is_nominal());
        assert_eq!(pgs.levels(dt), None);
    }
}
