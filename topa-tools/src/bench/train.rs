//! `topa bench train`: real training iterations of a preset, timed part by part — collection (env stepping,
//! of which physics and resets; inference; the serial rest) and the update — beside the bare physics bound
//! measured in the same run at the preset's integrator and timestep.
//!
//! Two bounds are printed. The *standing* bound is the issue's: bare `mj_step` on one Data holding the stand pose
//! under small random targets, × threads ÷ decimation. The *in-run* bound divides the env-steps by the CPU time
//! the workers actually spent inside `mj_step` (÷ threads): the same states, contacts and solver work as the
//! rollout, so its ratio is exactly the share of collection that is physics.
//!
//! The time to the preset's end takes each phase of the adversary's schedule at its own iteration time: phase 2
//! (the adversary's update) and phase 3 (the policy's, with the adversary acting and, in the current preset, each
//! minibatch mirrored) are timed on a trainer with the adversary moved to that phase.
//!
//! Thread counts are fixed once per process, so each count runs in a child process (`--worker`).

use std::process::Command;
use std::time::Instant;

use serde::{Deserialize, Serialize};
use trainer::Trainer;

use crate::error::{Error, Result};

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct WorkerResult {
    pub threads: usize,
    pub envs: usize,
    pub iterations: usize,
    /// Samples (env-steps) per iteration.
    pub samples: usize,
    /// Means over the timed iterations, s.
    pub iteration_s: f64,
    pub collect_s: f64,
    pub inference_s: f64,
    pub update_s: f64,
    /// Wall time of the batched env steps, and the workers' CPU time inside them (physics, resets, the rest).
    pub env_wall_s: f64,
    pub task_cpu_s: f64,
    pub physics_cpu_s: f64,
    pub reset_cpu_s: f64,
    /// Episodes that ended per iteration (resets).
    pub episodes: f64,
    /// Bare mj_step/s on one thread (stand pose), measured in this worker before training.
    pub standing_steps_per_s: f64,
    pub decimation: usize,
    /// Mean iteration time in the adversary's phases, s: phase 2 (the adversary learns) and phase 3 (the policy
    /// learns under attack), each timed on a trainer with the adversary moved to that phase.
    #[serde(default)]
    pub adversary_phase_s: f64,
    #[serde(default)]
    pub attacked_phase_s: f64,
}

/// Mean seconds of `iterations` iterations of the phase that starts at iteration `first` of the adversary's
/// schedule, after `warmup` untimed ones (all inside the phase, which `len` iterations long).
fn time_phase(
    cfg: &trainer::TrainConfig,
    env: &topa_env::EnvConfig,
    first: usize,
    len: usize,
    warmup: usize,
    iterations: usize,
) -> Result<f64> {
    let envs = topa_env::vec_env::task_batch(env, 0, cfg.run.num_envs, cfg.run.seed, 0)?;
    let mut t = Trainer::new(cfg.clone(), envs, true)?;
    t.iteration = first;
    let warmup = warmup.min(len.saturating_sub(iterations.max(1)));
    let timed = iterations.min(len - warmup).max(1);
    for _ in 0..warmup {
        t.iterate()?.ok_or_else(|| Error::bad_bench("warm-up iteration"))?;
    }
    let start = Instant::now();
    for _ in 0..timed {
        t.iterate()?.ok_or_else(|| Error::bad_bench("iteration"))?;
    }
    Ok(start.elapsed().as_secs_f64() / timed as f64)
}

pub struct Args<'a> {
    pub config: &'a std::path::Path,
    pub threads: &'a [usize],
    pub envs: Option<usize>,
    pub iterations: usize,
    pub warmup: usize,
    pub integrator: Option<topa_env::IntegratorChoice>,
    /// Interleaved rounds over the thread counts; the fastest round of each count is kept (the machine is shared).
    pub rounds: usize,
}

/// One measurement in this process: `warmup` untimed iterations, then `iterations` timed ones.
pub fn worker(a: &Args, threads: usize) -> Result<WorkerResult> {
    trainer::nn::init_threads(threads)?;
    let (mut cfg, mut env_cfg) = topa_train::load_config(a.config)?;
    cfg.run.threads = threads;
    if let Some(n) = a.envs {
        cfg.run.num_envs = n;
    }
    if let Some(i) = &a.integrator {
        env_cfg.integrator = *i;
        cfg.env = env_cfg.to_table();
    }
    let standing = super::env::physics_steps_per_second(&env_cfg, 2.0)?;
    let env = topa_env::vec_env::task_batch(&env_cfg, 0, cfg.run.num_envs, cfg.run.seed, 0)?;
    let mut t = Trainer::new(cfg.clone(), env, false)?;
    for _ in 0..a.warmup {
        t.iterate()?.ok_or_else(|| Error::bad_bench("warm-up iteration"))?;
    }
    let mut r = WorkerResult {
        threads,
        envs: cfg.run.num_envs,
        iterations: a.iterations,
        samples: cfg.run.num_envs * cfg.run.steps_per_env,
        standing_steps_per_s: standing,
        decimation: env_cfg.decimation,
        ..Default::default()
    };
    for _ in 0..a.iterations {
        let start = Instant::now();
        let log = t.iterate()?.ok_or_else(|| Error::bad_bench("iteration"))?;
        r.iteration_s += start.elapsed().as_secs_f64();
        r.collect_s += log.collect_s;
        r.inference_s += log.inference_s;
        r.update_s += log.update_s;
        let e = log.env_timing;
        r.env_wall_s += e.wall_s;
        r.task_cpu_s += e.task_s;
        r.physics_cpu_s += e.physics_s;
        r.reset_cpu_s += e.reset_s;
        r.episodes += (log.episodes.episodes + log.episodes.diverged) as f64;
    }
    let ad = &cfg.adversary;
    let attackable = !t.env.perturbation_channels().is_empty();
    if attackable && ad.phase2_adversary_iters > 0 && ad.phase3_policy_iters > 0 && ad.cycles > 0 {
        let (p1, p2) = (ad.phase1_policy_iters, ad.phase2_adversary_iters);
        r.adversary_phase_s = time_phase(&cfg, &env_cfg, p1, p2, a.warmup, a.iterations)?;
        r.attacked_phase_s = time_phase(&cfg, &env_cfg, p1 + p2, ad.phase3_policy_iters, a.warmup, a.iterations)?;
    }
    let k = a.iterations.max(1) as f64;
    for v in [
        &mut r.iteration_s,
        &mut r.collect_s,
        &mut r.inference_s,
        &mut r.update_s,
        &mut r.env_wall_s,
        &mut r.task_cpu_s,
        &mut r.physics_cpu_s,
        &mut r.reset_cpu_s,
        &mut r.episodes,
    ] {
        *v /= k;
    }
    Ok(r)
}

fn run_worker(a: &Args, threads: usize) -> Result<WorkerResult> {
    let exe = std::env::current_exe().map_err(|e| Error::bench("locating the topa binary", e))?;
    let mut cmd = Command::new(exe);
    cmd.args(["bench", "train", "--worker", "--config"]).arg(a.config);
    cmd.args(["--threads", &threads.to_string(), "--iterations", &a.iterations.to_string()]);
    cmd.args(["--warmup", &a.warmup.to_string()]);
    if let Some(n) = a.envs {
        cmd.args(["--envs", &n.to_string()]);
    }
    if let Some(i) = &a.integrator {
        cmd.args(["--integrator", i.name()]);
    }
    super::worker_result(cmd, threads)
}

pub fn run(a: &Args) -> Result<()> {
    let (cfg, env_cfg) = topa_train::load_config(a.config)?;
    let envs = a.envs.unwrap_or(cfg.run.num_envs);
    let integ = a.integrator.unwrap_or(env_cfg.integrator);
    println!(
        "{}: {envs} envs × {} steps, integrator {integ}, timestep {} s × {}; {} timed iterations after {} warm-up, \
         best of {} interleaved rounds\nmachine: {}\n",
        a.config.display(),
        cfg.run.steps_per_env,
        env_cfg.timestep,
        env_cfg.decimation,
        a.iterations,
        a.warmup,
        a.rounds.max(1),
        trainer::segments::this_machine()
    );
    let start = Instant::now();
    let mut results: Vec<Option<WorkerResult>> = vec![None; a.threads.len()];
    for _ in 0..a.rounds.max(1) {
        for (slot, &t) in results.iter_mut().zip(a.threads) {
            let r = run_worker(a, t)?;
            if slot.as_ref().is_none_or(|b| r.iteration_s < b.iteration_s) {
                *slot = Some(r);
            }
        }
    }
    let results: Vec<WorkerResult> = results.into_iter().flatten().collect();
    println!("| threads | samples/s | iteration (s) | collect (s) | env step (s) | inference (s) | serial rest (s) | update (s) |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &results {
        println!(
            "| {} | {:.0} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            r.threads,
            r.samples as f64 / r.iteration_s,
            r.iteration_s,
            r.collect_s,
            r.env_wall_s,
            r.inference_s,
            r.collect_s - r.env_wall_s - r.inference_s,
            r.update_s
        );
    }
    // What a user waits for: the preset's runs at the measured iteration times, each phase of the adversary's
    // schedule at its own (phase 2 updates the adversary, phase 3 the policy with the adversary acting).
    let ad = &cfg.adversary;
    let pipeline = ad.schedule().total();
    println!("\ntime to the preset's end at these rates (h:mm), and an iteration of each phase of C+A (s):\n");
    println!(
        "| threads | plain run ({} its) | C+A pipeline: its C, then C+A ({pipeline} its) | phase 1 / 2 / 3 iteration (s) |",
        cfg.run.iterations
    );
    println!("|---:|---:|---:|---|");
    for r in &results {
        let cycles = ad.cycles as f64
            * (ad.phase2_adversary_iters as f64 * r.adversary_phase_s
                + ad.phase3_policy_iters as f64 * r.attacked_phase_s);
        // No adversary phases timed: the task takes no perturbations, or the schedule has no cycles.
        let (pipeline, phases) = if r.attacked_phase_s > 0.0 {
            let all = ad.phase1_policy_iters as f64 * r.iteration_s + cycles;
            (
                hours_minutes(all),
                format!("{:.3} / {:.3} / {:.3}", r.iteration_s, r.adversary_phase_s, r.attacked_phase_s),
            )
        } else {
            ("–".into(), format!("{:.3} / – / –", r.iteration_s))
        };
        let plain = hours_minutes(cfg.run.iterations as f64 * r.iteration_s);
        println!("| {} | {plain} | {pipeline} | {phases} |", r.threads);
    }
    println!(
        "\nworkers' CPU in env steps, per iteration: physics / resets / the rest (s), and the bounds (env-steps/s):\n"
    );
    println!("| threads | physics | resets (episodes) | rest | standing bound | in-run bound | collect ratio (standing / in-run) | end-to-end ratio (standing / in-run) |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &results {
        let t = r.threads as f64;
        let standing = r.standing_steps_per_s / r.decimation as f64 * t;
        let in_run = r.samples as f64 / (r.physics_cpu_s / t);
        let collect = r.samples as f64 / r.collect_s;
        let e2e = r.samples as f64 / r.iteration_s;
        println!(
            "| {} | {:.3} | {:.3} ({:.0}) | {:.3} | {:.0} | {:.0} | {:.3} / {:.3} | {:.3} / {:.3} |",
            r.threads,
            r.physics_cpu_s,
            r.reset_cpu_s,
            r.episodes,
            r.task_cpu_s - r.physics_cpu_s - r.reset_cpu_s,
            standing,
            in_run,
            collect / standing,
            collect / in_run,
            e2e / standing,
            e2e / in_run
        );
    }
    if let (Some(one), Some(two)) = (results.iter().find(|r| r.threads == 1), results.iter().find(|r| r.threads == 2)) {
        println!(
            "\n2 threads vs 1: collect {:.2}×, end-to-end {:.2}× (goal ≥ 1.9× for collect)",
            one.collect_s / two.collect_s,
            one.iteration_s / two.iteration_s
        );
    }
    println!("goals: collect ≥ 0.9 of the bound; end-to-end (configs/cpu.toml) ≥ 0.6 of the bound");
    eprintln!("bench took {:.0} s", start.elapsed().as_secs_f64());
    Ok(())
}

fn hours_minutes(seconds: f64) -> String {
    let m = (seconds / 60.0).round() as u64;
    format!("{}:{:02}", m / 60, m % 60)
}
