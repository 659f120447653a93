//! The paper's robustness claims and the gait and tracking bars, checked on the groups' numbers: each line says
//! whether it holds, with the numbers it rests on — so that a report states a negative as plainly as a positive.

use std::fmt::Write as _;

use super::ablate::PolicyResults;
use super::groups::{Group, Stat};
use super::report::label;

/// One checked statement.
#[derive(Debug, Clone, PartialEq)]
pub struct Claim {
    pub statement: String,
    /// None: a group it needs is missing (or has no numbers).
    pub holds: Option<bool>,
    pub evidence: String,
}

/// Bars a shipped C or C+A policy must meet (issue 14): every tracking command without a fall, each component's
/// whole-window MAE within this bound, and at 0.5 m/s this gait.
pub const MAX_COMPONENT_MAE: f64 = 0.15;
pub const MIN_AIR_TIME_S: f64 = 0.2;
pub const MIN_CLEARANCE_M: f64 = 0.03;
pub const MAX_STEPS_PER_S: f64 = 2.5;
/// The paper's C+A mean time to fall is 9.71 s; the issue asks for at least this.
pub const MIN_CA_T_FALL_S: f64 = 9.0;

fn find<'a, 'b>(groups: &'a [Group<'b>], name: &str) -> Option<&'a Group<'b>> {
    groups.iter().find(|g| g.name == name)
}

fn known(s: Stat) -> Option<Stat> {
    s.mean.is_finite().then_some(s)
}

/// The claims that compare groups (O, C, CA by name), and the bars each C and C+A policy must meet.
pub fn check(groups: &[Group]) -> Vec<Claim> {
    let mut out = Vec::new();
    let t = |name: &str| find(groups, name).and_then(|g| known(g.t_fall_standing()));
    let (o, c, ca) = (t("O"), t("C"), t("CA"));
    out.push(Claim {
        statement: "mean t_fall (standing pushes): O < C < C+A".into(),
        holds: match (o, c, ca) {
            (Some(o), Some(c), Some(ca)) => Some(o.mean < c.mean && c.mean < ca.mean),
            _ => None,
        },
        evidence: format!(
            "O {}, C {}, C+A {} s (paper 4.77 < 8.48 < 9.71)",
            o.map_or("–".into(), |s| s.show(2)),
            c.map_or("–".into(), |s| s.show(2)),
            ca.map_or("–".into(), |s| s.show(2))
        ),
    });
    if let (Some(c), Some(ca)) = (c, ca) {
        let (diff, spread) = (ca.mean - c.mean, c.sd + ca.sd);
        out.push(Claim {
            statement: "C+A − C exceeds the two groups' standard deviations combined".into(),
            holds: (c.n > 1 && ca.n > 1).then_some(diff > spread),
            evidence: format!(
                "C+A − C = {diff:+.2} s, sd_C + sd_C+A = {spread:.2} s ({} and {} policies{})",
                c.n,
                ca.n,
                if c.n > 1 && ca.n > 1 { "" } else { ": one seed has no sd, no verdict" }
            ),
        });
        out.push(Claim {
            statement: format!("C+A mean t_fall ≥ {MIN_CA_T_FALL_S} s"),
            holds: Some(ca.mean >= MIN_CA_T_FALL_S),
            evidence: format!("{:.2} s (paper 9.71)", ca.mean),
        });
    }
    if let (Some(gc), Some(gca)) = (find(groups, "C"), find(groups, "CA")) {
        let levels = gc.members.iter().chain(&gca.members).map(|r| r.noise.len()).min().unwrap_or(0);
        let pairs: Vec<(f64, f64)> = (0..levels).map(|i| (gc.noise(i).mean, gca.noise(i).mean)).collect();
        // Where both succeed every time there is nothing to be above: a tie at 100 % does not count against.
        out.push(Claim {
            statement: "C+A above C at every command-noise level (ties at 100 % aside)".into(),
            holds: (levels > 0).then(|| pairs.iter().all(|&(c, ca)| ca > c || (c >= 100.0 && ca >= 100.0))),
            evidence: pairs
                .iter()
                .enumerate()
                .map(|(i, (c, ca))| format!("L{}: C {c:.0} %, C+A {ca:.0} %", i + 1))
                .collect::<Vec<_>>()
                .join("; "),
        });
    }
    for g in groups.iter().filter(|g| g.name == "C" || g.name == "CA") {
        for r in &g.members {
            out.extend(policy_bars(r));
        }
    }
    out
}

/// The bars for one C or C+A policy.
pub fn policy_bars(r: &PolicyResults) -> Vec<Claim> {
    let who = format!("{} {}", label(&r.name), r.policy.display());
    // "key (falls/starts)" for each command that fell, or stood still, from at least one start.
    let count = |n: usize, t: &crate::eval::tracking::TrackingRow| format!("{} ({n}/{})", t.key, t.starts);
    let falls: Vec<String> = r.tracking.iter().filter(|t| t.fell).map(|t| count(t.fall_count(), t)).collect();
    let still: Option<Vec<String>> = r
        .tracking
        .iter()
        .map(|t| t.stood_still.map(|n| (n > 0).then(|| count(n, t))))
        .collect::<Option<Vec<_>>>()
        .map(|v| v.into_iter().flatten().collect());
    let worst = r
        .tracking
        .iter()
        .flat_map(|t| t.mae_whole.iter().map(move |m| (t.key.as_str(), *m)))
        .fold(("", 0.0f64), |a, b| if b.1 > a.1 { b } else { a });
    let mut out = vec![
        Claim {
            statement: format!("{who}: no fall on any tracking command"),
            holds: Some(falls.is_empty()),
            evidence: if falls.is_empty() { "0 falls".into() } else { format!("fell on {}", falls.join(", ")) },
        },
        Claim {
            statement: format!("{who}: each component's MAE ≤ {MAX_COMPONENT_MAE}"),
            holds: Some(worst.1 <= MAX_COMPONENT_MAE),
            evidence: format!("worst {:.3} ({})", worst.1, worst.0),
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
        });
    }
    if let Some(g) = r.tracking.iter().find(|t| t.key == "walk_forward").map(|t| &t.gait) {
        let ok = g.air_time_s >= MIN_AIR_TIME_S && g.clearance_m >= MIN_CLEARANCE_M && g.steps_per_s <= MAX_STEPS_PER_S;
        out.push(Claim {
            statement: format!(
                "{who}: gait at 0.5 m/s (air ≥ {MIN_AIR_TIME_S} s, clearance ≥ {} cm, ≤ {MAX_STEPS_PER_S} steps/s)",
                100.0 * MIN_CLEARANCE_M
            ),
            holds: Some(ok),
            evidence: format!(
                "air {:.3} s, clearance {:.1} cm, {:.2} steps/s",
                g.air_time_s,
                100.0 * g.clearance_m,
                g.steps_per_s
            ),
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
            None => "–",
        };
        let _ = writeln!(s, "| {} | {verdict} | {} |", c.statement, c.evidence);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::gait::GaitStats;
    use crate::eval::groups::group;
    use crate::eval::noise::NoiseRow;
    use crate::eval::tracking::TrackingRow;
    use crate::push_grid::PushGrid;

    fn policy(name: &str, t_fall: f64, noise: [f64; 2], worst: f64, air: f64) -> PolicyResults {
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
            name: name.into(),
            policy: format!("{name}.json").into(),
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

    #[test]
    fn the_ordering_and_the_margin_are_judged_on_means_and_sds() {
        // C+A ahead of C by 0.6 s, but the seeds spread by 0.5 s each: ordered, not separated.
        let r = vec![
            policy("O", 5.0, [100.0, 10.0], 0.1, 0.25),
            policy("C", 8.0, [100.0, 40.0], 0.1, 0.25),
            policy("C", 9.0, [100.0, 40.0], 0.1, 0.25),
            policy("CA", 8.6, [100.0, 30.0], 0.1, 0.25),
            policy("CA", 9.6, [100.0, 60.0], 0.2, 0.15),
        ];
        let c = check(&group(&r));
        assert_eq!(verdict(&c, "mean t_fall (standing pushes): O < C < C+A"), Some(true));
        assert_eq!(verdict(&c, "C+A − C exceeds"), Some(false), "0.6 s against 0.71 + 0.71");
        assert_eq!(verdict(&c, "C+A mean t_fall ≥"), Some(true)); // 9.1
                                                                  // Level 1: both at 100 % (a tie that does not count against); level 2: 45 > 40.
        assert_eq!(verdict(&c, "C+A above C at every command-noise level"), Some(true));
        let mut worse = r.clone();
        worse[4].noise[1].success_pct = 20.0; // C+A level 2: 25 % against 40 %
        assert_eq!(verdict(&check(&group(&worse)), "C+A above C at every command-noise level"), Some(false));
        // The second C+A policy misses two bars: its worst component (0.2) and its air time (0.15 s).
        let bars: Vec<&Claim> = c.iter().filter(|x| x.statement.starts_with("C+A CA.json")).collect();
        assert_eq!(bars.iter().filter(|x| x.holds == Some(false)).count(), 2, "{bars:?}");
        // Starts that fell or stood still are named with their counts; a report without stand-still counts has
        // no verdict on them.
        let mut bistable = r.clone();
        bistable[1].tracking[1].stood_still = Some(4);
        bistable[1].tracking[1].fell = true;
        bistable[1].tracking[1].falls = Some(2);
        let c = check(&group(&bistable));
        let claim = |s: &str| c.iter().find(|x| x.statement.starts_with(s)).expect(s).clone();
        let still = claim("C C.json: no start stands still");
        assert_eq!((still.holds, still.evidence.as_str()), (Some(false), "stood still on rotate_cw (4/10)"));
        assert_eq!(claim("C C.json: no fall").evidence, "fell on rotate_cw (2/10)");
        assert_eq!(claim("C+A CA.json: no start stands still").holds, Some(true));
        let stand_claims = |r: &[PolicyResults]| {
            check(&group(r)).iter().filter(|x| x.statement.starts_with("C C.json: no start stands")).count()
        };
        assert_eq!(stand_claims(&bistable), 2, "one per C policy");
        bistable[1].tracking[0].stood_still = None;
        assert_eq!(stand_claims(&bistable), 1, "the first C's report has no count on walk_forward");
        // One seed per group: no sd, no verdict on the margin.
        let single = vec![policy("C", 8.0, [90.0, 40.0], 0.1, 0.25), policy("CA", 9.5, [95.0, 60.0], 0.1, 0.25)];
        let c = check(&group(&single));
        assert_eq!(verdict(&c, "C+A − C exceeds"), None);
        assert_eq!(verdict(&c, "mean t_fall (standing pushes): O < C < C+A"), None, "no O group");
    }
}
