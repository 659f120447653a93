//! Two ablation reports side by side: a change to the recipe (the variant) against what it would replace (the
//! baseline), group by group, each headline measure's difference with its bootstrap 95 % interval, the probability
//! that the variant is better, and a verdict — better, no difference resolved, or worse by how much. Both reports
//! must come from the same protocol and evaluation settings, on different policies: the seeds of each group are
//! resampled on their own (`intervals::compare`), as the paper's groups are.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::ablate::Ablation;
use crate::error::{ensure, Error, Result};
use crate::groups::{self, GroupResults};
use crate::intervals::{self, Interval, Resampling, Scores, MIN_RUNS_FOR_VERDICT};
use crate::merge::{self, Mergeable};
use crate::results::{Group, PolicyResults, RunCounts};

/// Which way a measure improves.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Better {
    Higher,
    Lower,
    /// A description, not a goal (the gait): shown without a verdict.
    Neither,
}

/// What the interval of the difference says.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// The whole interval lies on the better side.
    Better,
    /// The interval includes zero: no worse at this resolution.
    NoDifferenceResolved,
    /// The whole interval lies on the worse side.
    Worse,
    /// Fewer than `MIN_RUNS_FOR_VERDICT` seeds in a group: the interval is shown, it decides nothing.
    TooFewSeeds,
    /// A description (`Better::Neither`).
    NotJudged,
}

impl Verdict {
    fn words(self) -> &'static str {
        match self {
            Verdict::Better => "**better**",
            Verdict::NoDifferenceResolved => "no difference resolved",
            Verdict::Worse => "**worse**",
            Verdict::TooFewSeeds => "undecided: fewer than 5 seeds in a group",
            Verdict::NotJudged => "–",
        }
    }
}

/// One measure of one group.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    pub group: Group,
    pub measure: String,
    pub unit: &'static str,
    pub better: Better,
    pub baseline_seeds: usize,
    pub variant_seeds: usize,
    pub baseline: Interval,
    pub variant: Interval,
    /// Variant − baseline.
    pub difference: Interval,
    /// P(variant better than baseline) (rliable's probability of improvement; for a lower-is-better measure,
    /// P(variant < baseline)).
    pub p_variant_better: Option<Interval>,
    pub verdict: Verdict,
}

/// The comparison, as `topa compare` writes it (compare.json).
#[derive(Debug, Clone, Serialize)]
pub struct Comparison {
    pub baseline: PathBuf,
    pub variant: PathBuf,
    pub protocol: String,
    pub sim2sim: String,
    pub rows: Vec<Row>,
}

/// Reads both reports and compares them.
pub fn load_and_compare(baseline: &Path, variant: &Path) -> Result<Comparison> {
    let b: Ablation = merge::read(baseline, "--baseline")?;
    let v: Ablation = merge::read(variant, "--variant")?;
    compare(&b, &v, baseline, variant)
}

/// Compares the groups the two reports share (a group in only one of them is named in an error: nothing to
/// compare it with).
pub fn compare(b: &Ablation, v: &Ablation, b_file: &Path, v_file: &Path) -> Result<Comparison> {
    let ((bp, b_text), (vp, v_text)) = (b.protocol(), v.protocol());
    ensure!(
        bp == vp,
        "{} was run with another protocol ({v_text}) than {} ({b_text}); run one of them again with the other's \
         flags",
        v_file.display(),
        b_file.display()
    );
    ensure!(
        v.settings.same_results_as(&b.settings)?,
        "{} was run with other evaluation settings (timestep, sim2sim, integrator, settle time or seed) than {}; \
         compare only runs made with the same flags",
        v_file.display(),
        b_file.display()
    );
    for r in &v.results {
        let twin = b.results.iter().find(|x| x.policy == r.policy && x.weights_crc32 == r.weights_crc32);
        ensure!(
            twin.is_none(),
            "{} is in both reports ({} and {}) with the same weights: a comparison needs the variant's own policies",
            r.policy.display(),
            b_file.display(),
            v_file.display()
        );
    }
    let (bg, vg) = (groups::group(&b.results), groups::group(&v.results));
    let shared: Vec<Group> =
        Group::ALL.into_iter().filter(|g| bg.iter().any(|x| x.name == *g) && vg.iter().any(|x| x.name == *g)).collect();
    if shared.is_empty() {
        let names = |g: &[GroupResults]| g.iter().map(|x| x.name.label()).collect::<Vec<_>>().join(", ");
        return Err(Error::bad_file(format!(
            "{} holds the groups {} and {} the groups {}: none in common, nothing to compare",
            b_file.display(),
            names(&bg),
            v_file.display(),
            names(&vg)
        )));
    }
    let how = b.extent.resolution().push;
    let mut rows = Vec::new();
    for g in shared {
        let find = |gs: &'_ [GroupResults<'_>]| gs.iter().position(|x| x.name == g).expect("shared group");
        let (x, y) = (&bg[find(&bg)], &vg[find(&vg)]);
        for (measure, unit, better, scores, how) in measures(x, y, how) {
            rows.push(row(g, measure, unit, better, &scores.0, &scores.1, how));
        }
    }
    Ok(Comparison {
        baseline: b_file.to_path_buf(),
        variant: v_file.to_path_buf(),
        protocol: b.extent.describe(),
        sim2sim: b.settings.sim2sim_mode.to_string(),
        rows,
    })
}

type Measure = (String, &'static str, Better, (Scores, Scores), Resampling);

/// The headline measures of a group in the baseline and the variant.
fn measures(b: &GroupResults, v: &GroupResults, push: Resampling) -> Vec<Measure> {
    const WHOLE: Resampling = Resampling { tasks: false };
    let both = |f: &dyn Fn(&GroupResults) -> Scores| (f(b), f(v));
    let per_policy = |f: fn(&PolicyResults) -> f64| move |g: &GroupResults| Scores::per_run(&per(g, f));
    let mut out: Vec<Measure> = vec![
        ("push: mean t_fall standing".into(), "s", Better::Higher, both(&|g| g.push_scores(false)), push),
        ("push: mean t_fall walking".into(), "s", Better::Higher, both(&|g| g.push_scores(true)), push),
    ];
    let levels = b.members.iter().chain(&v.members).map(|r| r.noise.len()).min().unwrap_or(0);
    for level in 0..levels {
        let m = format!("command noise level {}: success", level + 1);
        out.push((m, "%", Better::Higher, both(&|g| g.noise_scores(level)), WHOLE));
    }
    out.push(("tracking: worst component MAE".into(), "", Better::Lower, both(&|g| g.worst_component_scores()), WHOLE));
    out.push(("tracking: runs fallen".into(), "%", Better::Lower, both(&per_policy(fallen_pct)), WHOLE));
    out.push(("tracking: runs stood still".into(), "%", Better::Lower, both(&per_policy(still_pct)), WHOLE));
    for (m, f) in [("gait at 0.5 m/s: air time", air as fn(&PolicyResults) -> f64), ("gait at 0.5 m/s: steps/s", steps)]
    {
        out.push((m.into(), if m.ends_with("time") { "s" } else { "" }, Better::Neither, both(&per_policy(f)), WHOLE));
    }
    out
}

fn per(g: &GroupResults, f: fn(&PolicyResults) -> f64) -> Vec<f64> {
    g.members.iter().map(|r| f(r)).collect()
}

fn fallen_pct(r: &PolicyResults) -> f64 {
    let n = RunCounts::of(&r.tracking);
    100.0 * n.falls as f64 / n.runs.max(1) as f64
}

fn still_pct(r: &PolicyResults) -> f64 {
    let n = RunCounts::of(&r.tracking);
    n.stood_still.map_or(f64::NAN, |s| 100.0 * s as f64 / n.runs.max(1) as f64)
}

fn forward(r: &PolicyResults) -> Option<&crate::gait::GaitStats> {
    r.tracking.iter().find(|t| t.key == "walk_forward").map(|t| &t.gait)
}

fn air(r: &PolicyResults) -> f64 {
    forward(r).map_or(f64::NAN, |g| g.air_time_s)
}

fn steps(r: &PolicyResults) -> f64 {
    forward(r).map_or(f64::NAN, |g| g.steps_per_s)
}

fn row(
    group: Group,
    measure: String,
    unit: &'static str,
    better: Better,
    b: &Scores,
    v: &Scores,
    how: Resampling,
) -> Row {
    let nan = Interval { point: f64::NAN, lo: f64::NAN, hi: f64::NAN };
    let (difference, p) = match intervals::compare(v, b, how) {
        Some((d, p)) => (d, Some(p)),
        None => (nan, None),
    };
    // P(v < b) for a lower-is-better measure: the same bootstrap with the roles swapped.
    let p_variant_better = match better {
        Better::Higher => p,
        Better::Lower => intervals::compare(b, v, how).map(|(_, p)| p),
        Better::Neither => None,
    };
    let enough = b.len() >= MIN_RUNS_FOR_VERDICT && v.len() >= MIN_RUNS_FOR_VERDICT;
    let verdict = match better {
        Better::Neither => Verdict::NotJudged,
        _ if !difference.point.is_finite() => Verdict::NotJudged,
        _ if !enough => Verdict::TooFewSeeds,
        _ => {
            let up = if better == Better::Higher { difference.lo > 0.0 } else { difference.hi < 0.0 };
            let down = if better == Better::Higher { difference.hi < 0.0 } else { difference.lo > 0.0 };
            if up {
                Verdict::Better
            } else if down {
                Verdict::Worse
            } else {
                Verdict::NoDifferenceResolved
            }
        }
    };
    Row {
        group,
        measure,
        unit,
        better,
        baseline_seeds: b.len(),
        variant_seeds: v.len(),
        baseline: intervals::interval(b, how, intervals::mean),
        variant: intervals::interval(v, how, intervals::mean),
        difference,
        p_variant_better,
        verdict,
    }
}

fn signed(s: &Interval, digits: usize) -> String {
    if s.point.is_finite() {
        format!("{:+.d$} [{:+.d$}, {:+.d$}]", s.point, s.lo, s.hi, d = digits)
    } else {
        "–".into()
    }
}

/// The comparison as a Markdown page.
pub fn markdown(c: &Comparison) -> String {
    let mut s = format!(
        "Variant `{}` against baseline `{}`; protocol: {}; sim2sim: {}. Each cell is the group's mean over its seeds \
         with a bootstrap 95 % interval (seeds resampled whole, each group on its own); the difference is variant − \
         baseline; a verdict needs {MIN_RUNS_FOR_VERDICT} seeds a group and an interval clear of zero.\n\n\
         | group | measure | seeds (baseline / variant) | baseline | variant | variant − baseline | P(variant better) | \
         verdict |\n|---|---|---:|---:|---:|---:|---:|---|\n",
        c.variant.display(),
        c.baseline.display(),
        c.protocol,
        c.sim2sim
    );
    for r in &c.rows {
        let digits = match r.unit {
            "%" => 0,
            "s" if r.measure.starts_with("gait") => 3,
            "s" => 2,
            _ => 3,
        };
        let unit = if r.unit.is_empty() { String::new() } else { format!(" ({})", r.unit) };
        let _ = writeln!(
            s,
            "| {} | {}{unit} | {} / {} | {} | {} | {} | {} | {} |",
            r.group.label(),
            r.measure,
            r.baseline_seeds,
            r.variant_seeds,
            r.baseline.show(digits),
            r.variant.show(digits),
            signed(&r.difference, digits),
            r.p_variant_better.as_ref().map_or("–".into(), |p| p.show(2)),
            r.verdict.words()
        );
    }
    s
}

/// Writes compare.md and compare.json into `out` (atomically, as every report).
pub fn write(c: &Comparison, out: &Path) -> Result<String> {
    std::fs::create_dir_all(out).map_err(Error::io("creating", out))?;
    let md = markdown(c);
    crate::report::write_text(out, "compare.md", &md)?;
    crate::report::write_json(out, "compare.json", c)?;
    Ok(md)
}
