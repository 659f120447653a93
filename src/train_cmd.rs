//! `topa train`: a run from a TOML preset (or `--resume DIR`), with a progress bar, CSV + TensorBoard metrics,
//! atomic checkpoints every K iterations, the latest policy exported next to them, and a PNG learning curve.

use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use topa_env::{assets, EnvConfig, ModelKind, TaskKind, VecEnv};
use trainer::checkpoint;
use trainer::comm::{Comm, Single};
use trainer::metrics::MetricsWriter;
use trainer::policy_file::{self, PolicyMeta, Provenance};
use trainer::{IterationLog, TrainConfig, Trainer};

/// `topa train`'s arguments.
#[derive(clap::Args, Debug, Clone)]
pub struct TrainArgs {
    /// TOML preset: configs/paper.toml (the paper's table) or configs/cpu.toml (2-core machine).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// TopA's model: closed (the paper's C) or open (the serial baseline O); shorthand for --robot with
    /// assets/robots/topa_closed.toml or topa_open.toml.
    #[arg(long, conflicts_with = "robot")]
    pub model: Option<ModelKind>,
    /// The robot to train: its spec (a TOML beside its MJCF), e.g. assets/robots/kestrel.toml.
    #[arg(long)]
    pub robot: Option<PathBuf>,
    #[arg(long)]
    pub seed: Option<u64>,
    /// Output folder (default runs/<model>[-adversary]-seed<S>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run the paper's cyclic adversarial schedule (phase 1, then 2/3 × cycles).
    #[arg(long)]
    pub adversary: bool,
    /// Threads for environments and networks (default: the config's; 0 = all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Override run.iterations (plain PPO only); with --resume, lengthens or shortens the run.
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Continue the run in this folder from its latest checkpoint.
    #[arg(long, conflicts_with = "config")]
    pub resume: Option<PathBuf>,
    /// Start the policy from another run's checkpoint (folder or sidecar), e.g. C+A from C; a blind policy into a
    /// config with `[env.height_scan]` on gets the scan as new inputs with zero weights.
    #[arg(long)]
    pub init_from: Option<PathBuf>,
    /// No progress bar; a status line every 10 iterations on stderr (for nohup logs).
    #[arg(long)]
    pub quiet: bool,
}

/// A training config file with its `[env]` table checked by the task: every problem names the file and the key.
pub fn load_config(path: &Path) -> Result<(TrainConfig, EnvConfig)> {
    let cfg = TrainConfig::load(path)?;
    let env = EnvConfig::from_table(&cfg.env).with_context(|| format!("config {}", path.display()))?;
    Ok((cfg, env))
}

/// The task's batched envs for a config: a robot's (the env crate checks its model against its spec) or the cart-pole.
pub fn task_env(cfg: &TrainConfig) -> Result<Box<dyn VecEnv>> {
    let env = EnvConfig::from_table(&cfg.env)?;
    Ok(Box::new(topa_env::vec_env::robot_batch(&env, cfg.run.num_envs, cfg.run.seed, 0)?))
}

/// This rank's share of the run's envs: `run.num_envs / ranks` of them, env `i` seeded as env
/// `rank · share + i` of a one-process run, so a seed names the same env streams whatever the rank layout.
fn rank_env(cfg: &TrainConfig, comm: &dyn Comm) -> Result<Box<dyn VecEnv>> {
    let (size, rank) = (comm.size(), comm.rank());
    let n = cfg.run.num_envs;
    if !n.is_multiple_of(size) {
        bail!("run.num_envs = {n} does not split over {size} MPI ranks: choose a multiple of {size}");
    }
    let share = n / size;
    let first = (rank * share) as u64;
    let env = EnvConfig::from_table(&cfg.env)?;
    Ok(match env.task {
        TaskKind::Robot => {
            let (spec, model) = assets::load_robot(&env)?;
            Box::new(topa_env::vec_env::robot_batch_from(model, &spec, &env, first, share, cfg.run.seed, 0)?)
        }
        TaskKind::Cartpole => {
            let model = topa_env::tasks::cartpole::model()?;
            let bound = env.adversary.generic_bound;
            let tasks = (0..share as u64)
                .map(|i| topa_env::tasks::CartPole::new(model.clone(), cfg.run.seed, first + i, 200, bound))
                .collect::<Result<Vec<_>, _>>()?;
            Box::new(topa_env::BatchEnv::new(tasks, 0)?)
        }
    })
}

/// The ranks of this run: MPI's when launched by `mpirun`/`srun` with the `mpi` feature, else one process.
fn ranks() -> Result<Rc<dyn Comm>> {
    let launched = ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_STEP_NUM_TASKS"]
        .iter()
        .find_map(|k| std::env::var(k).ok()?.parse::<usize>().ok())
        .filter(|&n| n > 1);
    match launched {
        None => Ok(Rc::new(Single)),
        #[cfg(feature = "mpi")]
        Some(_) => Ok(Rc::new(crate::mpi_comm::MpiComm::init()?)),
        #[cfg(not(feature = "mpi"))]
        Some(n) => bail!(
            "started as one of {n} MPI ranks, but this topa was built without MPI: build it with \
             `cargo build --release --features mpi` (scripts/setup.sh installs Open MPI when TOPA_MPI=1)"
        ),
    }
}

/// Checks that every MPI rank holds the same policy weights (they should, bit for bit): rank 0 errors otherwise.
/// Returns this rank's digest.
fn check_ranks_agree(t: &Trainer) -> Result<u32> {
    let mut bytes = Vec::new();
    for v in t.policy.ac.vars() {
        for x in v.as_tensor().flatten_all()?.to_vec1::<f32>()? {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
    }
    let crc = trainer::tensorfile::checksum(&bytes);
    let all = t.comm.gather_bytes(&crc.to_le_bytes());
    if t.comm.rank() == 0 && all.iter().any(|b| b[..] != crc.to_le_bytes()) {
        bail!("the MPI ranks' policy weights differ at iteration {} (a bug: please report it)", t.iteration);
    }
    Ok(crc)
}

/// The command as a user would retype it: `topa` and the arguments, whatever the binary's path.
fn command_line() -> String {
    std::iter::once("topa".to_string()).chain(std::env::args().skip(1)).collect::<Vec<_>>().join(" ")
}

/// `cfg` with its `[env]` table resolved: every key of the task's config, the defaults included, so a record of
/// the run says exactly what it ran with (and keeps saying it when a later build changes a default).
pub fn with_resolved_env(cfg: &TrainConfig) -> Result<TrainConfig> {
    let mut cfg = cfg.clone();
    cfg.env = EnvConfig::from_table(&cfg.env)?.to_table();
    Ok(cfg)
}

/// A policy file's sidecar for a run of `provenance.config` at the point `provenance` records: the task's robot,
/// sizes and control settings, and the provenance with its config fully resolved.
fn policy_meta(obs_dim: usize, action_dim: usize, provenance: Provenance) -> Result<PolicyMeta> {
    let cfg = with_resolved_env(&provenance.config)?;
    let env = EnvConfig::from_table(&cfg.env)?;
    Ok(PolicyMeta {
        format: policy_file::FORMAT.into(),
        version: policy_file::VERSION,
        robot: (env.task == TaskKind::Robot).then(|| env.robot.clone()),
        obs_dim,
        action_dim,
        hidden: cfg.network.actor_hidden.clone(),
        activation: cfg.network.activation,
        action_scale: env.action_scale,
        action_clip: env.action_clip,
        policy_dt: env.policy_dt(),
        weights: String::new(),
        weights_crc32: 0,
        provenance: Provenance { config: cfg, ..provenance },
    })
}

/// Exports the current policy as `<out>/policy.{safetensors,json}`; its provenance holds the full resolved config.
pub fn export_policy(t: &Trainer, out: &Path, command: &str) -> Result<PathBuf> {
    let meta = policy_meta(
        t.env.obs_dim(),
        t.env.action_dim(),
        Provenance {
            command: command.to_string(),
            config: t.cfg.clone(),
            seed: t.cfg.run.seed,
            iterations: t.iteration,
            samples: t.samples,
            wall_time_s: t.wall_time_s,
            with_adversary: t.adversary.is_some(),
            trained_on: format!("{}, {}", crate::today(), trainer::segments::this_machine()),
            segments: t.segments.clone(),
        },
    )?;
    policy_file::save(&out.join("policy"), &t.policy.ac.actor, &t.policy.normalizer, meta)
}

/// Exports the policy of a kept checkpoint (its sidecar) as `<stem>.{safetensors,json}`, e.g. to evaluate a run
/// part-way; the provenance is the checkpoint's (its iteration, samples and wall time so far).
pub fn export_checkpoint(sidecar: &Path, stem: &Path) -> Result<PathBuf> {
    let (side, loaded) = checkpoint::read_sidecar(sidecar)?;
    let machine = side.segments.last().map_or("unrecorded machine".to_string(), |s| s.machine.clone());
    let meta = policy_meta(
        side.obs_dim,
        side.action_dim,
        Provenance {
            command: side.command.clone(),
            config: side.config.clone(),
            seed: side.config.run.seed,
            iterations: side.iteration,
            samples: side.samples,
            wall_time_s: side.wall_time_s,
            with_adversary: side.with_adversary,
            trained_on: format!("{machine}; checkpoint {}", sidecar.file_name().unwrap_or_default().to_string_lossy()),
            segments: side.segments.clone(),
        },
    )?;
    checkpoint::save_policy(&side, &loaded, stem, meta)
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
    let comm = if log.comm.calls > 0 {
        format!(
            " | comm {:.0}% {:.1} MB",
            100.0 * log.comm.seconds / log.wall_time_delta(),
            log.comm.bytes as f64 / 1e6
        )
    } else {
        String::new()
    };
    format!(
        "it {}/{total} {phase} | {episodes} | {:.0} samples/s{comm}{}",
        log.iteration,
        log.fps,
        if e.diverged > 0 { format!(" | {} diverged", e.diverged) } else { String::new() }
    )
}

pub fn run(args: TrainArgs) -> Result<()> {
    let comm = ranks()?;
    let lead = comm.rank() == 0;
    let (mut trainer, out, command, resumed_at) = if let Some(dir) = &args.resume {
        if args.config.is_some()
            || args.model.is_some()
            || args.robot.is_some()
            || args.seed.is_some()
            || args.adversary
            || args.init_from.is_some()
        {
            bail!(
                "--resume continues a run with its own saved config: drop --config/--model/--robot/--seed/--adversary/--init-from"
            );
        }
        let side_path = checkpoint::latest(&dir.join("checkpoints"))?;
        let (side, loaded) = checkpoint::read_sidecar(&side_path)?;
        // Checkpoints of earlier builds hold the `[env]` table as written: resolved now, the run keeps the
        // defaults it was started with in the checkpoints it writes from here on.
        let mut cfg = with_resolved_env(&side.config)?;
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
        let mut t = Trainer::new(cfg.clone(), rank_env(&cfg, comm.as_ref())?, side.with_adversary)?;
        t.set_comm(comm.clone());
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
        let (mut cfg, _) = load_config(path)?;
        if let Some(m) = args.model {
            let mut env = EnvConfig::from_table(&cfg.env)?;
            env.robot = m.spec_path().into();
            cfg.env = env.to_table();
        }
        if let Some(r) = &args.robot {
            let mut env = EnvConfig::from_table(&cfg.env)?;
            env.robot = r.to_string_lossy().into_owned();
            cfg.env = env.to_table();
        }
        if let Some(s) = args.seed {
            cfg.run.seed = s;
        }
        if let Some(th) = args.threads {
            cfg.run.threads = th;
        }
        if let Some(n) = args.iterations {
            if args.adversary {
                bail!(
                    "--iterations sets a plain run's length; an adversary run's length is its [adversary] schedule \
                     (phase1_policy_iters + cycles × (phase2_adversary_iters + phase3_policy_iters)): change those"
                );
            }
            cfg.run.iterations = n;
        }
        cfg.validate().map_err(anyhow::Error::msg)?;
        // The run's config.toml, checkpoints and policy record every task key, not only the preset's.
        let cfg = with_resolved_env(&cfg)?;
        let env_cfg = EnvConfig::from_table(&cfg.env)?;
        trainer::nn::init_threads(crate::resolve_threads(cfg.run.threads))?;
        let out = args.out.clone().unwrap_or_else(|| {
            PathBuf::from(format!(
                "runs/{}{}-seed{}",
                std::path::Path::new(&env_cfg.robot).file_stem().map_or("robot".into(), |s| s.to_string_lossy()),
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
        if lead {
            std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
            trainer::tensorfile::write_atomic(&out.join("config.toml"), toml::to_string_pretty(&cfg)?.as_bytes())?;
        }
        let mut t = Trainer::new(cfg.clone(), rank_env(&cfg, comm.as_ref())?, args.adversary)?;
        t.set_comm(comm.clone());
        if let Some(from) = &args.init_from {
            let side_path = if from.is_dir() {
                checkpoint::latest(&from.join("checkpoints")).or_else(|_| checkpoint::latest(from))?
            } else {
                from.clone()
            };
            let (side, loaded) = checkpoint::read_sidecar(&side_path)?;
            checkpoint::init_policy_from(&mut t, &side, &loaded, added_inputs(&side, &env_cfg)?)?;
            eprintln!("policy initialised from {} (iteration {})", side_path.display(), side.iteration);
        }
        (t, out, command_line(), None)
    };

    let ckpt_dir = out.join("checkpoints");
    // Rank 0 alone writes (metrics, checkpoints, the policy) and reports; the others only train.
    let channels: Vec<String> = trainer.env.perturbation_channels().into_iter().map(|c| c.name).collect();
    let mut metrics =
        if lead { Some(MetricsWriter::open(&out, &trainer.env.term_names(), &channels, resumed_at)?) } else { None };
    if comm.size() > 1 && lead {
        eprintln!(
            "{} MPI ranks × {} envs; after an interruption: mpirun -np {} topa train --resume {}",
            comm.size(),
            trainer.env.num_envs(),
            comm.size(),
            out.display()
        );
    }
    let total = trainer.total_iterations();
    let bar = if args.quiet || !lead { ProgressBar::hidden() } else { ProgressBar::new(total as u64) };
    bar.set_style(ProgressStyle::with_template("{bar:30} {msg} | ETA {eta}").unwrap());
    bar.set_position(trainer.iteration as u64);
    let every = trainer.cfg.run.checkpoint_every;
    let keep = trainer.cfg.run.keep_checkpoints;
    let started = Instant::now();
    let save = |t: &Trainer| -> Result<()> {
        if comm.size() > 1 {
            check_ranks_agree(t)?;
        }
        checkpoint::save(t, &ckpt_dir, &command, keep)?;
        if lead {
            export_policy(t, &out, &command)?;
        }
        Ok(())
    };
    while let Some(log) = trainer.iterate()? {
        if let Some(m) = &mut metrics {
            m.write(&log)?;
        }
        bar.set_position(log.iteration as u64);
        bar.set_message(progress_line(&log, total));
        if args.quiet && lead && log.iteration % 10 == 0 {
            say(&progress_line(&log, total));
        }
        if log.iteration % every == 0 || trainer.is_done() {
            save(&trainer)?;
        }
    }
    bar.finish();
    // A resume that shortened the run to where it stood exports here: the record then names the final config.
    if resumed_at == Some(trainer.iteration) {
        save(&trainer)?;
    }
    if comm.size() > 1 {
        let crc = check_ranks_agree(&trainer)?;
        say(&format!("rank {}/{}: policy weights crc32 {crc:08x}", comm.rank(), comm.size()));
    }
    let Some(metrics) = metrics else { return Ok(()) };
    let png = out.join("learning_curve.png");
    if let Err(e) = crate::dashboard::learning_curve(metrics.csv_path(), &png) {
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

/// One line to stderr in a single write: `eprintln!` writes a formatted line piece by piece, and the lines of
/// MPI ranks sharing one stderr then interleave mid-line.
fn say(line: &str) {
    use std::io::Write;
    let _ = std::io::stderr().lock().write_all(format!("{line}\n").as_bytes());
}

/// Observation values a run adds to the policy it starts from: a height scan turned on (its values come after the
/// paper's, so the forked policy starts blind to it and learns to use it); nothing else may change the size.
fn added_inputs(side: &checkpoint::Sidecar, env: &EnvConfig) -> Result<usize> {
    let source = EnvConfig::from_table(&side.config.env)
        .context("the checkpoint's own [env] config does not parse with this build")?;
    let (nx, ny) = env.height_scan.grid();
    Ok(if env.height_scan.enabled && !source.height_scan.enabled { nx * ny } else { 0 })
}
