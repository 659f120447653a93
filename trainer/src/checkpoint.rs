//! Checkpoints: everything needed to continue a run bit for bit — both agents' weights, Adam moments, learning
//! rates and normalisers, the RNG, the iteration (hence the schedule position), and every environment's state —
//! as one safetensors file plus a JSON sidecar, written atomically. `latest.json` points at the newest complete
//! pair and is replaced last, so a crash at any moment leaves a loadable checkpoint.

use std::path::{Path, PathBuf};

use crate::error::{bad_file, invalid, Error, Result};
use candle_core::{Device, Tensor};
use serde::{Deserialize, Serialize};

use crate::config::TrainConfig;
use crate::optim::AdamState;
use crate::ppo::Agent;
use crate::tensorfile::{checksum, write_atomic, Bundle, Loaded, SidecarKind};
use crate::train::Trainer;
use crate::vec_env::EnvSnapshot;

pub const FORMAT: &str = "topa-checkpoint";
pub const VERSION: u32 = 1;

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct AgentMeta {
    pub learning_rate: f64,
    pub adam_step: u64,
    pub normalizer_count: f64,
    /// The concurrent estimator's Adam step count (none without an estimator).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimator_adam_step: Option<u64>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sidecar {
    pub format: String,
    pub version: u32,
    pub iteration: usize,
    pub samples: u64,
    pub wall_time_s: f64,
    pub with_adversary: bool,
    pub rng: Vec<u64>,
    pub policy: AgentMeta,
    pub adversary: Option<AgentMeta>,
    pub num_envs: usize,
    pub obs_dim: usize,
    pub action_dim: usize,
    pub env_f64_width: usize,
    pub env_u64_width: usize,
    /// The weights file (same directory) and its CRC-32.
    pub weights: String,
    pub weights_crc32: u32,
    pub config: TrainConfig,
    /// The command line that started the run (for the record).
    pub command: String,
    /// MPI ranks that wrote it: the env arrays hold `ranks × num_envs` rows in rank order, `rng` is rank 0's
    /// stream and `rank_rngs` those of ranks 1…
    #[serde(default = "one_rank")]
    pub ranks: usize,
    #[serde(default)]
    pub rank_rngs: Vec<Vec<u64>>,
    /// `wall_time_s` by machine and thread count (absent in checkpoints written before it was recorded).
    #[serde(default)]
    pub segments: Vec<crate::segments::Segment>,
}

fn one_rank() -> usize {
    1
}

#[derive(Debug, Serialize, Deserialize)]
struct Latest {
    sidecar: String,
    iteration: usize,
}

fn save_agent(b: &mut Bundle, prefix: &str, a: &Agent) -> Result<AgentMeta> {
    let named = a.ac.named_vars();
    for (i, (name, var)) in named.iter().enumerate() {
        let dims = var.dims().to_vec();
        b.add_f32(&format!("{prefix}.{name}"), &dims, &var.as_tensor().flatten_all()?.to_vec1::<f32>()?);
        b.add_f32(&format!("{prefix}.adam_m.{name}"), &dims, &a.opt.state.m[i]);
        b.add_f32(&format!("{prefix}.adam_v.{name}"), &dims, &a.opt.state.v[i]);
    }
    if let Some(learner) = &a.estimator {
        for (i, (name, var)) in a.ac.named_estimator_vars().iter().enumerate() {
            let dims = var.dims().to_vec();
            b.add_f32(&format!("{prefix}.{name}"), &dims, &var.as_tensor().flatten_all()?.to_vec1::<f32>()?);
            b.add_f32(&format!("{prefix}.adam_m.{name}"), &dims, &learner.opt.state.m[i]);
            b.add_f32(&format!("{prefix}.adam_v.{name}"), &dims, &learner.opt.state.v[i]);
        }
    }
    let d = a.normalizer.dim();
    b.add_f64(&format!("{prefix}.normalizer.mean"), &[d], &a.normalizer.mean);
    b.add_f64(&format!("{prefix}.normalizer.m2"), &[d], &a.normalizer.m2);
    Ok(AgentMeta {
        learning_rate: a.lr,
        adam_step: a.opt.state.step,
        normalizer_count: a.normalizer.count,
        estimator_adam_step: a.estimator.as_ref().map(|e| e.opt.state.step),
    })
}

/// The estimator's weights and Adam state, when the agent has one (a checkpoint of a run without one has none:
/// one clear error).
fn load_estimator(l: &Loaded, prefix: &str, a: &mut Agent, meta: &AgentMeta) -> Result<()> {
    let Some(learner) = &mut a.estimator else { return Ok(()) };
    let Some(step) = meta.estimator_adam_step else {
        bad_file!(
            "this run's observation has an estimated value and the checkpoint has no estimator: it was written with \
             another `[env.observation]`"
        );
    };
    let (mut m, mut v) = (Vec::new(), Vec::new());
    for (name, var) in a.ac.named_estimator_vars() {
        let dims = var.dims().to_vec();
        let read = |what: &str| l.f32(&format!("{prefix}.{what}{name}"), &dims);
        var.set(&Tensor::from_vec(read("")?, dims.as_slice(), &Device::Cpu)?)?;
        m.push(read("adam_m.")?);
        v.push(read("adam_v.")?);
    }
    learner.opt.set_state(AdamState { step, m, v })
}

fn load_agent(l: &Loaded, prefix: &str, a: &mut Agent, meta: &AgentMeta) -> Result<()> {
    load_agent_widened(l, prefix, a, meta, 0, &[])
}

/// Loads an agent whose networks had `extra` fewer inputs (0: the same), appended after the file's: their first
/// layers' weight columns start at zero, so the agent acts exactly as the file's did until it learns to use them.
/// Their Adam moments start at zero mean and at the second moment of the other columns of the same row (from zero
/// Adam's first steps would be ~3× the learning rate: the step count is long past its bias correction). Their
/// normaliser statistics come from `first_obs` (the task's first observations, rows × inputs) with the file's
/// weight, so that neither the file's inputs nor the new ones see their scaling drift under the policy.
fn load_agent_widened(
    l: &Loaded,
    prefix: &str,
    a: &mut Agent,
    meta: &AgentMeta,
    extra: usize,
    first_obs: &[f32],
) -> Result<()> {
    if extra > 0 && !a.ac.view.is_whole() {
        invalid!("inputs can be added to a policy whose actor reads the whole observation only");
    }
    load_estimator(l, prefix, a, meta)?;
    let named = a.ac.named_vars();
    let (mut m, mut v) = (Vec::new(), Vec::new());
    for (name, var) in &named {
        let dims = var.dims().to_vec();
        let first_layer = extra > 0 && (name == "actor.0.weight" || name == "critic.0.weight");
        let file_dims = if first_layer { vec![dims[0], dims[1] - extra] } else { dims.clone() };
        let cols = file_dims[file_dims.len() - 1];
        // Each row of the file's matrix with `extra` values appended: zeros, or (Adam's v) the row's mean.
        let widen = |x: Vec<f32>, row_mean: bool| -> Vec<f32> {
            if !first_layer {
                return x;
            }
            let fill = |r: &[f32]| if row_mean { r.iter().sum::<f32>() / cols as f32 } else { 0.0 };
            x.chunks_exact(cols).flat_map(|r| r.iter().copied().chain(std::iter::repeat_n(fill(r), extra))).collect()
        };
        let read = |what: &str| l.f32(&format!("{prefix}.{what}{name}"), &file_dims);
        var.set(&Tensor::from_vec(widen(read("")?, false), dims.as_slice(), &Device::Cpu)?)?;
        m.push(widen(read("adam_m.")?, false));
        v.push(widen(read("adam_v.")?, true));
    }
    a.opt.set_state(AdamState { step: meta.adam_step, m, v })?;
    let d = a.normalizer.dim() - extra;
    let (mut mean, mut m2) =
        (l.f64(&format!("{prefix}.normalizer.mean"), &[d])?, l.f64(&format!("{prefix}.normalizer.m2"), &[d])?);
    let count = meta.normalizer_count;
    if extra > 0 {
        let first = a.normalizer.batch_moments(first_obs);
        if first.count < 1.0 {
            invalid!("no observations to take the {extra} new inputs' statistics from");
        }
        for i in d..d + extra {
            mean.push(first.mean[i]);
            // A floor: an input constant over the first batch (e.g. flat ground) must not scale by 1/ε later.
            m2.push((first.m2[i] / first.count).max(1e-6) * count.max(1.0));
        }
    }
    a.normalizer.set_stats(mean, m2, count)?;
    a.lr = meta.learning_rate;
    Ok(())
}

/// Saves a checkpoint of `t` into `dir` (`ckpt_<iteration>.{safetensors,json}`), updates `latest.json`, and
/// keeps only the newest `keep` checkpoints (0 = all). Returns the sidecar's path.
pub fn save(t: &Trainer, dir: &Path, command: &str, keep: usize) -> Result<PathBuf> {
    let mut b = Bundle::default();
    let policy = save_agent(&mut b, "policy", &t.policy)?;
    let adversary = match &t.adversary {
        Some(a) => Some(save_agent(&mut b, "adversary", &a.agent)?),
        None => None,
    };
    let snap = t.env.save_state();
    let (n, od) = (t.env.num_envs(), t.env.obs_dim());
    let (fw, uw) = (snap.f64_width, snap.u64_width);
    let mut rng = Vec::new();
    crate::rng::save_rng(&t.rng, &mut rng);
    let stem = format!("ckpt_{:07}", t.iteration);
    let side_path = dir.join(format!("{stem}.json"));
    let (mut f64s, mut u64s, mut obs, mut rank_rngs) = (snap.f64s, snap.u64s, snap.obs, Vec::new());
    // Every rank's envs and stream go to rank 0, which alone writes (the weights are the same on all ranks).
    let ranks = t.comm.size();
    if ranks > 1 {
        let mut mine = Bundle::default();
        mine.add_f64("env.f64", &[n, fw], &f64s);
        mine.add_u64("env.u64", &[n, uw], &u64s);
        mine.add_f32("env.obs", &[n, od], &obs);
        mine.add_u64("rng", &[rng.len()], &rng);
        let all = t.comm.gather_bytes(&mine.to_bytes(None)?);
        if t.comm.rank() != 0 {
            return Ok(side_path);
        }
        for (r, bytes) in all.into_iter().enumerate().skip(1) {
            let l = Loaded::from_bytes(Path::new(&format!("rank {r}'s checkpoint state")), bytes)?;
            f64s.extend(l.f64("env.f64", &[n, fw])?);
            u64s.extend(l.u64("env.u64", &[n, uw])?);
            obs.extend(l.f32("env.obs", &[n, od])?);
            rank_rngs.push(l.u64("rng", &[rng.len()])?);
        }
    }
    let rows = ranks * n;
    b.add_f64("env.f64", &[rows, fw], &f64s);
    b.add_u64("env.u64", &[rows, uw], &u64s);
    b.add_f32("env.obs", &[rows, od], &obs);
    let bytes = b.to_bytes(None)?;
    let weights = format!("{stem}.safetensors");
    write_atomic(&dir.join(&weights), &bytes)?;
    let side = Sidecar {
        format: FORMAT.into(),
        version: VERSION,
        iteration: t.iteration,
        samples: t.samples,
        wall_time_s: t.wall_time_s,
        with_adversary: t.adversary.is_some(),
        rng,
        policy,
        adversary,
        num_envs: n,
        obs_dim: od,
        action_dim: t.env.action_dim(),
        env_f64_width: fw,
        env_u64_width: uw,
        weights_crc32: checksum(&bytes),
        weights,
        config: t.cfg.clone(),
        command: command.to_string(),
        ranks,
        rank_rngs,
        segments: t.segments.clone(),
    };
    write_atomic(&side_path, serde_json::to_string_pretty(&side)?.as_bytes())?;
    let latest = Latest { sidecar: format!("{stem}.json"), iteration: t.iteration };
    write_atomic(&dir.join("latest.json"), serde_json::to_string_pretty(&latest)?.as_bytes())?;
    if keep > 0 {
        prune(dir, keep)?;
    }
    Ok(side_path)
}

/// Removes all but the newest `keep` checkpoint pairs.
fn prune(dir: &Path, keep: usize) -> Result<()> {
    let mut stems: Vec<String> = std::fs::read_dir(dir)
        .map_err(Error::io("cannot list", dir))?
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter_map(|n| n.strip_suffix(".json").filter(|s| s.starts_with("ckpt_")).map(str::to_string))
        .collect();
    stems.sort();
    let drop = stems.len().saturating_sub(keep);
    for s in &stems[..drop] {
        for ext in ["json", "safetensors"] {
            let _ = std::fs::remove_file(dir.join(format!("{s}.{ext}")));
        }
    }
    Ok(())
}

/// The sidecar path `latest.json` in `dir` points at.
pub fn latest(dir: &Path) -> Result<PathBuf> {
    let p = dir.join("latest.json");
    let text = std::fs::read_to_string(&p).map_err(|e| {
        let m = format!(
            "no checkpoint in {}: {} is missing (was the run started with --out here?)",
            dir.display(),
            p.display()
        );
        Error::file(m, e)
    })?;
    let l: Latest = serde_json::from_str(&text).map_err(|e| Error::file(format!("{} is corrupt", p.display()), e))?;
    Ok(dir.join(l.sidecar))
}

/// Reads and validates a sidecar (format, version, weights checksum).
pub fn read_sidecar(path: &Path) -> Result<(Sidecar, Loaded)> {
    let kind = SidecarKind { kind: "checkpoint", format: FORMAT, version: VERSION, hint: "" };
    crate::tensorfile::read_sidecar(path, &kind)
}

/// Restores `t` (built from the sidecar's config) to the checkpoint's exact state.
pub fn restore(t: &mut Trainer, side: &Sidecar, l: &Loaded) -> Result<()> {
    let (ranks, rank) = (t.comm.size(), t.comm.rank());
    if side.ranks != ranks || side.rank_rngs.len() + 1 != side.ranks {
        bad_file!(
            "this checkpoint was written by {} MPI rank(s) and this run has {ranks}: resume it with `mpirun -np {} \
             topa train --resume …` (each rank continues its own envs), or start a new run from its policy with \
             `--init-from` (weights, optimiser and normaliser; fresh envs)",
            side.ranks,
            side.ranks
        );
    }
    let n = t.env.num_envs();
    if side.num_envs != n || side.obs_dim != t.env.obs_dim() || side.action_dim != t.env.action_dim() {
        bad_file!(
            "checkpoint is for {} envs × {} observations × {} actions, this run has {n} × {} × {}",
            side.num_envs,
            side.obs_dim,
            side.action_dim,
            t.env.obs_dim(),
            t.env.action_dim()
        );
    }
    if side.with_adversary != t.adversary.is_some() {
        bad_file!(
            "checkpoint {} an adversary; resume it {} --adversary",
            if side.with_adversary { "has" } else { "has no" },
            if side.with_adversary { "with" } else { "without" }
        );
    }
    load_agent(l, "policy", &mut t.policy, &side.policy)?;
    if let (Some(a), Some(meta)) = (&mut t.adversary, &side.adversary) {
        load_agent(l, "adversary", &mut a.agent, meta)?;
    }
    let rows = ranks * n;
    let (fw, uw, od) = (side.env_f64_width, side.env_u64_width, side.obs_dim);
    let mine = |v: Vec<f64>, w: usize| v[rank * n * w..(rank + 1) * n * w].to_vec();
    let snap = EnvSnapshot {
        f64_width: fw,
        f64s: mine(l.f64("env.f64", &[rows, fw])?, fw),
        u64_width: uw,
        u64s: l.u64("env.u64", &[rows, uw])?[rank * n * uw..(rank + 1) * n * uw].to_vec(),
        obs: l.f32("env.obs", &[rows, od])?[rank * n * od..(rank + 1) * n * od].to_vec(),
    };
    t.env.load_state(&snap).map_err(Error::env("restoring the environments' state"))?;
    let rng = if rank == 0 { &side.rng } else { &side.rank_rngs[rank - 1] };
    if rng.len() != crate::rng::RNG_WORDS {
        bad_file!("checkpoint RNG state has {} words, expected {}", rng.len(), crate::rng::RNG_WORDS);
    }
    t.rng = crate::rng::load_rng(rng);
    t.iteration = side.iteration;
    t.samples = side.samples;
    t.wall_time_s = side.wall_time_s;
    t.segments = side.segments.clone();
    Ok(())
}

/// Starts `t` from another run's policy (e.g. C+A from a C run's checkpoint): the policy's weights, Adam state,
/// learning rate and normaliser, and the iteration count up to the end of phase 1 (so a finished C run goes
/// straight to the adversary's first phase). The environments and the RNG stay fresh.
///
/// `extra_inputs`: how many observation values this task has after the checkpoint's (the caller vouches that the
/// first ones mean the same, e.g. a height scan added to a blind policy); 0 demands equal sizes.
pub fn init_policy_from(t: &mut Trainer, side: &Sidecar, l: &Loaded, extra_inputs: usize) -> Result<()> {
    if side.obs_dim + extra_inputs != t.env.obs_dim() || side.action_dim != t.env.action_dim() {
        bad_file!(
            "the checkpoint's policy has {}→{} inputs/outputs, this task needs {}→{}{}",
            side.obs_dim,
            side.action_dim,
            t.env.obs_dim(),
            t.env.action_dim(),
            if extra_inputs > 0 { format!(" ({extra_inputs} inputs added)") } else { String::new() }
        );
    }
    if side.config.network != t.cfg.network {
        bad_file!(
            "the checkpoint's network ({:?}) differs from this config's ({:?})",
            side.config.network,
            t.cfg.network
        );
    }
    load_agent_widened(l, "policy", &mut t.policy, &side.policy, extra_inputs, t.env.obs())?;
    let phase1 = if t.adversary.is_some() { t.cfg.adversary.phase1_policy_iters } else { t.cfg.run.iterations };
    t.iteration = side.iteration.min(phase1);
    t.samples = side.samples;
    t.wall_time_s = side.wall_time_s;
    t.segments = side.segments.clone();
    Ok(())
}

/// The checkpoint's policy as a deployable policy (its actor and normaliser), described by `meta` (the caller knows
/// the task: robot, sizes, control settings). For studying a run's progress from its kept checkpoints.
pub fn policy(side: &Sidecar, l: &Loaded, meta: crate::policy_file::PolicyMeta) -> Result<crate::policy_file::Policy> {
    let (view, actor, estimator) = crate::policy_file::read_networks(l, "policy.", &meta)?;
    let mut normalizer = crate::normalizer::Normalizer::new(side.obs_dim, None);
    let d = side.obs_dim;
    normalizer.set_stats(
        l.f64("policy.normalizer.mean", &[d])?,
        l.f64("policy.normalizer.m2", &[d])?,
        side.policy.normalizer_count,
    )?;
    normalizer.frozen = true;
    Ok(crate::policy_file::Policy::from_parts(meta, view, actor, estimator, normalizer))
}
