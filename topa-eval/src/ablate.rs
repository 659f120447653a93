//! `topa ablate`: the paper's three experiments for O, C and C+A — each group one or several policies (seeds) —
//! and the push test while walking beside the paper's standing one; mean ± sd of every headline number with the
//! paper's beside (groups.rs), each policy's own numbers, the groups' mean heatmaps, all written to a folder.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::groups;
use super::noise;
use super::push;
use super::report;
use super::results::{one, Group, PolicyResults, PushGrid};
use super::settings::EvalSettings;
use super::tracking;
use crate::error::{ensure, invalid, Error, Result};
use crate::merge::Mergeable;
use topa_env::policy_runner::PolicyRunner;

/// How much of each experiment to run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Extent {
    pub tracking_window_s: f64,
    pub tracking_transient_s: f64,
    /// Initial states each tracking command runs from (1 in reports written before there was a choice).
    #[serde(default = "one")]
    pub tracking_starts: usize,
    pub push_range_n: f64,
    pub push_step_n: f64,
    pub push_window_s: f64,
    pub noise_runs: usize,
    pub noise_seconds: f64,
    pub noise_interval_s: f64,
    /// The command held in the second push test (the paper does not say whether its robot stood or walked).
    pub walking_push_command: [f64; 3],
}

impl Extent {
    /// The paper's protocol: 13 × 13 push grid, 100 noise runs per level.
    pub fn full() -> Self {
        Extent {
            tracking_window_s: 10.0,
            tracking_transient_s: 2.0,
            tracking_starts: 10,
            push_range_n: 30.0,
            push_step_n: 5.0,
            push_window_s: 10.0,
            noise_runs: 100,
            noise_seconds: 20.0,
            noise_interval_s: 0.5,
            walking_push_command: [0.5, 0.0, 0.0],
        }
    }
    /// A quick look (a few minutes for three policies on 2 cores): 7 × 7 push grid (10 N steps), 20 noise runs
    /// of 10 s per level, 3 starts per tracking command.
    pub fn quick() -> Self {
        Extent { tracking_starts: 3, push_step_n: 10.0, noise_runs: 20, noise_seconds: 10.0, ..Extent::full() }
    }
    /// Refuses a grid that cannot be laid out (push::axis's rules), naming the flags, before any policy runs.
    pub fn check(&self) -> Result<()> {
        ensure!(self.tracking_starts >= 1, "--starts must be at least 1 (initial states per tracking command)");
        push::axis(self.push_range_n, self.push_step_n)
            .map(|_| ())
            .map_err(|e| Error::file(format!("--range {} N with --step {} N", self.push_range_n, self.push_step_n), e))
    }
    /// The paper's push grid (±30 N), whatever its step: its mean t_fall values are comparable with ours.
    pub fn paper_push_range(&self) -> bool {
        self.push_range_n == Extent::full().push_range_n
    }
    /// How finely this protocol resolves the claims: a grid coarser than the paper's is a sample of its cells (so
    /// intervals resample the cells too), and anything short of the full protocol says so in its verdicts.
    pub fn resolution(&self) -> super::claims::Resolution {
        let full = Extent::full();
        super::claims::Resolution {
            push: super::intervals::Resampling { tasks: self.push_step_n > full.push_step_n },
            quick: *self != full,
        }
    }
    /// One line: grid, noise runs, tracking starts.
    pub fn describe(&self) -> String {
        let cells = push::axis(self.push_range_n, self.push_step_n).map_or(0, |a| a.len());
        format!(
            "{cells}×{cells} push grid to ±{} N, {} noise runs of {} s per level, {} starts per tracking command",
            self.push_range_n, self.noise_runs, self.noise_seconds, self.tracking_starts
        )
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ablation {
    pub settings: EvalSettings,
    pub extent: Extent,
    pub results: Vec<PolicyResults>,
    /// The real-world test of the same policies (`topa field`), when attached with `--field`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field: Option<super::field::Field>,
    /// The terrain test of these or other policies (`topa terrain`), when attached with `--terrain`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub terrain: Option<super::terrain_report::TerrainReport>,
    /// The simulator-perturbation test (`topa physics`), when attached with `--physics`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub physics: Option<super::physics::report::PhysicsReport>,
}

/// Runs every experiment for each (group, policy file).
pub fn run(policies: &[(Group, PathBuf)], settings: &EvalSettings, extent: &Extent) -> Result<Ablation> {
    ensure!(!policies.is_empty(), "give at least one policy with --o, --c or --ca");
    let mut results = Vec::new();
    for (name, path) in policies {
        let mut runner = PolicyRunner::load(path, name.label())?;
        eprintln!("{}: {} (trained on the {} model)", name.label(), path.display(), runner.trained_on());
        let (window, transient) = (extent.tracking_window_s, extent.tracking_transient_s);
        let tracking = tracking::run(&mut runner, settings, window, transient, extent.tracking_starts)?;
        let push =
            push::run(&mut runner, settings, extent.push_range_n, extent.push_step_n, extent.push_window_s, [0.0; 3])?;
        let (range, step, window) = (extent.push_range_n, extent.push_step_n, extent.push_window_s);
        let walking = push::run(&mut runner, settings, range, step, window, extent.walking_push_command)?;
        let noise =
            noise::run(&mut runner, settings, extent.noise_runs, extent.noise_seconds, extent.noise_interval_s)?;
        results.push(PolicyResults {
            name: *name,
            policy: path.clone(),
            weights_crc32: Some(runner.policy.meta.weights_crc32),
            trained_on: runner.trained_on().into(),
            tracking,
            push,
            push_walking: Some(walking),
            noise,
        });
    }
    Ok(Ablation {
        settings: settings.clone(),
        extent: extent.clone(),
        results,
        field: None,
        terrain: None,
        physics: None,
    })
}

/// Joins ablations of the same protocol and settings (`--merge`, the rule of every report: `crate::merge`);
/// the attached field and terrain reports stay with the first file's (`--field` / `--terrain` replace them).
pub fn merge(files: &[PathBuf]) -> Result<Ablation> {
    crate::merge::merge(files)
}

impl Mergeable for Ablation {
    const FILE: &'static str = "ablation.json";
    const COMMAND: &'static str = "topa ablate";

    fn protocol(&self) -> (serde_json::Value, String) {
        (serde_json::to_value(&self.extent).unwrap_or_default(), self.extent.describe())
    }

    fn settings(&self) -> Option<&EvalSettings> {
        Some(&self.settings)
    }

    fn measured(&self) -> Vec<(PathBuf, Option<u32>)> {
        measured_weights(self)
    }

    fn absorb(&mut self, part: Ablation) -> Result<()> {
        self.results.extend(part.results);
        Ok(())
    }

    fn finish(&mut self) {
        self.results.sort_by_key(|r| r.name); // the report's order: O, C, CA
    }
}

/// Each result's policy file with the CRC-32 of the weights it measured (where recorded).
pub fn measured_weights(a: &Ablation) -> Vec<(PathBuf, Option<u32>)> {
    a.results.iter().map(|r| (r.policy.clone(), r.weights_crc32)).collect()
}

/// Refuses an attached field or terrain report that measured one of the ablation's policy files with other
/// weights than the ablation (`weights`: its files and their CRC-32s): the report would pair numbers of two
/// different policies under one name.
pub fn check_attached_weights(a: &Ablation, weights: &[(PathBuf, Option<u32>)]) -> Result<()> {
    let ours = |p: &Path| weights.iter().find(|(q, _)| q == p).and_then(|&(_, crc)| crc);
    let field = a.field.iter().flat_map(|f| &f.results).map(|r| ("field", &r.policy, r.weights_crc32));
    let terrain = a.terrain.iter().flat_map(|t| &t.entries).map(|e| ("terrain", &e.policy, e.weights_crc32));
    let physics = a.physics.iter().flat_map(|t| &t.entries).map(|e| ("physics", &e.policy, e.weights_crc32));
    for (test, policy, theirs) in field.chain(terrain).chain(physics) {
        if let (Some(x), Some(y)) = (ours(policy), theirs) {
            ensure!(
                x == y,
                "--{test}: the {test} test measured {} with weights of CRC-32 {y:08x}, this ablation with {x:08x}; \
                 run `topa {test}` on the current policy again",
                policy.display()
            );
        }
    }
    Ok(())
}

/// The Markdown report: the groups' headline numbers, tracking, gait, and every policy's own row.
pub fn markdown(a: &Ablation) -> Result<String> {
    let paper = paper(a)?;
    let paper = paper.as_ref();
    let g = groups::group(&a.results);
    let grid_note = if a.extent.paper_push_range() {
        String::new()
    } else {
        format!(
            "Push grid to ±{} N, not the paper's ±{} N: the paper's mean t_fall beside ours and the t_fall claims \
             below are for its grid, so read them as a comparison between our groups only.\n\n",
            a.extent.push_range_n,
            Extent::full().push_range_n
        )
    };
    let protocol = if a.extent == Extent::full() {
        format!("Protocol: the paper's full protocol ({}).", a.extent.describe())
    } else {
        format!(
            "Protocol: quick ({}), not the paper's; `--full` runs the paper's 13×13 grid to ±30 N and 100 runs of \
             20 s per level.",
            a.extent.describe()
        )
    };
    let mut field = match field_section(a)? {
        f if f.is_empty() => f,
        f => format!("## The paper's real-world test, in simulation\n\n{f}\n"),
    };
    if let Some(t) = &a.terrain {
        field.push_str(&format!("## Terrain\n\n{}\n", super::terrain_report::markdown(t)));
    }
    if let Some(p) = &a.physics {
        field.push_str(&format!("## Robustness to the simulator\n\n{}\n", physics_summary(p)));
    }
    Ok(format!(
        "{protocol}\n\n## Headline numbers\n\n{grid_note}{}\n## The paper's claims and the bars, checked\n\n{}\n## Commanded velocity \
         tracking\n{}\n## Gait\n\n{}\n## Intervals\n\n{}\n## Each policy\n\n{}",
        groups::headline_markdown(&g, paper, a.extent.resolution().push),
        super::claims::markdown(&super::claims::check(&g, a.extent.resolution(), paper)),
        groups::tracking_markdown(&g, paper),
        groups::gait_markdown(&g),
        groups::intervals_markdown(&g, a.extent.resolution().push),
        groups::per_policy_markdown(&a.results),
    )
    .replace("## Each policy", &format!("{field}## Each policy")))
}

/// The paper's tables when every policy measured is TopA's (`report::paper_for`).
fn paper(a: &Ablation) -> Result<Option<report::PaperTables>> {
    report::paper_for(a.results.iter().map(|r| r.trained_on.as_str()))
}

/// The perturbation test's group scores with their intervals, and what they came from.
fn physics_summary(p: &super::physics::report::PhysicsReport) -> String {
    let cases = p.entries.first().map_or(0, |e| e.result.perturbed().len());
    format!(
        "Each seed under {cases} perturbations of the simulator (`topa physics`, matrix {}; {}); a perturbation is \
         survived when every tracking and push bar holds there.\n\n{}",
        p.matrix.source,
        p.protocol.describe(),
        super::physics::render::groups_markdown(p)
    )
}

/// The real-world test's tables and claims, when a field report is attached (empty otherwise).
fn field_section(a: &Ablation) -> Result<String> {
    Ok(match &a.field {
        Some(f) => format!(
            "{}\n{}",
            super::field::markdown(f, super::field::paper(f)?.as_ref()),
            super::field::claims_markdown(f)
        ),
        None => String::new(),
    })
}

/// One section of the report by name, for the pages that show it (README.md): "headline", "claims" (every claim
/// and every seed's bars), "summary" (the group claims, and the bars one line per group), "field" (the real-world
/// test's tables and claims) or "field_tables".
pub fn section(a: &Ablation, kind: &str) -> Result<String> {
    let paper = paper(a)?;
    let paper = paper.as_ref();
    let g = groups::group(&a.results);
    match kind {
        "headline" => Ok(groups::headline_markdown(&g, paper, a.extent.resolution().push)),
        "claims" => Ok(super::claims::markdown(&super::claims::check(&g, a.extent.resolution(), paper))),
        "summary" => Ok(super::claims::summary_markdown(&g, a.extent.resolution(), paper)),
        "field" => field_section(a),
        "field_tables" => Ok(match &a.field {
            Some(f) => super::field::markdown(f, super::field::paper(f)?.as_ref()),
            None => String::new(),
        }),
        "terrain" => Ok(a.terrain.as_ref().map_or(String::new(), super::terrain_report::markdown)),
        "physics" => Ok(a.physics.as_ref().map_or(String::new(), physics_summary)),
        _ => invalid!(
            "no report section {kind:?}: use headline, claims, summary, field, field_tables, terrain or physics"
        ),
    }
}

/// Writes ablation.{md,json}, per-policy CSVs, and each group's mean heatmaps (standing and walking) into `out`.
pub fn write(a: &Ablation, out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).map_err(Error::io("creating", out))?;
    report::write_text(out, "ablation.md", &markdown(a)?)?;
    report::write_json(out, "ablation.json", a)?;
    let mut seen: Vec<(Group, usize)> = Vec::new();
    for r in &a.results {
        // The k-th policy of a group is NAME_k (NAME alone for the first), so that seeds never overwrite each other.
        let k = match seen.iter_mut().find(|(n, _)| *n == r.name) {
            Some((_, k)) => {
                *k += 1;
                *k
            }
            None => {
                seen.push((r.name, 1));
                1
            }
        };
        let stem = if k == 1 { r.name.key().to_string() } else { format!("{}_{k}", r.name.key()) };
        report::write_text(out, &format!("{stem}_tracking.csv"), &report::tracking_csv(&r.tracking))?;
        report::write_text(out, &format!("{stem}_push.csv"), &report::push_csv(&r.push))?;
        if let Some(w) = &r.push_walking {
            report::write_text(out, &format!("{stem}_push_walking.csv"), &report::push_csv(w))?;
        }
        report::write_text(out, &format!("{stem}_noise.csv"), &report::noise_csv(&r.noise))?;
    }
    let g = groups::group(&a.results);
    let mean = |walking: bool| -> Vec<(String, PushGrid)> {
        g.iter()
            .filter_map(|grp| {
                let grids =
                    grp.members.iter().filter_map(|r| if walking { r.push_walking.as_ref() } else { Some(&r.push) });
                let n = grp.members.len();
                let mut title = grp.name.label().to_string();
                if walking {
                    let c = a.extent.walking_push_command;
                    title += &format!(
                        ", walking {}",
                        if c[1] == 0.0 && c[2] == 0.0 { format!("{} m/s", c[0]) } else { format!("{c:?}") }
                    );
                }
                if n > 1 {
                    title += &format!(" (mean of {n})");
                }
                groups::mean_grid(grids).map(|m| (title, m))
            })
            .collect()
    };
    for (walking, stem) in [(false, "heatmaps"), (true, "heatmaps_walking")] {
        let grids = mean(walking);
        if grids.is_empty() {
            continue;
        }
        let refs: Vec<(String, &PushGrid)> = grids.iter().map(|(n, g)| (n.clone(), g)).collect();
        super::heatmaps::push_heatmaps(&refs, &out.join(format!("{stem}.png")), &out.join(format!("{stem}.svg")))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::results::{NoiseRow, TrackingRow};

    #[test]
    fn push_grid_flags_are_checked_and_described() {
        let full = Extent::full();
        full.check().unwrap();
        assert!(full.paper_push_range());
        assert_eq!(
            full.describe(),
            "13×13 push grid to ±30 N, 100 noise runs of 20 s per level, 10 starts per tracking command"
        );
        let no_start = Extent { tracking_starts: 0, ..Extent::full() };
        assert!(no_start.check().unwrap_err().to_string().contains("--starts"));
        assert!(Extent::quick().describe().starts_with("7×7 push grid to ±30 N"));
        let strong = Extent { push_range_n: 60.0, push_step_n: 10.0, ..Extent::full() };
        assert!(!strong.paper_push_range());
        assert!(strong.describe().starts_with("13×13 push grid to ±60 N"));
        let zero_step = Extent { push_step_n: 0.0, ..Extent::full() };
        assert!(zero_step.check().unwrap_err().to_string().contains("--step"));
        let negative = Extent { push_range_n: -1.0, ..Extent::full() };
        assert!(negative.check().unwrap_err().to_string().contains("--range"));
        let uneven = Extent { push_range_n: 25.0, push_step_n: 10.0, ..Extent::full() };
        assert!(crate::error::chain(&uneven.check().unwrap_err()).contains("not a multiple"));
    }

    fn one(name: &str, policy: &str, t_fall: f64) -> PolicyResults {
        let gait = super::super::gait::GaitStats { air_time_s: f64::NAN, ..Default::default() };
        let row = TrackingRow {
            key: "walk_forward".into(),
            command: [0.5, 0.0, 0.0],
            mae: f64::NAN,
            mae_components: [f64::NAN, 0.1, 0.2],
            mae_whole: [0.1, 0.2, 0.3],
            mae_paper: 0.6,
            mean_torque: 30.0,
            mean_roll: 0.0,
            mean_pitch: 0.0,
            fell: true,
            fell_at: Some(1.5),
            gait,
            starts: 2,
            falls: Some(1),
            stood_still: Some(1),
        };
        let grid =
            PushGrid { axis: vec![-30.0, 0.0, 30.0], t_fall: vec![t_fall; 9], window_s: 10.0, command: [0.0; 3] };
        PolicyResults {
            name: Group::from_key(name).unwrap(),
            policy: policy.into(),
            weights_crc32: None,
            trained_on: "closed".into(),
            tracking: vec![row],
            push: grid.clone(),
            push_walking: Some(grid),
            noise: vec![NoiseRow { sigma_v: 0.175, sigma_wz: 0.5, runs: 4, successes: 3, success_pct: 75.0 }],
        }
    }

    #[test]
    fn merged_ablations_read_back_whole_and_refuse_what_cannot_be_joined() {
        let dir = std::env::temp_dir().join(format!("topa-merge-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let settings = EvalSettings { threads: 1, ..Default::default() };
        let write = |file: &str, extent: Extent, results: Vec<PolicyResults>| {
            let a = Ablation { settings: settings.clone(), extent, results, field: None, terrain: None, physics: None };
            report::write_json(&dir, file, &a).unwrap();
            dir.join(file)
        };
        let ca = write("ca.json", Extent::full(), vec![one("CA", "ca1.json", 9.0)]);
        let c = write("c.json", Extent::full(), vec![one("C", "c1.json", 8.0), one("O", "o1.json", 4.0)]);
        // Thread count may differ: results do not depend on it.
        let mut more = settings.clone();
        more.threads = 2;
        let c2_ablation = Ablation {
            settings: more,
            extent: Extent::full(),
            results: vec![one("C", "c2.json", 7.0)],
            field: None,
            terrain: None,
            physics: None,
        };
        report::write_json(&dir, "c2.json", &c2_ablation).unwrap();
        let m = merge(&[ca.clone(), c.clone(), dir.join("c2.json")]).unwrap();
        let order: Vec<(&str, &str)> = m.results.iter().map(|r| (r.name.key(), r.policy.to_str().unwrap())).collect();
        assert_eq!(order, [("O", "o1.json"), ("C", "c1.json"), ("C", "c2.json"), ("CA", "ca1.json")]);
        let g = groups::group(&m.results);
        assert_eq!(g[1].t_fall_standing().mean, 7.5);
        // NaN (written as null) reads back as NaN, every other number exactly.
        let row = &m.results[1].tracking[0];
        assert!(row.mae.is_nan() && row.mae_components[0].is_nan() && row.gait.air_time_s.is_nan());
        assert_eq!((row.mae_components[2], row.fell_at, row.mae_paper), (0.2, Some(1.5), 0.6));
        assert_eq!((row.starts, row.falls, row.stood_still), (2, Some(1), Some(1)));

        // Reports written before tracking ran from several starts still read: one start, a fall counted from
        // `fell`, stand-stills unknown — and they do not merge with a protocol that has several.
        let mut old: serde_json::Value = serde_json::from_slice(&std::fs::read(&ca).unwrap()).unwrap();
        old["extent"].as_object_mut().unwrap().remove("tracking_starts");
        for k in ["starts", "falls", "stood_still"] {
            old["results"][0]["tracking"][0].as_object_mut().unwrap().remove(k);
        }
        report::write_json(&dir, "old.json", &old).unwrap();
        let o: Ablation = serde_json::from_slice(&std::fs::read(dir.join("old.json")).unwrap()).unwrap();
        let t = &o.results[0].tracking[0];
        assert_eq!((o.extent.tracking_starts, t.starts, t.falls, t.stood_still, t.fall_count()), (1, 1, None, None, 1));
        assert!(
            crate::error::chain(&merge(&[c.clone(), dir.join("old.json")]).unwrap_err()).contains("another protocol")
        );

        let err = |files: &[PathBuf]| crate::error::chain(&merge(files).unwrap_err());
        let quick = write("quick.json", Extent::quick(), vec![one("C", "c3.json", 7.0)]);
        assert!(err(&[c.clone(), quick]).contains("another protocol"));
        let mut other = settings.clone();
        other.seed = 2;
        let s2 = Ablation {
            settings: other,
            extent: Extent::full(),
            results: vec![one("C", "c4.json", 7.0)],
            field: None,
            terrain: None,
            physics: None,
        };
        report::write_json(&dir, "seed2.json", &s2).unwrap();
        assert!(err(&[c.clone(), dir.join("seed2.json")]).contains("other evaluation settings"));
        assert!(err(&[c.clone(), c.clone()]).contains("c1.json is in more than one file"));
        std::fs::write(dir.join("policy.json"), "{\"weights\": \"policy.safetensors\"}").unwrap();
        assert!(err(&[c.clone(), dir.join("policy.json")]).contains("is not an ablation.json"));
        assert!(err(&[c.clone(), dir.join("missing.json")]).contains("cannot read"));
        // One file renders its report again (to attach a field test); none is an error.
        assert_eq!(merge(std::slice::from_ref(&c)).unwrap().results.len(), 2);
        assert!(err(&[]).contains("one or more"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn results_stay_tied_to_the_weights_they_measured() {
        use super::super::endurance::Operator;
        use super::super::field::{Field, FieldExtent, FieldPolicy};
        let dir = std::env::temp_dir().join(format!("topa-weights-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let shipped_path = topa_env::assets::repo_dir().join("assets/policies/C/seed1.json");
        let shipped = shipped_path.to_str().unwrap();
        let crc = trainer::policy_file::Policy::load(Path::new(shipped)).unwrap().meta.weights_crc32;
        let ablation = |measured: Option<u32>| {
            let r = PolicyResults { weights_crc32: measured, ..one("C", shipped, 8.0) };
            let settings = EvalSettings { threads: 1, ..Default::default() };
            Ablation { settings, extent: Extent::full(), results: vec![r], field: None, terrain: None, physics: None }
        };
        // Merging: the policy file at the recorded path must still hold the weights measured.
        for (file, measured) in [("same.json", Some(crc)), ("unrecorded.json", None), ("stale.json", Some(crc ^ 1))] {
            report::write_json(&dir, file, &ablation(measured)).unwrap();
        }
        assert_eq!(merge(&[dir.join("same.json")]).unwrap().results[0].weights_crc32, Some(crc));
        assert!(merge(&[dir.join("unrecorded.json")]).is_ok());
        let stale = crate::error::chain(&merge(&[dir.join("stale.json")]).unwrap_err());
        assert!(stale.contains("now holds") && stale.contains(shipped), "{stale}");
        // A file that is not on this machine cannot be checked: let through.
        let mut elsewhere = ablation(Some(7));
        elsewhere.results[0].policy = "elsewhere/c9.json".into();
        report::write_json(&dir, "elsewhere.json", &elsewhere).unwrap();
        assert!(merge(&[dir.join("elsewhere.json")]).is_ok());

        // Attaching: a field test of the same path must have measured the same weights.
        let field = |measured: Option<u32>| Field {
            extent: FieldExtent {
                course: "c.toml".into(),
                speeds: vec![0.5],
                endurance_minutes: 1.0,
                modes: vec![],
                operator: Operator::default(),
            },
            settings: EvalSettings::default(),
            results: vec![FieldPolicy {
                name: Group::C,
                policy: shipped.into(),
                weights_crc32: measured,
                trained_on: None,
                modes: vec![],
            }],
        };
        for (measured, ok) in [(Some(crc), true), (None, true), (Some(crc ^ 1), false)] {
            let a = Ablation { field: Some(field(measured)), ..ablation(Some(crc)) };
            assert_eq!(check_attached_weights(&a, &measured_weights(&a)).is_ok(), ok, "{measured:?}");
        }
        let a = Ablation { field: Some(field(Some(crc ^ 1))), ..ablation(Some(crc)) };
        let e = crate::error::chain(&check_attached_weights(&a, &measured_weights(&a)).unwrap_err());
        assert!(e.contains("--field") && e.contains("topa field"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
