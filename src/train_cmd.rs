//! `topa train`: a run from a TOML preset (or `--resume DIR`), with a progress bar, CSV + TensorBoard metrics,
//! atomic checkpoints every K iterations, the latest policy exported next to them, and a PNG learning curve.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use topa_env::{assets, ModelKind, VecEnv};
use trainer::checkpoint;
use trainer::metrics::MetricsWriter;
use trainer::policy_file::{self, PolicyMeta, Provenance};
use trainer::{IterationLog, TrainConfig, Trainer};

pub struct TrainArgs {
    pub config: Option<PathBuf>,
    pub model: Option<ModelKind>,
    pub seed: Option<u64>,
    pub out: Option<PathBuf>,
    pub adversary: bool,
    pub threads: Option<usize>,
    pub iterations: Option<usize>,
    pub resume: Option<PathBuf>,
    pub init_from: Option<PathBuf>,
    pub quiet: bool,
}

/// The TopA batch for a config (the env crate checks the model against the spec).
pub fn topa_env(cfg: &TrainConfig) -> Result<Box<dyn VecEnv>> {
    Ok(Box::new(assets::topa_batch(&cfg.env, cfg.run.num_envs, cfg.run.seed, 0)?))
}

/// The command as a user would retype it: `topa` and the arguments, whatever the binary's path.
fn command_line() -> String {
    std::iter::once("topa".to_string()).chain(std::env::args().skip(1)).collect::<Vec<_>>().join(" ")
}

fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    format!("{} × {cpu}", std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Exports the current policy as `<out>/policy.{safetensors,json}`.
pub fn export_policy(t: &Trainer, out: &Path, command: &str) -> Result<PathBuf> {
    let cfg = &t.cfg;
    let meta = PolicyMeta {
        format: policy_file::FORMAT.into(),
        version: policy_file::VERSION,
        model: Some(cfg.env.model),
        obs_dim: t.env.obs_dim(),
        action_dim: t.env.action_dim(),
        hidden: cfg.network.actor_hidden.clone(),
        activation: cfg.network.activation.clone(),
        action_scale: cfg.env.action_scale,
        action_clip: cfg.env.action_clip,
        policy_dt: cfg.env.policy_dt(),
        weights: String::new(),
        weights_crc32: 0,
        provenance: Provenance {
            command: command.to_string(),
            config: cfg.clone(),
            seed: cfg.run.seed,
            iterations: t.iteration,
            samples: t.samples,
            wall_time_s: t.wall_time_s,
            with_adversary: t.adversary.is_some(),
            trained_on: format!("{}, {}", crate::today(), machine()),
        },
    };
    policy_file::save(&out.join("policy"), &t.policy.ac.actor, &t.policy.normalizer, meta)
}

fn progress_line(log: &IterationLog, total: usize) -> String {
    let e = &log.episodes;
    let phase = match log.phase.number() {
        1 => "phase 1".to_string(),
        p => format!("phase {p} c{}", log.cycle),
    };
    // Envs that start together (a new run, a fork) also time out together, so most iterations end no episode.
    let episodes = if e.episodes == 0 {
        "no episode ended".to_string()
    } else {
        format!("return {:.2} | length {:.0}", e.mean_return, e.mean_length)
    };
    format!(
        "it {}/{total} {phase} | {episodes} | {:.0} samples/s{}",
        log.iteration,
        log.fps,
        if e.diverged > 0 { format!(" | {} diverged", e.diverged) } else { String::new() }
    )
}

pub fn run(args: TrainArgs) -> Result<()> {
    let (mut trainer, out, command, resumed_at) = if let Some(dir) = &args.resume {
        if args.config.is_some()
            || args.model.is_some()
            || args.seed.is_some()
            || args.adversary
            || args.init_from.is_some()
        {
            bail!("--resume continues a run with its own saved config: drop --config/--model/--seed/--adversary/--init-from");
        }
        let side_path = checkpoint::latest(&dir.join("checkpoints"))?;
        let (side, loaded) = checkpoint::read_sidecar(&side_path)?;
        let mut cfg = side.config.clone();
        if let Some(th) = args.threads {
            cfg.run.threads = th;
        }
        if let Some(n) = args.iterations {
            if side.with_adversary {
                bail!("--iterations cannot change an adversary run: its length is the [adversary] schedule's");
            }
            if n < side.iteration {
                bail!("--iterations {n} is below the {} iterations {} has already run", side.iteration, dir.display());
            }
            cfg.run.iterations = n;
        }
        trainer::nn::init_threads(crate::resolve_threads(cfg.run.threads))?;
        let mut t = Trainer::new(cfg.clone(), topa_env(&cfg)?, side.with_adversary)?;
        checkpoint::restore(&mut t, &side, &loaded)?;
        eprintln!("resuming {} at iteration {} ({} samples so far)", dir.display(), t.iteration, t.samples);
        let it = t.iteration;
        // The record keeps every invocation that shaped the run (a resume may change its length).
        let command = if args.iterations.is_some() {
            format!("{} && {}", side.command, command_line())
        } else {
            side.command.clone()
        };
        (t, dir.clone(), command, Some(it))
    } else {
        let path = args.config.as_deref().context("give --config configs/<preset>.toml (or --resume DIR)")?;
        let mut cfg = TrainConfig::load(path)?;
        if let Some(m) = args.model {
            cfg.env.model = m;
        }
        if let Some(s) = args.seed {
            cfg.run.seed = s;
        }
        if let Some(th) = args.threads {
            cfg.run.threads = th;
        }
        if let Some(n) = args.iterations {
            cfg.run.iterations = n;
        }
        cfg.validate().map_err(anyhow::Error::msg)?;
        trainer::nn::init_threads(crate::resolve_threads(cfg.run.threads))?;
        let out = args.out.clone().unwrap_or_else(|| {
            PathBuf::from(format!(
                "runs/{}{}-seed{}",
                cfg.env.model.name(),
                if args.adversary { "-adversary" } else { "" },
                cfg.run.seed
            ))
        });
        if out.join("checkpoints/latest.json").exists() {
            bail!(
                "{} already holds a run: continue it with `topa train --resume {}` or choose another --out",
                out.display(),
                out.display()
            );
        }
        std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
        trainer::tensorfile::write_atomic(&out.join("config.toml"), toml::to_string_pretty(&cfg)?.as_bytes())?;
        let mut t = Trainer::new(cfg.clone(), topa_env(&cfg)?, args.adversary)?;
        if let Some(from) = &args.init_from {
            let side_path = if from.is_dir() {
                checkpoint::latest(&from.join("checkpoints")).or_else(|_| checkpoint::latest(from))?
            } else {
                from.clone()
            };
            let (side, loaded) = checkpoint::read_sidecar(&side_path)?;
            checkpoint::init_policy_from(&mut t, &side, &loaded)?;
            eprintln!("policy initialised from {} (iteration {})", side_path.display(), side.iteration);
        }
        (t, out, command_line(), None)
    };

    let ckpt_dir = out.join("checkpoints");
    let mut metrics = MetricsWriter::open(&out, &trainer.env.term_names(), resumed_at)?;
    let total = trainer.total_iterations();
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(total as u64) };
    bar.set_style(ProgressStyle::with_template("{bar:30} {msg} | ETA {eta}").unwrap());
    bar.set_position(trainer.iteration as u64);
    let every = trainer.cfg.run.checkpoint_every;
    let keep = trainer.cfg.run.keep_checkpoints;
    let started = Instant::now();
    while let Some(log) = trainer.iterate()? {
        metrics.write(&log)?;
        bar.set_position(log.iteration as u64);
        bar.set_message(progress_line(&log, total));
        if args.quiet && log.iteration % 10 == 0 {
            eprintln!("{}", progress_line(&log, total));
        }
        if log.iteration % every == 0 || trainer.is_done() {
            checkpoint::save(&trainer, &ckpt_dir, &command, keep)?;
            export_policy(&trainer, &out, &command)?;
        }
    }
    bar.finish();
    // A resume that shortened the run to where it stood exports here: the record then names the final config.
    if resumed_at == Some(trainer.iteration) {
        checkpoint::save(&trainer, &ckpt_dir, &command, keep)?;
        export_policy(&trainer, &out, &command)?;
    }
    let png = out.join("learning_curve.png");
    if let Err(e) = crate::plots::learning_curve(metrics.csv_path(), &png) {
        log::warn!("no learning curve: {e:#}");
    }
    println!(
        "trained {} iterations ({} samples, {:.0} s this session) → {}",
        trainer.iteration,
        trainer.samples,
        started.elapsed().as_secs_f64(),
        out.join("policy.json").display()
    );
    println!(
        "metrics: {}, TensorBoard: {}, curve: {}",
        metrics.csv_path().display(),
        out.join("tb").display(),
        png.display()
    );
    Ok(())
}
