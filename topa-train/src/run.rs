//! A training run in its folder: started from a config (or forked from another run's policy), or resumed from its
//! latest checkpoint; trained to its end with CSV + TensorBoard metrics, atomic checkpoints every K iterations, the
//! latest policy exported beside them, and a PNG learning curve. Rank 0 alone writes; the others only train.

use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::Instant;

use trainer::checkpoint;
use trainer::comm::Comm;
use trainer::metrics::MetricsWriter;
use trainer::{IterationLog, Trainer};

use crate::config::{added_inputs, env_config, load_config, with_env};
use crate::error::{invalid, Error, Result};
use crate::policy::export_policy;
use crate::ranks::{check_ranks_agree, rank_env, ranks};

/// What a run is asked to be: a new run of `config` (with overrides) or `resume` of the run in a folder.
#[derive(Debug, Clone, Default)]
pub struct Start {
    /// The TOML preset of a new run.
    pub config: Option<PathBuf>,
    /// The robot spec to train (overrides the config's `env.robot`).
    pub robot: Option<String>,
    pub seed: Option<u64>,
    /// Output folder (default `runs/<robot>[-adversary]-seed<S>`).
    pub out: Option<PathBuf>,
    /// Run the paper's cyclic adversarial schedule.
    pub adversary: bool,
    /// Threads for environments and networks (default: the config's; 0 = all cores).
    pub threads: Option<usize>,
    /// A plain run's length; with `resume`, lengthens or shortens it.
    pub iterations: Option<usize>,
    /// Continue the run in this folder from its latest checkpoint.
    pub resume: Option<PathBuf>,
    /// Start the policy from another run's checkpoint (folder or sidecar).
    pub init_from: Option<PathBuf>,
    /// The command as the user typed it, recorded in checkpoints and policy files.
    pub command: String,
}

/// A run opened in its folder, ready to train.
pub struct Run {
    pub trainer: Trainer,
    /// The run's folder.
    pub out: PathBuf,
    command: String,
    resumed_at: Option<usize>,
    comm: Rc<dyn Comm>,
    metrics: Option<MetricsWriter>,
    /// What opening did beyond a new run, for the user: the checkpoint resumed, the policy forked from.
    pub notice: Option<String>,
}

/// Where a finished run put its results (rank 0).
pub struct Outcome {
    pub iterations: usize,
    pub samples: u64,
    pub seconds: f64,
    pub policy: PathBuf,
    pub metrics: Option<PathBuf>,
    pub curve: Option<PathBuf>,
    /// With several MPI ranks: this rank's digest of the final weights (every rank's is the same).
    pub weights_crc: Option<u32>,
}

impl Run {
    /// Opens the run `s` asks for: checks the request, sets the thread pools, builds this rank's envs, restores a
    /// resumed run's checkpoint or a fork's policy, and writes a new run's resolved `config.toml`.
    pub fn open(s: &Start) -> Result<Run> {
        let comm = ranks()?;
        let (trainer, out, command, resumed_at, notice) = match &s.resume {
            Some(dir) => resume(s, dir, &comm)?,
            None => start(s, &comm)?,
        };
        let lead = comm.rank() == 0;
        let channels: Vec<String> = trainer.env.perturbation_channels().into_iter().map(|c| c.name).collect();
        let metrics = if lead {
            Some(MetricsWriter::open(&out, &trainer.env.term_names(), &channels, resumed_at)?)
        } else {
            None
        };
        Ok(Run { trainer, out, command, resumed_at, comm, metrics, notice })
    }

    /// This process writes the run's files and reports (rank 0).
    pub fn is_lead(&self) -> bool {
        self.comm.rank() == 0
    }

    /// The number of processes training the run.
    pub fn ranks(&self) -> usize {
        self.comm.size()
    }

    /// Trains to the run's end, calling `each` after every iteration; checkpoints every `run.checkpoint_every`.
    pub fn train(mut self, mut each: impl FnMut(&IterationLog)) -> Result<Outcome> {
        let started = Instant::now();
        let (every, keep) = (self.trainer.cfg.run.checkpoint_every, self.trainer.cfg.run.keep_checkpoints);
        while let Some(log) = self.trainer.iterate()? {
            if let Some(m) = &mut self.metrics {
                m.write(&log)?;
            }
            each(&log);
            if log.iteration % every == 0 || self.trainer.is_done() {
                self.save(keep)?;
            }
        }
        // A resume that shortened the run to where it stood exports here: the record then names the final config.
        if self.resumed_at == Some(self.trainer.iteration) {
            self.save(keep)?;
        }
        let weights_crc = if self.comm.size() > 1 { Some(check_ranks_agree(&self.trainer)?) } else { None };
        let (metrics, curve) = match &self.metrics {
            None => (None, None),
            Some(m) => {
                let png = self.out.join("learning_curve.png");
                let curve = match crate::dashboard::learning_curve(m.csv_path(), &png) {
                    Ok(()) => Some(png),
                    Err(e) => {
                        log::warn!("no learning curve: {e}");
                        None
                    }
                };
                (Some(m.csv_path().to_path_buf()), curve)
            }
        };
        Ok(Outcome {
            iterations: self.trainer.iteration,
            samples: self.trainer.samples,
            seconds: started.elapsed().as_secs_f64(),
            policy: self.out.join("policy.json"),
            metrics,
            curve,
            weights_crc,
        })
    }

    fn save(&self, keep: usize) -> Result<()> {
        if self.comm.size() > 1 {
            check_ranks_agree(&self.trainer)?;
        }
        checkpoint::save(&self.trainer, &self.out.join("checkpoints"), &self.command, keep)?;
        if self.is_lead() {
            export_policy(&self.trainer, &self.out, &self.command)?;
        }
        Ok(())
    }
}

type Opened = (Trainer, PathBuf, String, Option<usize>, Option<String>);

fn resume(s: &Start, dir: &Path, comm: &Rc<dyn Comm>) -> Result<Opened> {
    if s.config.is_some() || s.robot.is_some() || s.seed.is_some() || s.adversary || s.init_from.is_some() {
        invalid!(
            "--resume continues a run with its own saved config: drop --config/--model/--robot/--seed/--adversary/--init-from"
        );
    }
    let side_path = checkpoint::latest(&dir.join("checkpoints"))?;
    let (side, loaded) = checkpoint::read_sidecar(&side_path)?;
    // Checkpoints of earlier builds hold the `[env]` table as written: resolved now, the run keeps the
    // defaults it was started with in the checkpoints it writes from here on.
    let env = env_config(&side.config)?;
    let mut cfg = with_env(&side.config, &env);
    if let Some(th) = s.threads {
        cfg.run.threads = th;
    }
    if let Some(n) = s.iterations {
        if side.with_adversary {
            invalid!("--iterations cannot change an adversary run: its length is the [adversary] schedule's");
        }
        if n < side.iteration {
            invalid!("--iterations {n} is below the {} iterations {} has already run", side.iteration, dir.display());
        }
        cfg.run.iterations = n;
    }
    trainer::nn::init_threads(trainer::nn::resolve_threads(cfg.run.threads))?;
    let mut t = Trainer::new(cfg.clone(), rank_env(&cfg, &env, comm.as_ref())?, side.with_adversary)?;
    t.set_comm(comm.clone());
    checkpoint::restore(&mut t, &side, &loaded)?;
    let notice = format!("resuming {} at iteration {} ({} samples so far)", dir.display(), t.iteration, t.samples);
    let it = t.iteration;
    // The record keeps every invocation that shaped the run (a resume may change its length).
    let command =
        if s.iterations.is_some() { format!("{} && {}", side.command, s.command) } else { side.command.clone() };
    Ok((t, dir.to_path_buf(), command, Some(it), Some(notice)))
}

fn start(s: &Start, comm: &Rc<dyn Comm>) -> Result<Opened> {
    let path = s
        .config
        .as_deref()
        .ok_or_else(|| Error::Invalid("give --config configs/<preset>.toml (or --resume DIR)".into()))?;
    let (mut cfg, mut env) = load_config(path)?;
    if let Some(r) = &s.robot {
        env.robot = r.clone();
    }
    if let Some(seed) = s.seed {
        cfg.run.seed = seed;
    }
    if let Some(th) = s.threads {
        cfg.run.threads = th;
    }
    if let Some(n) = s.iterations {
        if s.adversary {
            invalid!(
                "--iterations sets a plain run's length; an adversary run's length is its [adversary] schedule \
                 (phase1_policy_iters + cycles × (phase2_adversary_iters + phase3_policy_iters)): change those"
            );
        }
        cfg.run.iterations = n;
    }
    // The run's config.toml, checkpoints and policy record every task key, not only the preset's.
    let cfg = with_env(&cfg, &env);
    cfg.validate().map_err(trainer::Error::from)?;
    trainer::nn::init_threads(trainer::nn::resolve_threads(cfg.run.threads))?;
    let out = s.out.clone().unwrap_or_else(|| {
        PathBuf::from(format!(
            "runs/{}{}-seed{}",
            Path::new(&env.robot).file_stem().map_or("robot".into(), |s| s.to_string_lossy()),
            if s.adversary { "-adversary" } else { "" },
            cfg.run.seed
        ))
    });
    if out.join("checkpoints/latest.json").exists() {
        invalid!(
            "{} already holds a run: continue it with `topa train --resume {}` or choose another --out",
            out.display(),
            out.display()
        );
    }
    if comm.rank() == 0 {
        std::fs::create_dir_all(&out).map_err(Error::io("creating", &out))?;
        trainer::tensorfile::write_atomic(&out.join("config.toml"), toml::to_string_pretty(&cfg)?.as_bytes())?;
    }
    let mut t = Trainer::new(cfg.clone(), rank_env(&cfg, &env, comm.as_ref())?, s.adversary)?;
    t.set_comm(comm.clone());
    let mut notice = None;
    if let Some(from) = &s.init_from {
        let side_path = if from.is_dir() {
            checkpoint::latest(&from.join("checkpoints")).or_else(|_| checkpoint::latest(from))?
        } else {
            from.clone()
        };
        let (side, loaded) = checkpoint::read_sidecar(&side_path)?;
        checkpoint::init_policy_from(&mut t, &side, &loaded, added_inputs(&side, &env)?)?;
        notice = Some(format!("policy initialised from {} (iteration {})", side_path.display(), side.iteration));
    }
    Ok((t, out, s.command.clone(), None, notice))
}
