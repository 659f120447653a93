//! The paper's robustness claims and the gait and tracking bars, checked on the groups' numbers: each line says
//! whether it holds, with the numbers it rests on — so that a report states a negative as plainly as a positive.

use std::fmt::Write as _;

use super::groups::{GroupResults, Stat};
use super::intervals::{self, Interval, Resampling, Scores};
use super::report::PaperTables;
use super::results::{Group, PolicyResults};

/// One checked statement.
#[derive(Debug, Clone, PartialEq)]
pub struct Claim {
    pub statement: String,
    /// None: no verdict — a group it needs is missing, or an interval straddles zero (see `undecided`).
    pub holds: Option<bool>,
    pub evidence: String,
    /// What the report says when there is no verdict.
    pub undecided: &'static str,
}

/// How finely the data resolve a claim: how the push grid is resampled, and whether the protocol is the quick one
/// (whose grid and noise runs are coarser than the paper's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resolution {
    pub push: Resampling,
    pub quick: bool,
}

const TOO_FEW: &str = "undecided: fewer than 5 seeds in a group, too few for a bootstrap interval to decide";

impl Resolution {
    fn undecided(&self) -> &'static str {
        if self.quick {
            "undecided: the 95 % CI includes zero; the quick protocol is too coarse to decide, run `--full`"
        } else {
            "undecided: the 95 % CI includes zero"
        }
    }
}

/// A claim that group x beats group y, judged on the 95 % interval of the difference of their means.
fn improvement(statement: String, x: &Scores, y: &Scores, how: Resampling, res: Resolution, unit: &str) -> Claim {
    let Some((d, p)) = intervals::compare(x, y, how) else {
        return Claim { statement, holds: None, evidence: "a group has no numbers".into(), undecided: "–" };
    };
    let digits = if unit == "s" { 2 } else { 0 };
    let enough = x.len() >= intervals::MIN_RUNS_FOR_VERDICT && y.len() >= intervals::MIN_RUNS_FOR_VERDICT;
    Claim {
        statement,
        holds: if enough { d.sign() } else { None },
        evidence: format!(
            "difference {} {unit} [{}, {}], P(improvement) {}",
            signed(d.point, digits),
            signed(d.lo, digits),
            signed(d.hi, digits),
            p.show(2)
        ),
        undecided: if enough { res.undecided() } else { TOO_FEW },
    }
}

fn signed(x: f64, digits: usize) -> String {
    format!("{x:+.digits$}")
}

/// Bars a shipped C or C+A policy must meet: every tracking command without a fall, each component's
/// whole-window MAE within this bound, and at 0.5 m/s this gait.
pub const MAX_COMPONENT_MAE: f64 = 0.15;
pub const MIN_AIR_TIME_S: f64 = 0.2;
pub const MIN_CLEARANCE_M: f64 = 0.03;
pub const MAX_STEPS_PER_S: f64 = 2.5;
/// The mean time to fall C+A must reach (the paper's C+A: 9.71 s).
pub const MIN_CA_T_FALL_S: f64 = 9.0;

fn find<'a, 'b>(groups: &'a [GroupResults<'b>], name: Group) -> Option<&'a GroupResults<'b>> {
    groups.iter().find(|g| g.name == name)
}

fn known(s: Stat) -> Option<Stat> {
    s.mean.is_finite().then_some(s)
}

/// The claims that compare groups (O, C, CA by name), and the bars each C and C+A policy must meet. A comparison
/// holds when the 95 % interval of the difference lies above zero (rliable's reading), fails when it lies below.
/// `paper`: the paper's tables, whose numbers the claims quote beside ours (None for a robot other than TopA).
pub fn check(groups: &[GroupResults], res: Resolution, paper: Option<&PaperTables>) -> Vec<Claim> {
    let mut out = group_claims(groups, res, paper);
    for g in groups.iter().filter(|g| matches!(g.name, Group::C | Group::CA)) {
        for r in &g.members {
            out.extend(policy_bars(r));
        }
    }
    out
}

/// The claims about groups (orderings, differences with their intervals), without the per-seed bars.
fn group_claims(groups: &[GroupResults], res: Resolution, paper: Option<&PaperTables>) -> Vec<Claim> {
    let mut out = Vec::new();
    let t = |name: Group| find(groups, name).and_then(|g| known(g.t_fall_standing()));
    let (o, c, ca) = (t(Group::O), t(Group::C), t(Group::CA));
    let paper_t =
        |g: Group| paper.and_then(|p| p.push_mean_t_fall.get(g.key())).map_or("–".into(), |x| format!("{x:.2}"));
    out.push(Claim {
        statement: "mean t_fall (standing pushes): O < C < C+A, on the means".into(),
        holds: match (o, c, ca) {
            (Some(o), Some(c), Some(ca)) => Some(o.mean < c.mean && c.mean < ca.mean),
            _ => None,
        },
        evidence: format!(
            "O {}, C {}, C+A {} s (mean ± sd{})",
            o.map_or("–".into(), |s| s.show(2)),
            c.map_or("–".into(), |s| s.show(2)),
            ca.map_or("–".into(), |s| s.show(2)),
            match paper {
                Some(_) => format!("; paper {} < {} < {}", paper_t(Group::O), paper_t(Group::C), paper_t(Group::CA)),
                None => String::new(),
            }
        ),
        undecided: "–",
    });
    let push = |name: Group| find(groups, name).map(|g| g.push_scores(false));
    for (x, y) in [(Group::C, Group::O), (Group::CA, Group::C)] {
        if let (Some(sx), Some(sy)) = (push(x), push(y)) {
            let statement = format!("{} − {} under standing pushes (mean t_fall): above zero", x.label(), y.label());
            out.push(improvement(statement, &sx, &sy, res.push, res, "s"));
        }
    }
    if let Some(g) = find(groups, Group::CA) {
        let ci: Interval = intervals::interval(&g.push_scores(false), res.push, intervals::mean);
        if ci.point.is_finite() {
            out.push(Claim {
                statement: format!("C+A mean t_fall ≥ {MIN_CA_T_FALL_S} s"),
                holds: Some(ci.point >= MIN_CA_T_FALL_S),
                evidence: match paper {
                    Some(_) => format!("{} s (paper {})", ci.show(2), paper_t(Group::CA)),
                    None => format!("{} s", ci.show(2)),
                },
                undecided: "–",
            });
        }
    }
    if let (Some(gc), Some(gca)) = (find(groups, Group::C), find(groups, Group::CA)) {
        let levels = gc.members.iter().chain(&gca.members).map(|r| r.noise.len()).min().unwrap_or(0);
        for i in 0..levels {
            let statement = format!("C+A − C success at command-noise level {}: above zero", i + 1);
            let (sc, sca) = (gc.noise_scores(i), gca.noise_scores(i));
            let all_succeed = |s: &Scores| s.runs.iter().all(|r| r[0] >= 100.0);
            if all_succeed(&sc) && all_succeed(&sca) {
                // Where both succeed every time there is nothing to be above.
                out.push(Claim { statement, holds: None, evidence: "both 100 %".into(), undecided: "tie" });
                continue;
            }
            out.push(improvement(statement, &sca, &sc, Resampling { tasks: false }, res, "%"));
        }
    }
    out
}

/// The claims about groups as a table, then per group one line on the per-seed bars: how many seeds meet all of
/// them, and what each other seed misses (the full report lists every bar of every seed).
pub fn summary_markdown(groups: &[GroupResults], res: Resolution, paper: Option<&PaperTables>) -> String {
    let mut s = markdown(&group_claims(groups, res, paper));
    s.push('\n');
    for g in groups.iter().filter(|g| matches!(g.name, Group::C | Group::CA)) {
        let misses: Vec<String> = g
            .members
            .iter()
            .filter_map(|r| {
                let missed: Vec<String> = policy_bars(r)
                    .into_iter()
                    .filter(|c| c.holds == Some(false))
                    .map(|c| {
                        let bar = c.statement.rsplit(": ").next().unwrap_or("").split(" (").next().unwrap_or("");
                        format!("{bar} — {}", c.evidence)
                    })
                    .collect();
                let seed = r.policy.file_stem().map_or(String::new(), |f| f.to_string_lossy().into_owned());
                (!missed.is_empty()).then(|| format!("{seed}: {}", missed.join("; ")))
            })
            .collect();
        let _ = writeln!(
            s,
            "- {} bars per seed (no fall, each MAE ≤ {MAX_COMPONENT_MAE}, no stand-still, gait): {}/{} seeds meet all{}",
            g.name.label(),
            g.members.len() - misses.len(),
            g.members.len(),
            if misses.is_empty() { String::new() } else { format!("; {}", misses.join(" · ")) }
        );
    }
    s
}

/// The bars for one C or C+A policy.
pub fn policy_bars(r: &PolicyResults) -> Vec<Claim> {
    tracking_bars(&format!("{} {}", r.name.label(), r.policy.display()), &r.tracking)
}

/// The largest whole-window MAE of any component on any command, with that command's key (NaNs skipped; ("", 0)
/// for no rows).
pub fn worst_component(tracking: &[super::results::TrackingRow]) -> (&str, f64) {
    tracking.iter().flat_map(|t| t.mae_whole.iter().map(move |m| (t.key.as_str(), *m))).fold(("", 0.0f64), |a, b| {
        if b.1 > a.1 {
            b
        } else {
            a
        }
    })
}

/// The bars on `who`'s tracking rows (the six commands, gait at 0.5 m/s): no fall, each component's MAE, no
/// stand-still (where starts were counted), gait.
pub fn tracking_bars(who: &str, tracking: &[super::results::TrackingRow]) -> Vec<Claim> {
    // "key (falls/starts)" for each command that fell, or stood still, from at least one start.
    let count = |n: usize, t: &super::results::TrackingRow| format!("{} ({n}/{})", t.key, t.starts);
    let falls: Vec<String> = tracking.iter().filter(|t| t.fell).map(|t| count(t.fall_count(), t)).collect();
    let still: Option<Vec<String>> = tracking
        .iter()
        .map(|t| t.stood_still.map(|n| (n > 0).then(|| count(n, t))))
        .collect::<Option<Vec<_>>>()
        .map(|v| v.into_iter().flatten().collect());
    let worst = worst_component(tracking);
    let mut out = vec![
        Claim {
            statement: format!("{who}: no fall on any tracking command"),
            holds: Some(falls.is_empty()),
            evidence: if falls.is_empty() { "0 falls".into() } else { format!("fell on {}", falls.join(", ")) },
            undecided: "–",
        },
        Claim {
            statement: format!("{who}: each component's MAE ≤ {MAX_COMPONENT_MAE}"),
            holds: Some(worst.1 <= MAX_COMPONENT_MAE),
            evidence: format!("worst {:.3} ({})", worst.1, worst.0),
            undecided: "–",
        },
    ];
    // Not one of the bars, but a policy that stands still on a command from some initial states fails its
    // user as a fall would; reports written before starts were counted have no verdict here.
    if let Some(still) = still {
        out.push(Claim {
            statement: format!("{who}: no start stands still on a tracking command"),
            holds: Some(still.is_empty()),
            evidence: if still.is_empty() {
                "0 stand-stills".into()
            } else {
                format!("stood still on {}", still.join(", "))
            },
            undecided: "–",
        });
    }
    if let Some(g) = tracking.iter().find(|t| t.key == "walk_forward").map(|t| &t.gait) {
        let ok = g.air_time_s >= MIN_AIR_TIME_S && g.clearance_m >= MIN_CLEARANCE_M && g.steps_per_s <= MAX_STEPS_PER_S;
        out.push(Claim {
            statement: format!(
                "{who}: gait at 0.5 m/s (air ≥ {MIN_AIR_TIME_S} s, clearance ≥ {} cm, ≤ {MAX_STEPS_PER_S} steps/s)",
                100.0 * MIN_CLEARANCE_M
            ),
            holds: Some(ok),
            // A policy that never lifts a foot has no air time or clearance to average (NaN): say so instead.
            evidence: if g.air_time_s.is_finite() {
                format!(
                    "air {:.3} s, clearance {:.1} cm, {:.2} steps/s",
                    g.air_time_s,
                    100.0 * g.clearance_m,
                    g.steps_per_s
                )
            } else {
                "no step taken".into()
            },
            undecided: "–",
        });
    }
    out
}

pub fn markdown(claims: &[Claim]) -> String {
    let mut s = String::from("| claim | holds | numbers |\n|---|---|---|\n");
    for c in claims {
        let verdict = match c.holds {
            Some(true) => "yes",
            Some(false) => "**no**",
            None => c.undecided,
        };
        let _ = writeln!(s, "| {} | {verdict} | {} |", c.statement, c.evidence);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gait::GaitStats;
    use crate::groups::group;
    use crate::results::{NoiseRow, PushGrid, TrackingRow};

    fn policy(name: &str, id: usize, t_fall: f64, noise: [f64; 2], worst: f64, air: f64) -> PolicyResults {
        let row = |key: &str, fell: bool| TrackingRow {
            key: key.into(),
            command: [0.5, 0.0, 0.0],
            mae: 0.0,
            mae_components: [0.0; 3],
            mae_whole: [0.01, worst, 0.02],
            mae_paper: 0.0,
            mean_torque: 0.0,
            mean_roll: 0.0,
            mean_pitch: 0.0,
            fell,
            fell_at: None,
            gait: GaitStats { steps_per_s: 2.0, air_time_s: air, clearance_m: 0.035, ..Default::default() },
            starts: 10,
            falls: Some(usize::from(fell)),
            stood_still: Some(0),
        };
        let grid = PushGrid { axis: vec![0.0], t_fall: vec![t_fall], window_s: 10.0, command: [0.0; 3] };
        PolicyResults {
            name: Group::from_key(name).unwrap(),
            policy: format!("{name}{id}.json").into(),
            weights_crc32: None,
            trained_on: "topa_closed".into(),
            tracking: vec![row("walk_forward", false), row("rotate_cw", false)],
            push: grid.clone(),
            push_walking: Some(grid),
            noise: noise
                .iter()
                .map(|&p| NoiseRow { sigma_v: 0.1, sigma_wz: 0.1, runs: 100, successes: p as usize, success_pct: p })
                .collect(),
        }
    }

    fn verdict(claims: &[Claim], starts: &str) -> Option<bool> {
        claims.iter().find(|c| c.statement.starts_with(starts)).expect(starts).holds
    }

    const FULL: Resolution = Resolution { push: Resampling { tasks: false }, quick: false };

    /// Five seeds per group: O far below C; C+A within C's spread under pushes, far above it under noise.
    fn five_seeds() -> Vec<PolicyResults> {
        let mut r = Vec::new();
        for (i, t) in [5.0, 5.4, 5.1, 5.3, 5.2].into_iter().enumerate() {
            r.push(policy("O", i + 1, t, [60.0, 5.0], 0.3, 0.25));
        }
        for (i, t) in [8.0, 9.0, 8.5, 8.8, 8.2].into_iter().enumerate() {
            r.push(policy("C", i + 1, t, [100.0, 40.0 + i as f64], 0.1, 0.25));
        }
        for (i, t) in [8.1, 9.1, 8.4, 8.9, 8.6].into_iter().enumerate() {
            r.push(policy("CA", i + 1, t, [100.0, 80.0 + i as f64], if i == 1 { 0.2 } else { 0.1 }, 0.25));
        }
        r[11].tracking[0].gait.air_time_s = 0.15; // C+A seed 2 also misses the gait bar
        r
    }

    #[test]
    fn the_ordering_is_on_means_and_the_margins_on_intervals() {
        let r = five_seeds();
        let c = check(&group(&r), FULL, None);
        assert_eq!(verdict(&c, "mean t_fall (standing pushes): O < C < C+A"), Some(true));
        assert_eq!(verdict(&c, "C − O under standing pushes"), Some(true), "3.3 s, no overlap");
        let margin = c.iter().find(|x| x.statement.starts_with("C+A − C under standing pushes")).unwrap();
        assert_eq!(margin.holds, None, "0.12 s inside the seeds' spread: {margin:?}");
        assert_eq!(margin.undecided, "undecided: the 95 % CI includes zero");
        assert!(margin.evidence.starts_with("difference +0.12 s ["), "{}", margin.evidence);
        let row = markdown(std::slice::from_ref(margin));
        assert!(row.contains("| undecided: the 95 % CI includes zero |"), "{row}");
        assert_eq!(verdict(&c, "C+A mean t_fall ≥"), Some(false), "8.62 s is below the 9 s bar");
        // Level 1: every seed of both at 100 % — a tie, no verdict; level 2: ~82 against ~42 % — above.
        let l1 = c.iter().find(|x| x.statement.contains("level 1")).unwrap();
        assert_eq!((l1.holds, l1.undecided), (None, "tie"));
        assert_eq!(verdict(&c, "C+A − C success at command-noise level 2"), Some(true));
        let mut worse = r.clone();
        for x in worse.iter_mut().filter(|x| x.name == Group::CA) {
            x.noise[1].success_pct = 10.0;
            x.noise[1].successes = 10;
        }
        assert_eq!(
            verdict(&check(&group(&worse), FULL, None), "C+A − C success at command-noise level 2"),
            Some(false)
        );
        // Fewer than five seeds: the interval is shown, the verdict withheld.
        let three: Vec<PolicyResults> =
            r.iter().filter(|x| x.name != Group::C || x.policy.ends_with("C4.json")).cloned().collect();
        let c3 = check(&group(&three), FULL, None);
        let m = c3.iter().find(|x| x.statement.starts_with("C − O under standing pushes")).unwrap();
        assert!(m.holds.is_none() && m.undecided.contains("fewer than 5 seeds"), "{m:?}");
        // The quick protocol says that it cannot decide, rather than deciding.
        let quick = check(&group(&r), Resolution { push: Resampling { tasks: true }, quick: true }, None);
        let m = quick.iter().find(|x| x.statement.starts_with("C+A − C under standing pushes")).unwrap();
        assert!(m.holds.is_none() && m.undecided.contains("quick protocol is too coarse"), "{m:?}");
        // C+A seed 2 misses two bars: its worst component (0.2) and its air time (0.15 s).
        let bars: Vec<&Claim> = c.iter().filter(|x| x.statement.starts_with("C+A CA2.json")).collect();
        assert_eq!(bars.iter().filter(|x| x.holds == Some(false)).count(), 2, "{bars:?}");
        // Starts that fell or stood still are named with their counts; a report without stand-still counts has
        // no verdict on them.
        let mut bistable = r.clone();
        bistable[5].tracking[1].stood_still = Some(4);
        bistable[5].tracking[1].fell = true;
        bistable[5].tracking[1].falls = Some(2);
        let c = check(&group(&bistable), FULL, None);
        let claim = |s: &str| c.iter().find(|x| x.statement.starts_with(s)).expect(s).clone();
        let still = claim("C C1.json: no start stands still");
        assert_eq!((still.holds, still.evidence.as_str()), (Some(false), "stood still on rotate_cw (4/10)"));
        assert_eq!(claim("C C1.json: no fall").evidence, "fell on rotate_cw (2/10)");
        assert_eq!(claim("C+A CA1.json: no start stands still").holds, Some(true));
        let stand_claims = |r: &[PolicyResults]| {
            check(&group(r), FULL, None)
                .iter()
                .filter(|x| x.statement.starts_with("C C1.json: no start stands"))
                .count()
        };
        assert_eq!(stand_claims(&bistable), 1);
        bistable[5].tracking[0].stood_still = None;
        assert_eq!(stand_claims(&bistable), 0, "the report has no count on walk_forward");
        // No O group: no ordering verdict.
        let single = vec![policy("C", 1, 8.0, [90.0, 40.0], 0.1, 0.25), policy("CA", 1, 9.5, [95.0, 60.0], 0.1, 0.25)];
        assert_eq!(verdict(&check(&group(&single), FULL, None), "mean t_fall (standing pushes): O < C < C+A"), None);
    }

    #[test]
    fn the_papers_numbers_are_quoted_only_with_its_tables() {
        let r = five_seeds();
        let evidence = |paper: Option<&PaperTables>| {
            let c = check(&group(&r), FULL, paper);
            let find = |s: &str| c.iter().find(|x| x.statement.starts_with(s)).unwrap().evidence.clone();
            (find("mean t_fall (standing pushes)"), find("C+A mean t_fall"))
        };
        let tables = crate::report::paper().unwrap();
        let (order, ca) = evidence(Some(&tables));
        assert!(order.ends_with("(mean ± sd; paper 4.77 < 8.48 < 9.71)"), "{order}");
        assert!(ca.ends_with(" s (paper 9.71)"), "{ca}");
        // Another robot's report (report::paper_for gives None) states ours alone.
        let (order, ca) = evidence(None);
        assert!(order.ends_with(" s (mean ± sd)") && !ca.contains("paper"), "{order} / {ca}");
        assert!(crate::report::paper_for(["topa_closed", "topa_open"]).unwrap().is_some());
        assert!(crate::report::paper_for(["topa_closed", "cassie"]).unwrap().is_none());
    }

    #[test]
    fn a_policy_that_never_steps_fails_the_gait_bar_and_says_why() {
        let gait = |air: f64| {
            let p = policy("C", 1, 9.0, [90.0, 80.0], 0.1, air);
            tracking_bars("C", &p.tracking).into_iter().find(|c| c.statement.contains("gait")).unwrap()
        };
        let still = gait(f64::NAN);
        assert_eq!((still.holds, still.evidence.as_str()), (Some(false), "no step taken"));
        let walking = gait(0.3);
        assert_eq!(walking.holds, Some(true));
        assert!(walking.evidence.starts_with("air 0.300 s, clearance 3.5 cm"), "{}", walking.evidence);
    }
}
