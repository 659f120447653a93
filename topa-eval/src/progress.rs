//! Iterations to the bars: a run's kept checkpoints, every N-th one exported as a policy and put through the six
//! tracking commands, with the bars a shipped C or C+A policy must meet (no fall, each component's MAE, no
//! stand-still, gait at 0.5 m/s). Per run: the first checkpoint that meets them all and the one from which every
//! later one does — what a preset's length can be cut to, measured rather than guessed.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use topa_env::policy_runner::PolicyRunner;

use super::claims;
use super::results::{RunCounts, TrackingRow};
use super::settings::EvalSettings;
use super::{push, tracking};
use crate::error::{invalid, Error, Result};

/// One checkpoint's policy through the tracking commands.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Snapshot {
    pub iteration: usize,
    pub samples: u64,
    /// The run's wall time up to this checkpoint, s (summed over its segments).
    pub wall_time_s: f64,
    pub tracking: Vec<TrackingRow>,
    /// The standing push grid's mean time to fall, s (when asked for).
    #[serde(default)]
    pub push_t_fall_s: Option<f64>,
    pub bars: Vec<Bar>,
}

/// One bar at one checkpoint: its statement, whether it holds, and the numbers.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Bar {
    pub statement: String,
    pub holds: bool,
    pub evidence: String,
}

impl Snapshot {
    pub fn meets_all(&self) -> bool {
        self.bars.iter().all(|b| b.holds)
    }
}

/// One run's snapshots in iteration order.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunProgress {
    pub run: String,
    pub seed: u64,
    /// The iterations the run's config asks for.
    pub planned_iterations: usize,
    pub snapshots: Vec<Snapshot>,
}

impl RunProgress {
    /// The first snapshot meeting every bar.
    pub fn first_met(&self) -> Option<&Snapshot> {
        self.snapshots.iter().find(|s| s.meets_all())
    }

    /// The first snapshot from which every later one meets every bar (none if the last one misses a bar).
    pub fn held_from(&self) -> Option<&Snapshot> {
        let misses_after = self.snapshots.iter().rposition(|s| !s.meets_all());
        match misses_after {
            None => self.snapshots.first(),
            Some(i) => self.snapshots.get(i + 1),
        }
    }
}

/// The run's checkpoint sidecars whose iteration is a multiple of `every`, and its last one, in iteration order
/// (two at least: a progress needs more than one point).
pub fn checkpoints(run: &Path, every: usize) -> Result<Vec<(usize, PathBuf)>> {
    let picked = topa_train::policy::kept_checkpoints(run, every)?;
    if picked.len() < 2 {
        invalid!(
            "{} keeps only {} checkpoint(s) at multiples of {every}: train with `[run] keep_checkpoints = 0` to keep \
             them all, or pass a smaller --every",
            run.join("checkpoints").display(),
            picked.len()
        );
    }
    Ok(picked)
}

/// A run's name in reports: its folder's name.
pub fn run_name(run: &Path) -> String {
    run.file_name().map_or_else(|| run.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// What each checkpoint goes through: the tracking commands, and optionally the paper's standing push grid.
#[derive(Debug, Clone, Copy)]
pub struct Protocol {
    pub every: usize,
    pub seconds: f64,
    pub starts: usize,
    /// The push grid's step to ±30 N, N (None: no push test).
    pub push_step: Option<f64>,
}

impl Protocol {
    /// One line for the report; a cached result is reused only under the same line.
    pub fn describe(&self, settings: &EvalSettings) -> String {
        let push = self.push_step.map_or(String::new(), |n| format!(", standing push grid to ±30 N in {n} N steps"));
        format!(
            "{} starts × {} s per command{push}, {} sim2sim at {} s with the {} integrator, seed {}",
            self.starts,
            self.seconds,
            String::from(settings.sim2sim_mode.clone()),
            settings.timestep(),
            settings.integrator().name(),
            settings.seed
        )
    }
}

/// A snapshot's result as kept beside its exported policy: re-running the study (e.g. while the run trains on)
/// evaluates only the checkpoints it has not seen under the same protocol, without exporting them again.
#[derive(Serialize, Deserialize)]
struct Cached {
    protocol: String,
    /// CRC-32 of the checkpoint's sidecar (a run retrained into the same folder has other checkpoints).
    checkpoint_crc32: u32,
    /// The run's seed and planned length, as the checkpoint's config says.
    seed: u64,
    planned_iterations: usize,
    /// Whether the run trains with the adversary (C+A): its push time is then held to C+A's bar.
    with_adversary: bool,
    snapshot: Snapshot,
}

/// The tracking bars of run `name` at iteration `it`.
fn tracking_bars(name: &str, it: usize, rows: &[TrackingRow]) -> Vec<Bar> {
    claims::tracking_bars(&format!("{name} iteration {it}"), rows)
        .into_iter()
        .map(|c| Bar { holds: c.holds == Some(true), statement: c.statement, evidence: c.evidence })
        .collect()
}

/// Every bar of run `name` at iteration `it`: the tracking bars, and C+A's bar on the standing push grid's mean time
/// to fall where the run has the adversary and the grid was run.
fn bars(name: &str, it: usize, rows: &[TrackingRow], push_t_fall_s: Option<f64>, with_adversary: bool) -> Vec<Bar> {
    let mut bars = tracking_bars(name, it, rows);
    if let (Some(t), true) = (push_t_fall_s, with_adversary) {
        bars.push(Bar {
            statement: format!("{name} iteration {it}: push mean t_fall ≥ {} s", claims::MIN_CA_T_FALL_S),
            holds: t >= claims::MIN_CA_T_FALL_S,
            evidence: format!("{t:.2} s"),
        });
    }
    bars
}

fn cached(file: &Path, protocol: &str, crc: u32) -> Option<Cached> {
    let c: Cached = serde_json::from_str(&std::fs::read_to_string(file).ok()?).ok()?;
    (c.protocol == protocol && c.checkpoint_crc32 == crc).then_some(c)
}

/// Evaluates every `every`-th kept checkpoint of `run` (policies and results kept under
/// `out/policies/<run name>/`). With the push grid, a run with the adversary also has the C+A bar on its mean time
/// to fall.
pub fn run(run: &Path, p: Protocol, settings: &EvalSettings, out: &Path) -> Result<RunProgress> {
    let name = run_name(run);
    let dir = out.join("policies").join(&name);
    std::fs::create_dir_all(&dir).map_err(Error::io("creating", &dir))?;
    let mut snapshots = Vec::new();
    let (mut seed, mut planned) = (0, 0);
    let protocol = p.describe(settings);
    for (it, sidecar) in checkpoints(run, p.every)? {
        let crc = trainer::tensorfile::checksum(&std::fs::read(&sidecar).map_err(Error::io("cannot read", &sidecar))?);
        let result = format!("it{it:05}.result.json");
        if let Some(c) = cached(&dir.join(&result), &protocol, crc) {
            (seed, planned) = (c.seed, c.planned_iterations);
            // The bars are re-derived from the cached measurements, so a report follows the current bars' wording
            // and limits.
            let mut s = c.snapshot;
            s.bars = bars(&name, it, &s.tracking, s.push_t_fall_s, c.with_adversary);
            snapshots.push(s);
            continue;
        }
        let policy = topa_train::export_checkpoint(&sidecar, &dir.join(format!("it{it:05}")))?;
        let mut runner = PolicyRunner::load(&policy, &name)?;
        let prov = &runner.policy.meta.provenance;
        let (samples, wall_time_s, with_adversary) = (prov.samples, prov.wall_time_s, prov.with_adversary);
        // A C+A run's length is its schedule's (phase 1 and the cycles), not `run.iterations`.
        let planned_run =
            if with_adversary { prov.config.adversary.schedule().total() } else { prov.config.run.iterations };
        (seed, planned) = (prov.seed, planned_run);
        let rows = tracking::run(&mut runner, settings, p.seconds, 2.0_f64.min(p.seconds / 2.0), p.starts)?;
        let push_t_fall_s = match p.push_step {
            Some(step) => Some(push::run(&mut runner, settings, 30.0, step, 10.0, [0.0; 3])?.mean_t_fall()),
            None => None,
        };
        let bars = bars(&name, it, &rows, push_t_fall_s, with_adversary);
        let s = Snapshot { iteration: it, samples, wall_time_s, tracking: rows, push_t_fall_s, bars };
        eprintln!("{name} iteration {it}: {}", if s.meets_all() { "meets every bar" } else { "misses a bar" });
        let c = Cached {
            protocol: protocol.clone(),
            checkpoint_crc32: crc,
            seed,
            planned_iterations: planned,
            with_adversary,
            snapshot: s,
        };
        super::report::write_json(&dir, &result, &c)?;
        snapshots.push(c.snapshot);
    }
    Ok(RunProgress { run: name, seed, planned_iterations: planned, snapshots })
}

fn hm(s: f64) -> String {
    let m = (s / 60.0).round() as u64;
    format!("{}:{:02}", m / 60, m % 60)
}

/// The bar's numbers in a short cell: the part of the evidence after the statement.
fn cell(s: &Snapshot, bar: &str) -> String {
    s.bars.iter().find(|b| b.statement.contains(bar)).map_or("–".into(), |b| {
        let mark = if b.holds { "" } else { " ✗" };
        format!("{}{mark}", b.evidence)
    })
}

/// The summary across runs, then one table per run.
pub fn markdown(runs: &[RunProgress], protocol: &str) -> String {
    let mut s = format!(
        "# Iterations to the bars\n\nBars: no fall on the six tracking commands, each component's MAE ≤ {}, no stand-still, gait at 0.5 m/s \
         (air ≥ {} s, clearance ≥ {} cm, ≤ {} steps/s); {protocol}.\n\n",
        claims::MAX_COMPONENT_MAE,
        claims::MIN_AIR_TIME_S,
        100.0 * claims::MIN_CLEARANCE_M,
        claims::MAX_STEPS_PER_S
    );
    s.push_str("| run | seed | first meets every bar | meets them from (every later checkpoint too) | of |\n");
    s.push_str("|---|---:|---|---|---:|\n");
    let at = |x: Option<&Snapshot>| {
        x.map_or("never".to_string(), |x| {
            format!("{} ({:.1} M samples, {})", x.iteration, x.samples as f64 / 1e6, hm(x.wall_time_s))
        })
    };
    for r in runs {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            r.run,
            r.seed,
            at(r.first_met()),
            at(r.held_from()),
            r.planned_iterations
        );
    }
    for r in runs {
        let pushed = r.snapshots.iter().any(|x| x.push_t_fall_s.is_some());
        let _ = write!(
            s,
            "\n### {}\n\n| iteration | samples (M) | wall (h:mm) | falls (runs) | stand-stills (runs) | worst MAE | \
             gait at 0.5 m/s |{} every bar |\n|---:|---:|---:|---|---|---|---|{}---|\n",
            r.run,
            if pushed { " push t_fall (s) |" } else { "" },
            if pushed { "---:|" } else { "" }
        );
        for x in &r.snapshots {
            let counts = RunCounts::of(&x.tracking);
            let push = match (pushed, x.push_t_fall_s) {
                (false, _) => String::new(),
                (true, t) => format!(" {} |", t.map_or("–".into(), |t| format!("{t:.2}"))),
            };
            let _ = writeln!(
                s,
                "| {} | {:.1} | {} | {} | {} | {} | {} |{push} {} |",
                x.iteration,
                x.samples as f64 / 1e6,
                hm(x.wall_time_s),
                counts.falls_cell(),
                counts.still_cell(),
                cell(x, "MAE"),
                cell(x, "gait"),
                if x.meets_all() { "yes" } else { "**no**" }
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snap(it: usize, ok: bool) -> Snapshot {
        let bar = Bar {
            statement: "x: no fall on any tracking command".into(),
            holds: ok,
            evidence: if ok { "0 falls".into() } else { "fell on walk_left (1/10)".into() },
        };
        Snapshot {
            iteration: it,
            samples: it as u64 * 12_288,
            wall_time_s: it as f64 * 2.0,
            tracking: vec![],
            push_t_fall_s: None,
            bars: vec![bar],
        }
    }

    #[test]
    fn first_met_and_held_from() {
        let r = |v: &[(usize, bool)]| RunProgress {
            run: "C-s1".into(),
            seed: 1,
            planned_iterations: 1500,
            snapshots: v.iter().map(|&(i, ok)| snap(i, ok)).collect(),
        };
        // Met at 500, lost at 700, met again from 900 on.
        let p = r(&[(300, false), (500, true), (700, false), (900, true), (1100, true)]);
        assert_eq!(p.first_met().map(|s| s.iteration), Some(500));
        assert_eq!(p.held_from().map(|s| s.iteration), Some(900));
        let md = markdown(&[p], "10 starts");
        assert!(md.contains("| C-s1 | 1 | 500 (6.1 M samples, 0:17) | 900 (11.1 M samples, 0:30) | 1500 |"), "{md}");
        assert!(md.contains("| 300 | 3.7 | 0:10 | 0/0 | 0/0 | – | – | **no** |"), "{md}");
        // The last checkpoint misses: nothing holds to the end.
        let p = r(&[(500, true), (1000, false)]);
        assert_eq!(p.held_from().map(|s| s.iteration), None);
        assert!(markdown(&[p], "").contains("| 500 (6.1 M samples, 0:17) | never |"));
        assert_eq!(r(&[(500, true), (1000, true)]).held_from().map(|s| s.iteration), Some(500));
    }

    #[test]
    fn checkpoints_pick_multiples_and_the_last() {
        let dir = std::env::temp_dir().join(format!("topa-progress-{}", std::process::id()));
        let ck = dir.join("checkpoints");
        std::fs::create_dir_all(&ck).unwrap();
        for it in [25, 50, 75, 100, 125] {
            std::fs::write(ck.join(format!("ckpt_{it:07}.json")), "{}").unwrap();
        }
        std::fs::write(ck.join("latest.json"), "{}").unwrap();
        let its: Vec<usize> = checkpoints(&dir, 50).unwrap().into_iter().map(|c| c.0).collect();
        assert_eq!(its, [50, 100, 125]);
        let e = checkpoints(&dir, 1000).unwrap_err().to_string();
        assert!(e.contains("keep_checkpoints = 0"), "{e}");
        let e = checkpoints(&dir.join("nowhere"), 50).unwrap_err().to_string();
        assert!(e.contains("no checkpoints folder"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_push_bar_is_derived_from_the_push_time_for_a_run_with_the_adversary_only() {
        let push = |t: Option<f64>, adversary: bool| -> Vec<(bool, String)> {
            bars("CA-s4", 300, &[], t, adversary)
                .into_iter()
                .filter(|b| b.statement.contains("push"))
                .map(|b| (b.holds, b.evidence))
                .collect()
        };
        assert_eq!(push(Some(9.5), true), [(true, "9.50 s".to_string())]);
        assert_eq!(push(Some(8.2), true), [(false, "8.20 s".to_string())], "under C+A's 9 s");
        assert!(push(Some(9.5), false).is_empty(), "a C run is not held to C+A's bar");
        assert!(push(None, true).is_empty(), "no push grid, no push bar");
    }
}
