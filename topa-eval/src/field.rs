//! The paper's real-world test over groups of seeds (`topa field`): every policy driven over the course at each
//! top speed and run for the endurance minutes, in each sim2sim mode; per group and mode the share of seeds that
//! reach the goal, finish clean, the best clean time, joint-limit hits and the endurance interventions, with the
//! paper's numbers beside; and the paper's three real-world claims, each answered yes or no with the numbers.

use crate::merge::Mergeable;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use topa_env::course::Course;
use topa_env::policy_runner::PolicyRunner;

use super::course::{self, CourseResult};
use super::endurance::{self, EnduranceRun, Operator};
use super::groups::Stat;
use super::report::{self, PaperTables};
use super::results::Group;
use super::settings::{EvalSettings, Sim2SimMode};
use crate::error::{ensure, Result};

/// What the field test runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FieldExtent {
    pub course: PathBuf,
    pub speeds: Vec<f64>,
    pub endurance_minutes: f64,
    pub modes: Vec<Sim2SimMode>,
    pub operator: Operator,
}

/// One policy in one sim2sim mode.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FieldMode {
    pub sim2sim: Sim2SimMode,
    pub course: CourseResult,
    pub endurance: EnduranceRun,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FieldPolicy {
    pub name: Group,
    pub policy: PathBuf,
    /// CRC-32 of the weights measured (as in `PolicyResults`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weights_crc32: Option<u32>,
    /// The robot spec it was trained on (absent in reports written before it was recorded, all of them TopA's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trained_on: Option<String>,
    pub modes: Vec<FieldMode>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Field {
    pub extent: FieldExtent,
    /// Evaluation settings apart from the sim2sim mode (the extent's modes replace it).
    pub settings: EvalSettings,
    pub results: Vec<FieldPolicy>,
}

/// Runs the course and the endurance run for each (group, policy) in each mode.
pub fn run(policies: &[(Group, PathBuf)], base: &EvalSettings, extent: &FieldExtent) -> Result<Field> {
    ensure!(!policies.is_empty(), "give at least one policy with --o, --c or --ca");
    let map = Course::load(&topa_env::assets::resolve_path(&extent.course.to_string_lossy()))?;
    let mut results = Vec::new();
    for (group, path) in policies {
        let mut runner = PolicyRunner::load(path, group.label())?;
        let mut modes = Vec::new();
        for mode in &extent.modes {
            let s = base.clone().with_sim2sim(mode)?;
            eprintln!(
                "{}: {} — course and {} min run, {mode} sim2sim",
                group.label(),
                path.display(),
                extent.endurance_minutes
            );
            let course = course::run(&mut runner, &map, &s, &extent.speeds, None)?;
            let endurance = endurance::run(&mut runner, &s, extent.endurance_minutes, 1, &extent.operator)?.remove(0);
            modes.push(FieldMode { sim2sim: mode.clone(), course, endurance });
        }
        let weights_crc32 = Some(runner.policy.meta.weights_crc32);
        let trained_on = Some(runner.trained_on().to_string());
        results.push(FieldPolicy { name: *group, policy: path.clone(), weights_crc32, trained_on, modes });
    }
    Ok(Field { extent: extent.clone(), settings: base.clone(), results })
}

/// Joins field tests of the same course, speeds, minutes and settings (`--merge`, the rule of every report:
/// `crate::merge`); a policy's runs in other sim2sim modes join its modes.
pub fn merge(files: &[PathBuf]) -> Result<Field> {
    crate::merge::merge(files)
}

impl Mergeable for Field {
    const FILE: &'static str = "field.json";
    const COMMAND: &'static str = "topa field";

    fn protocol(&self) -> (serde_json::Value, String) {
        let e = FieldExtent { modes: Vec::new(), ..self.extent.clone() };
        let text = format!(
            "course {}, speeds {:?} m/s, {} endurance minutes",
            e.course.display(),
            e.speeds,
            e.endurance_minutes
        );
        (serde_json::to_value(&e).unwrap_or_default(), text)
    }

    fn settings(&self) -> Option<&EvalSettings> {
        Some(&self.settings)
    }

    fn measured(&self) -> Vec<(PathBuf, Option<u32>)> {
        self.results.iter().map(|r| (r.policy.clone(), r.weights_crc32)).collect()
    }

    const JOINS_A_POLICY: bool = true;

    fn absorb(&mut self, part: Field) -> Result<()> {
        for mode in &part.extent.modes {
            if !self.extent.modes.contains(mode) {
                self.extent.modes.push(mode.clone());
            }
        }
        for r in part.results {
            let Some(q) = self.results.iter_mut().find(|q| q.policy == r.policy) else {
                self.results.push(r);
                continue;
            };
            ensure!(q.name == r.name, "--merge: {} is in two groups", r.policy.display());
            // A file written before reports recorded weights says nothing: keep the one that does.
            q.weights_crc32 = q.weights_crc32.or(r.weights_crc32);
            for m in r.modes {
                ensure!(
                    !q.modes.iter().any(|x| x.sim2sim == m.sim2sim),
                    "--merge: policy {} in {} sim2sim is in more than one file; it would count as two seeds",
                    r.policy.display(),
                    m.sim2sim
                );
                q.modes.push(m);
            }
        }
        Ok(())
    }

    fn finish(&mut self) {
        // Ideal before realistic before files, whatever order the parts came in.
        let rank = |m: &Sim2SimMode| match m {
            Sim2SimMode::Ideal => 0,
            Sim2SimMode::Realistic => 1,
            Sim2SimMode::File(_) => 2,
        };
        self.extent.modes.sort_by_key(rank);
        for r in &mut self.results {
            r.modes.sort_by_key(|m| rank(&m.sim2sim));
        }
        self.results.sort_by_key(|r| r.name);
    }
}

/// Reads a field.json.
pub fn load(file: &Path) -> Result<Field> {
    crate::merge::read(file, "--field")
}

/// One group in one mode.
struct GroupMode<'a> {
    group: Group,
    runs: Vec<&'a FieldMode>,
}

fn by_group<'a>(f: &'a Field, mode: &Sim2SimMode) -> Vec<GroupMode<'a>> {
    Group::ALL
        .into_iter()
        .map(|group| GroupMode {
            group,
            runs: f
                .results
                .iter()
                .filter(|r| r.name == group)
                .filter_map(|r| r.modes.iter().find(|m| &m.sim2sim == mode))
                .collect(),
        })
        .filter(|g| !g.runs.is_empty())
        .collect()
}

impl GroupMode<'_> {
    fn n(&self) -> usize {
        self.runs.len()
    }
    fn reached(&self) -> usize {
        self.runs.iter().filter(|m| m.course.finished()).count()
    }
    fn clean_times(&self) -> Vec<f64> {
        self.runs.iter().filter_map(|m| m.course.best_clean_time()).collect()
    }
    fn limit_hits(&self) -> Stat {
        Stat::of(&self.runs.iter().map(|m| m.course.max_joint_limit_hits_per_min()).collect::<Vec<_>>())
    }
    fn endurance_clean(&self) -> usize {
        self.runs.iter().filter(|m| m.endurance.interventions == 0).count()
    }
    fn endurance_interventions(&self) -> Stat {
        Stat::of(&self.runs.iter().map(|m| m.endurance.interventions as f64).collect::<Vec<_>>())
    }
}

/// The integrator and timestep a mode runs with, as this build resolves the mode (a result file names its modes,
/// not their models).
fn physics(base: &EvalSettings, mode: &Sim2SimMode) -> String {
    match base.clone().with_sim2sim(mode) {
        Ok(s) if s.integrator() == topa_env::IntegratorChoice::Model => {
            format!(", the MJCF's integrator at {} s", s.timestep())
        }
        Ok(s) => format!(", {} at {} s", s.integrator(), s.timestep()),
        Err(_) => String::new(),
    }
}

/// The group table per mode, with the paper's numbers beside.
pub fn markdown(f: &Field, paper: Option<&PaperTables>) -> String {
    let e = &f.extent;
    let mut s = format!(
        "Course {} at top speeds {:?} m/s (the best clean time is the fastest run with no intervention); a {}-minute \
         run under a joystick operator with pushes.{}\n",
        e.course.display(),
        e.speeds,
        e.endurance_minutes,
        if paper.is_some() { " Cells: ours (paper, the real robot)." } else { "" }
    );
    for mode in &e.modes {
        s.push_str(&format!(
            "\n{mode} sim2sim{}:\n\n| Group | seeds | reach the goal | finish clean | best clean time, min (mean ± sd) | joint-limit hits/min | {} min without intervention | interventions in {} min |\n|---|---:|---:|---:|---:|---:|---:|---:|\n",
            physics(&f.settings, mode),
            e.endurance_minutes,
            e.endurance_minutes
        ));
        for g in by_group(f, mode) {
            let times: Vec<f64> = g.clean_times().iter().map(|t| t / 60.0).collect();
            let paper_time = match (paper, g.group) {
                (None, _) => String::new(),
                (Some(_), Group::O) => " (did not finish)".to_string(),
                (Some(p), k) => p.course_minutes.get(k.key()).map_or(String::new(), |m| format!(" ({m:.1})")),
            };
            let paper_endurance = match paper {
                Some(p) if g.group == Group::CA => format!(" ({:.0} min)", p.continuous_minutes_ca),
                _ => String::new(),
            };
            s.push_str(&format!(
                "| {} | {} | {}/{} | {}/{} | {}{paper_time} | {} | {}/{}{paper_endurance} | {} |\n",
                g.group.label(),
                g.n(),
                g.reached(),
                g.n(),
                times.len(),
                g.n(),
                if times.is_empty() { "–".into() } else { Stat::of(&times).show(2) },
                g.limit_hits().show(1),
                g.endurance_clean(),
                g.n(),
                g.endurance_interventions().show(1)
            ));
        }
    }
    s
}

/// The paper's real-world claims per mode: (claim, verdict — None when the data cannot decide —, numbers).
pub fn claims(f: &Field) -> Vec<(String, Option<bool>, String)> {
    let mut out = Vec::new();
    for mode in &f.extent.modes {
        let groups = by_group(f, mode);
        let get = |k: Group| groups.iter().find(|g| g.group == k);
        if let Some(o) = get(Group::O) {
            let clean = o.clean_times().len();
            // Strictly the most: O tied with another group (all at zero, say) does not have the most.
            let others: Vec<_> = groups.iter().filter(|g| g.group != Group::O).collect();
            let most_hits = !others.is_empty() && others.iter().all(|g| g.limit_hits().mean < o.limit_hits().mean);
            out.push((
                format!("{mode}: O does not finish cleanly at any speed, or has the most joint-limit hits"),
                Some(clean == 0 || most_hits),
                format!(
                    "O: {clean}/{} seeds finish clean; joint-limit hits/min {}",
                    o.n(),
                    groups
                        .iter()
                        .map(|g| format!("{} {}", g.group.label(), g.limit_hits().show(1)))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        for k in [Group::C, Group::CA] {
            if let Some(g) = get(k) {
                out.push((
                    format!("{mode}: every {} seed reaches the goal", k.label()),
                    Some(g.reached() == g.n()),
                    format!("{}/{} seeds", g.reached(), g.n()),
                ));
            }
        }
        if let (Some(c), Some(ca)) = (get(Group::C), get(Group::CA)) {
            let (tc, tca) = (c.clean_times(), ca.clean_times());
            out.push(faster_claim(mode, &tc, c.n(), &tca, ca.n()));
            out.push((
                format!("{mode}: C+A runs {} min without intervention on every seed", f.extent.endurance_minutes),
                Some(ca.endurance_clean() == ca.n()),
                format!(
                    "{}/{} seeds; interventions per seed: {:?}",
                    ca.endurance_clean(),
                    ca.n(),
                    ca.runs.iter().map(|m| m.endurance.interventions).collect::<Vec<_>>()
                ),
            ));
        }
    }
    out
}

pub fn claims_markdown(f: &Field) -> String {
    let mut s = String::from("| real-world claim (in simulation) | holds | numbers |\n|---|---|---|\n");
    for (claim, holds, numbers) in claims(f) {
        let verdict = match holds {
            Some(true) => "yes",
            Some(false) => "**no**",
            None => "undecided: fewer than 5 clean seeds a group, or an interval across zero",
        };
        s.push_str(&format!("| {claim} | {verdict} | {numbers} |\n"));
    }
    s
}

/// "C+A's best clean time below C's": the difference of the groups' mean best clean times (C − C+A, the time C+A
/// saves) with its bootstrap 95 % interval, decided as the ablation's claims are — when both groups have
/// `MIN_RUNS_FOR_VERDICT` clean seeds and the interval excludes zero; a group with no clean seed decides it at once.
fn faster_claim(mode: &Sim2SimMode, tc: &[f64], nc: usize, tca: &[f64], nca: usize) -> (String, Option<bool>, String) {
    use super::intervals::{self, Resampling, Scores};
    let statement = format!("{mode}: C+A's best clean time below C's (paper: about half)");
    let counts = format!(
        "C {} s ({}/{nc} seeds clean), C+A {} s ({}/{nca} seeds clean)",
        Stat::of(tc).show(0),
        tc.len(),
        Stat::of(tca).show(0),
        tca.len()
    );
    match (tc.is_empty(), tca.is_empty()) {
        (_, true) => return (statement, Some(false), counts),
        (true, false) => return (statement, Some(true), counts),
        _ => {}
    }
    let Some((diff, p)) = intervals::compare(&Scores::per_run(tc), &Scores::per_run(tca), Resampling { tasks: false })
    else {
        return (statement, None, counts);
    };
    let enough = tc.len().min(tca.len()) >= intervals::MIN_RUNS_FOR_VERDICT;
    let ratio = Stat::of(tca).mean / Stat::of(tc).mean;
    (
        statement,
        if enough { diff.sign() } else { None },
        format!(
            "{counts}; C − C+A {} s, P(C slower) {}; C+A / C {ratio:.2} (paper about 0.5)",
            diff.show(0),
            p.show(2)
        ),
    )
}

/// The paper's tables when every policy driven is TopA's (`report::paper_for`; a report without the robots
/// recorded is TopA's).
pub fn paper(f: &Field) -> Result<Option<PaperTables>> {
    report::paper_for(f.results.iter().map(|r| r.trained_on.as_deref().unwrap_or("topa_closed")))
}

/// Writes field.md and field.json into `out`.
pub fn write(f: &Field, out: &Path) -> Result<String> {
    let md = format!("{}\n{}", markdown(f, paper(f)?.as_ref()), claims_markdown(f));
    report::write_text(out, "field.md", &md)?;
    report::write_json(out, "field.json", f)?;
    Ok(md)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::course::CourseRun;

    fn run(speed: f64, finished: bool, time_s: f64, falls: usize, hits: f64) -> CourseRun {
        CourseRun {
            top_speed: speed,
            finished,
            time_s,
            falls,
            wall_contacts: 0,
            stuck: 0,
            joint_limit_hits_per_min: hits,
            mean_off_path_m: 0.0,
            max_off_path_m: 0.0,
            progress_m: 0.0,
            trajectory: vec![],
            intervention_at: vec![],
        }
    }

    fn policy(name: Group, file: &str, runs: Vec<CourseRun>, endurance_falls: usize) -> FieldPolicy {
        FieldPolicy {
            name,
            policy: file.into(),
            weights_crc32: None,
            trained_on: None,
            modes: vec![FieldMode {
                sim2sim: Sim2SimMode::Ideal,
                course: CourseResult { course: "t".into(), length_m: 100.0, runs },
                endurance: EnduranceRun { minutes: 40.0, interventions: endurance_falls, ..Default::default() },
            }],
        }
    }

    fn field(results: Vec<FieldPolicy>) -> Field {
        Field {
            extent: FieldExtent {
                course: "assets/courses/indoor.toml".into(),
                speeds: vec![0.3, 0.7],
                endurance_minutes: 40.0,
                modes: vec![Sim2SimMode::Ideal],
                operator: Operator::default(),
            },
            settings: EvalSettings::default(),
            results,
        }
    }

    #[test]
    fn the_papers_claims_are_answered_from_the_runs() {
        let f = field(vec![
            policy(Group::O, "o1", vec![run(0.3, false, 1000.0, 4, 3.0), run(0.7, true, 400.0, 2, 5.0)], 7),
            policy(Group::C, "c1", vec![run(0.3, true, 400.0, 0, 0.5), run(0.7, true, 200.0, 1, 1.0)], 1),
            policy(Group::C, "c2", vec![run(0.3, true, 420.0, 0, 0.0), run(0.7, true, 190.0, 0, 0.2)], 0),
            policy(Group::CA, "ca1", vec![run(0.3, true, 410.0, 0, 0.0), run(0.7, true, 150.0, 0, 0.0)], 0),
        ]);
        let c = claims(&f);
        let holds: Vec<Option<bool>> = c.iter().map(|x| x.1).collect();
        // O never clean; C and C+A all reach the goal; C+A's best clean time (150) below C's mean (400, 190 → 295)
        // but on one and two seeds: no verdict; C+A 40 minutes clean.
        assert_eq!(holds, [Some(true), Some(true), Some(true), None, Some(true)], "{c:?}");
        assert!(c[3].2.contains("C 295 ± 148 s (2/2 seeds clean)"), "{}", c[3].2);
        let md = markdown(&f, Some(&report::paper().unwrap()));
        assert!(md.contains("| O | 1 | 1/1 | 0/1 | – (did not finish) | 5.0 |"), "{md}");
        assert!(md.contains("| C+A | 1 | 1/1 | 1/1 | 2.50 (3.1) |"), "{md}");
        // Another robot's runs: ours alone, none of the paper's numbers beside them.
        let mut other = f.clone();
        other.results.iter_mut().for_each(|r| r.trained_on = Some("cassie".into()));
        let md = markdown(&other, paper(&other).unwrap().as_ref());
        assert!(
            md.contains("| O | 1 | 1/1 | 0/1 | – | 5.0 |") && md.contains("| C+A | 1 | 1/1 | 1/1 | 2.50 |"),
            "{md}"
        );
        assert!(!md.contains("(paper") && paper(&f).unwrap().is_some(), "{md}");

        // Five seeds each: C+A clearly faster, then clearly slower — decided both ways, with the interval.
        let seeds = |g: Group, times: [f64; 5], interventions: usize| -> Vec<FieldPolicy> {
            times
                .iter()
                .enumerate()
                .map(|(i, &t)| policy(g, &format!("{g:?}{i}"), vec![run(0.7, true, t, 0, 0.0)], interventions))
                .collect()
        };
        let faster = [
            seeds(Group::C, [300.0, 320.0, 310.0, 290.0, 305.0], 0),
            seeds(Group::CA, [160.0, 170.0, 150.0, 165.0, 155.0], 0),
        ]
        .concat();
        let c = claims(&field(faster));
        let claim = c.iter().find(|x| x.0.contains("best clean time")).unwrap();
        assert_eq!(claim.1, Some(true), "{claim:?}");
        assert!(claim.2.contains("C − C+A 145 [134, 156] s") && claim.2.contains("C+A / C 0.52"), "{}", claim.2);
        let slower = [
            seeds(Group::C, [150.0, 155.0, 160.0, 152.0, 158.0], 0),
            seeds(Group::CA, [170.0, 175.0, 180.0, 172.0, 171.0], 2),
        ]
        .concat();
        let c = claims(&field(slower));
        assert_eq!(
            c.iter().map(|x| x.1).collect::<Vec<_>>(),
            [Some(true), Some(true), Some(false), Some(false)],
            "{c:?}"
        );
        assert!(c[3].2.contains("interventions per seed: [2, 2, 2, 2, 2]"), "{}", c[3].2);
        assert!(claims_markdown(&field(vec![])).contains("| holds |"));

        // O finishing clean is the paper's claim broken unless it hits the joint limits most; a tie is not most.
        let o_clean = |o_hits: f64, c_hits: f64| {
            claims(&field(vec![
                policy(Group::O, "o1", vec![run(0.7, true, 300.0, 0, o_hits)], 0),
                policy(Group::C, "c1", vec![run(0.7, true, 200.0, 0, c_hits)], 0),
            ]))[0]
                .1
        };
        assert_eq!(o_clean(0.0, 0.0), Some(false));
        assert_eq!(o_clean(1.0, 1.0), Some(false));
        assert_eq!(o_clean(2.0, 1.0), Some(true));
        assert_eq!(o_clean(1.0, 2.0), Some(false));
    }

    #[test]
    fn each_modes_table_names_its_physics() {
        let base = EvalSettings::default();
        assert_eq!(physics(&base, &Sim2SimMode::Realistic), ", euler at 0.001 s");
        assert_eq!(physics(&base, &Sim2SimMode::Ideal), ", the MJCF's integrator at 0.0025 s");
        assert_eq!(physics(&base, &Sim2SimMode::File("no/such.toml".into())), "");
    }

    #[test]
    fn merging_refuses_other_extents_and_double_policies() {
        let dir = std::env::temp_dir().join(format!("topa-field-merge-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let write = |name: &str, f: &Field| {
            report::write_json(&dir, name, f).unwrap();
            dir.join(name)
        };
        let a = write("a.json", &field(vec![policy(Group::C, "c1", vec![run(0.7, true, 150.0, 0, 0.0)], 0)]));
        let b = write("b.json", &field(vec![policy(Group::O, "o1", vec![run(0.7, false, 900.0, 3, 2.0)], 5)]));
        let m = merge(&[a.clone(), b.clone()]).unwrap();
        assert_eq!(m.results.iter().map(|r| r.name).collect::<Vec<_>>(), [Group::O, Group::C]);
        let err = crate::error::chain(&merge(&[a.clone(), a.clone()]).unwrap_err());
        assert!(err.contains("c1 in ideal sim2sim is in more than one file"), "{err}");
        // The same policy in another mode joins its modes: ideal first, whatever the order of the files.
        let mut realistic = field(vec![policy(Group::C, "c1", vec![run(0.7, true, 170.0, 0, 0.0)], 1)]);
        realistic.extent.modes = vec![Sim2SimMode::Realistic];
        realistic.results[0].modes[0].sim2sim = Sim2SimMode::Realistic;
        let r = write("r.json", &realistic);
        let m = merge(&[r, a.clone(), b.clone()]).unwrap();
        assert_eq!(m.extent.modes, [Sim2SimMode::Ideal, Sim2SimMode::Realistic]);
        let c1 = m.results.iter().find(|p| p.name == Group::C).unwrap();
        assert_eq!(c1.modes.iter().map(|x| x.sim2sim.clone()).collect::<Vec<_>>(), m.extent.modes);
        assert_eq!(c1.modes[1].endurance.interventions, 1);
        // Its realistic run measured other weights than its ideal one: refused.
        realistic.results[0].weights_crc32 = Some(2);
        let mut ideal = field(vec![policy(Group::C, "c1", vec![run(0.7, true, 150.0, 0, 0.0)], 0)]);
        ideal.results[0].weights_crc32 = Some(1);
        let (r, i) = (write("r2.json", &realistic), write("i2.json", &ideal));
        assert!(
            crate::error::chain(&merge(&[i.clone(), r]).unwrap_err()).contains("c1 was measured with other weights")
        );
        // An earlier file that recorded no weights takes the later file's, whichever mode came first.
        realistic.results[0].weights_crc32 = None;
        let r = write("r3.json", &realistic);
        for files in [[r.clone(), i.clone()], [i, r]] {
            let m = merge(&files).unwrap();
            assert_eq!(m.results.iter().find(|p| p.name == Group::C).unwrap().weights_crc32, Some(1));
        }
        let mut other = field(vec![policy(Group::CA, "ca1", vec![], 0)]);
        other.extent.endurance_minutes = 10.0;
        let o = write("o.json", &other);
        assert!(crate::error::chain(&merge(&[a, o]).unwrap_err()).contains("another protocol (course"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
