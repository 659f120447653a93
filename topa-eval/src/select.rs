//! Checkpoint selection on held-out commands. A run's late checkpoints can swing in tracking from one to the next
//! (a policy's worst component 0.13 at one checkpoint and 0.19 fifty iterations later), so its last checkpoint is a
//! draw. Each checkpoint from `from` on is put through validation commands drawn from the training ranges — never
//! the six commands the reports measure — and the one with the smallest mean worst-component error, with no fall and
//! no stand-still, is kept. The reports then measure it on the six: the choice did not see them.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use topa_env::config::CommandConfig;
use topa_env::policy_runner::PolicyRunner;

use super::results::TrackingRow;
use super::settings::EvalSettings;
use super::{progress, tracking};
use crate::claims::MAX_STEPS_PER_S;
use crate::error::{ensure, invalid, Error, Result};

/// Every `PURE_TURN_EVERY`-th validation command turns in place, the command policies learn last and a uniform draw
/// almost never gives.
const PURE_TURN_EVERY: usize = 3;
/// A validation command moves or turns at least this share of its range's largest magnitude: a tiny command says
/// little about tracking.
const MIN_SHARE: f64 = 0.3;

/// What the checkpoints go through.
#[derive(Debug, Clone, Copy)]
pub struct Protocol {
    /// The first iteration a checkpoint may be taken from.
    pub from: usize,
    pub every: usize,
    /// Validation commands drawn from the training ranges.
    pub commands: usize,
    pub starts: usize,
    pub seconds: f64,
    /// The gait a kept checkpoint must show on the walking validation commands: mean air time per step, s.
    pub min_air_time_s: f64,
}

impl Protocol {
    pub fn describe(&self, settings: &EvalSettings) -> String {
        format!(
            "checkpoints from iteration {} at multiples of {} (and the last); {} validation commands drawn from the \
             training ranges (every {PURE_TURN_EVERY}rd a turn in place), {} starts × {} s each, {} sim2sim at {} s \
             with the {} integrator, seed {}; kept only with no fall, no stand-still, and on the walking commands a \
             mean air time ≥ {} s at ≤ {MAX_STEPS_PER_S} steps/s",
            self.from,
            self.every,
            self.commands,
            self.starts,
            self.seconds,
            String::from(settings.sim2sim_mode.clone()),
            settings.timestep(),
            settings.integrator().name(),
            settings.seed,
            self.min_air_time_s
        )
    }
}

/// One checkpoint on the validation commands.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Candidate {
    pub iteration: usize,
    /// The mean over the validation commands of each command's largest component MAE (whole window).
    pub score: f64,
    /// The largest component MAE over the validation commands.
    pub worst: f64,
    /// Runs that fell, and runs that stood still, over all commands and starts.
    pub falls: usize,
    pub stand_stills: usize,
    /// The gait over the validation commands that walk (their means; NaN when no foot left the ground).
    pub air_time_s: f64,
    pub steps_per_s: f64,
}

impl Candidate {
    /// A checkpoint that falls, stands still or shuffles on a validation command is never kept, whatever its errors.
    pub fn eligible(&self, p: &Protocol) -> bool {
        let steps = self.air_time_s >= p.min_air_time_s && self.steps_per_s <= MAX_STEPS_PER_S;
        self.falls == 0 && self.stand_stills == 0 && self.score.is_finite() && steps
    }
}

/// One run's selection.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Selection {
    pub run: String,
    pub seed: u64,
    /// The validation commands (v_x, v_y, w_z).
    pub commands: Vec<[f64; 3]>,
    pub candidates: Vec<Candidate>,
    /// The kept checkpoint's iteration.
    pub selected: usize,
    /// The kept checkpoint as a policy file, relative to the report's folder.
    pub policy: PathBuf,
}

/// `n` validation commands from the training ranges, fixed by `seed`: each component uniform in its range, every
/// third a turn in place; each moves or turns at least `MIN_SHARE` of its range's largest magnitude.
pub fn validation_commands(ranges: &CommandConfig, n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5e1e_c7ed);
    let span = |r: [f64; 2]| r[0].abs().max(r[1].abs());
    let uniform = |rng: &mut ChaCha8Rng, r: [f64; 2]| if r[1] > r[0] { rng.random_range(r[0]..r[1]) } else { r[0] };
    let (vx, vy, wz) = (ranges.lin_vel_x, ranges.lin_vel_y, ranges.ang_vel_z);
    let lin_min = MIN_SHARE * span(vx).max(span(vy));
    (0..n)
        .map(|i| loop {
            let c = if i % PURE_TURN_EVERY == PURE_TURN_EVERY - 1 {
                [0.0, 0.0, uniform(&mut rng, wz)]
            } else {
                [uniform(&mut rng, vx), uniform(&mut rng, vy), uniform(&mut rng, wz)]
            };
            let lin = c[0].hypot(c[1]);
            let moves = if c[0] == 0.0 && c[1] == 0.0 { c[2].abs() >= MIN_SHARE * span(wz) } else { lin >= lin_min };
            if moves || (span(vx) == 0.0 && span(vy) == 0.0 && span(wz) == 0.0) {
                break c;
            }
        })
        .collect()
}

/// The candidate kept: the eligible one with the smallest score (a later one on a tie).
pub fn choose<'a>(candidates: &'a [Candidate], p: &Protocol) -> Option<&'a Candidate> {
    candidates
        .iter()
        .filter(|c| c.eligible(p))
        .min_by(|a, b| a.score.total_cmp(&b.score).then(b.iteration.cmp(&a.iteration)))
}

fn candidate(iteration: usize, rows: &[TrackingRow]) -> Candidate {
    let worst_of = |r: &TrackingRow| r.mae_whole.iter().copied().fold(f64::NAN, f64::max);
    Candidate {
        iteration,
        score: rows.iter().map(worst_of).sum::<f64>() / rows.len() as f64,
        worst: rows.iter().map(worst_of).fold(f64::NAN, f64::max),
        falls: rows.iter().map(|r| r.falls.unwrap_or(usize::from(r.fell))).sum(),
        stand_stills: rows.iter().map(|r| r.stood_still.unwrap_or(0)).sum(),
        air_time_s: walking_mean(rows, |r| r.gait.air_time_s),
        steps_per_s: walking_mean(rows, |r| r.gait.steps_per_s),
    }
}

/// The mean of a gait measure over the rows whose command walks (a linear velocity).
fn walking_mean(rows: &[TrackingRow], f: impl Fn(&TrackingRow) -> f64) -> f64 {
    let walking: Vec<f64> = rows.iter().filter(|r| r.command[0].hypot(r.command[1]) > 0.0).map(f).collect();
    walking.iter().sum::<f64>() / walking.len() as f64
}

/// Selects `run`'s checkpoint; the checkpoints' policies and the kept one (`policy.{json,safetensors}`) are written
/// under `out/<run name>/`.
pub fn run(run: &Path, p: Protocol, settings: &EvalSettings, out: &Path) -> Result<Selection> {
    ensure!(p.commands >= 1, "selection needs at least one validation command (--commands ≥ 1)");
    let name = progress::run_name(run);
    let picked: Vec<(usize, PathBuf)> =
        progress::checkpoints(run, p.every)?.into_iter().filter(|(it, _)| *it >= p.from).collect();
    if picked.is_empty() {
        invalid!("{} keeps no checkpoint from iteration {}: pass a smaller --from", run.display(), p.from);
    }
    let dir = out.join(&name);
    std::fs::create_dir_all(dir.join("checkpoints")).map_err(Error::io("creating", &dir))?;
    let (mut commands, mut keyed, mut seed) = (Vec::new(), Vec::new(), 0);
    let mut candidates = Vec::new();
    for (it, sidecar) in &picked {
        let policy = topa_train::export_checkpoint(sidecar, &dir.join("checkpoints").join(format!("it{it:05}")))?;
        let mut runner = PolicyRunner::load(&policy, &name)?;
        if commands.is_empty() {
            seed = runner.policy.meta.provenance.seed;
            commands = validation_commands(&runner.training_config().commands, p.commands, settings.seed);
            keyed = commands.iter().enumerate().map(|(i, c)| (format!("validation_{}", i + 1), *c)).collect();
        }
        let rows =
            tracking::run_commands(&mut runner, settings, &keyed, p.seconds, 2.0_f64.min(p.seconds / 2.0), p.starts)?;
        let c = candidate(*it, &rows);
        eprintln!("{name} iteration {it}: validation score {:.3}, air {:.3} s", c.score, c.air_time_s);
        candidates.push(c);
    }
    let Some(kept) = choose(&candidates, &p) else {
        invalid!(
            "no checkpoint of {} from iteration {} walks every validation command without a fall or a stand-still \
             and with air time ≥ {} s at ≤ {MAX_STEPS_PER_S} steps/s: pass a smaller --from or --min-air-time, or \
             train longer",
            run.display(),
            p.from,
            p.min_air_time_s
        );
    };
    let selected = kept.iteration;
    let sidecar = &picked.iter().find(|(it, _)| *it == selected).expect("the kept candidate is a picked checkpoint").1;
    let written = topa_train::export_checkpoint(sidecar, &dir.join("policy"))?;
    // The report names the policy relative to its own folder: reports carry no path of the machine.
    let policy = PathBuf::from(&name).join(written.file_name().unwrap_or_default());
    Ok(Selection { run: name, seed, commands, candidates, selected, policy })
}

/// The report: the validation commands, then per run each checkpoint's score with the kept one marked.
pub fn markdown(selections: &[Selection], protocol: &str) -> String {
    let mut s = String::from("# Checkpoint selection on held-out commands\n\n");
    let _ = writeln!(
        s,
        "{protocol}. Score: the mean over the validation commands of each command's largest component MAE (whole \
         window). The six tracking commands of the reports \
         are not among the validation commands.\n"
    );
    if let Some(first) = selections.first() {
        let list: Vec<String> =
            first.commands.iter().map(|c| format!("({:.2}, {:.2}, {:.2})", c[0], c[1], c[2])).collect();
        let _ = writeln!(s, "Validation commands (v_x, v_y, w_z): {}.\n", list.join(", "));
    }
    let _ = writeln!(s, "| run | seed | kept iteration | score | worst | policy |\n|---|---:|---:|---:|---:|---|");
    for sel in selections {
        let k = sel.candidates.iter().find(|c| c.iteration == sel.selected).expect("the kept candidate is listed");
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.3} | {:.3} | `{}` |",
            sel.run,
            sel.seed,
            sel.selected,
            k.score,
            k.worst,
            sel.policy.display()
        );
    }
    for sel in selections {
        let _ = writeln!(
            s,
            "\n### {}\n\n| iteration | score | worst | falls | stand-stills | air (s) | steps/s | kept |\n\
             |---:|---:|---:|---:|---:|---:|---:|---|",
            sel.run
        );
        for c in &sel.candidates {
            let mark = if c.iteration == sel.selected { "**kept**" } else { "" };
            let _ = writeln!(
                s,
                "| {} | {:.3} | {:.3} | {} | {} | {:.3} | {:.2} | {mark} |",
                c.iteration, c.score, c.worst, c.falls, c.stand_stills, c.air_time_s, c.steps_per_s
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::results::COMMANDS;

    fn cand(iteration: usize, score: f64, falls: usize, stand_stills: usize) -> Candidate {
        Candidate { iteration, score, worst: score, falls, stand_stills, air_time_s: 0.3, steps_per_s: 1.5 }
    }

    const P: Protocol = Protocol { from: 800, every: 25, commands: 12, starts: 2, seconds: 10.0, min_air_time_s: 0.25 };

    #[test]
    fn validation_commands_are_in_range_fixed_by_the_seed_and_never_a_report_command() {
        let ranges = CommandConfig::default();
        let a = validation_commands(&ranges, 30, 1);
        assert_eq!(a, validation_commands(&ranges, 30, 1));
        assert_ne!(a, validation_commands(&ranges, 30, 2));
        for (i, c) in a.iter().enumerate() {
            assert!((ranges.lin_vel_x[0]..=ranges.lin_vel_x[1]).contains(&c[0]), "{c:?}");
            assert!((ranges.lin_vel_y[0]..=ranges.lin_vel_y[1]).contains(&c[1]), "{c:?}");
            assert!((ranges.ang_vel_z[0]..=ranges.ang_vel_z[1]).contains(&c[2]), "{c:?}");
            if i % PURE_TURN_EVERY == PURE_TURN_EVERY - 1 {
                assert!(c[0] == 0.0 && c[1] == 0.0 && c[2].abs() >= MIN_SHARE * 1.2, "turn in place {c:?}");
            } else {
                assert!(c[0].hypot(c[1]) >= MIN_SHARE * 0.7 - 1e-12, "moves {c:?}");
            }
            assert!(COMMANDS.iter().all(|(_, _, r)| r != c), "{c:?} is a report command");
        }
    }

    #[test]
    fn the_smallest_score_without_a_fall_or_stand_still_is_kept() {
        let c = [cand(800, 0.10, 1, 0), cand(850, 0.12, 0, 2), cand(900, 0.14, 0, 0), cand(950, 0.13, 0, 0)];
        assert_eq!(choose(&c, &P).map(|c| c.iteration), Some(950));
        // A tie goes to the later checkpoint.
        let tie = [cand(800, 0.13, 0, 0), cand(850, 0.13, 0, 0)];
        assert_eq!(choose(&tie, &P).map(|c| c.iteration), Some(850));
        assert!(choose(&[cand(800, 0.1, 1, 0), cand(850, f64::NAN, 0, 0)], &P).is_none());
    }

    #[test]
    fn a_checkpoint_that_shuffles_is_never_kept() {
        let short = Candidate { air_time_s: 0.24, ..cand(900, 0.09, 0, 0) };
        let fast = Candidate { steps_per_s: 2.6, ..cand(925, 0.08, 0, 0) };
        let c = [short, fast, cand(950, 0.12, 0, 0)];
        assert_eq!(choose(&c, &P).map(|c| c.iteration), Some(950));
        let no_step = Candidate { air_time_s: f64::NAN, ..cand(975, 0.05, 0, 0) };
        assert!(choose(&[no_step], &P).is_none());
    }
}
