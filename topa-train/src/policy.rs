//! Policy files of a run: the latest policy exported beside the checkpoints, or a kept checkpoint's, with the
//! task's robot, sizes and control settings in the sidecar and the full resolved config in its provenance.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use topa_env::observation::ObsLayout;
use topa_env::TaskKind;
use trainer::checkpoint;
use trainer::policy_file::{self, Policy, PolicyMeta, Provenance};
use trainer::Trainer;

use crate::config::{env_config, with_env};

/// A policy file's sidecar for a run of `provenance.config` at the point `provenance` records.
fn policy_meta(obs_dim: usize, action_dim: usize, provenance: Provenance) -> Result<PolicyMeta> {
    let env = env_config(&provenance.config)?;
    let cfg = with_env(&provenance.config, &env);
    // The view of a robot's row: its layout has one motor per action.
    let view = (env.task == TaskKind::Robot)
        .then(|| {
            let layout = env.observation.layout(ObsLayout::new(action_dim).with_scan(env.height_scan.grid()));
            env.observation.actor_view(&layout)
        })
        .filter(|v| !v.is_whole());
    if let Some(v) = view.as_ref().filter(|v| v.obs_dim != obs_dim) {
        return Err(trainer::Error::Invalid(format!(
            "the observation has {obs_dim} values and its config describes {}",
            v.obs_dim
        ))
        .into());
    }
    let estimator_hidden = view.as_ref().filter(|v| v.estimate.is_some()).map(|_| cfg.network.estimator_hidden.clone());
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
        actor_view: view,
        estimator_hidden,
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
            trained_on: format!("{}, {}", today(), trainer::segments::this_machine()),
            segments: t.segments.clone(),
            averaged_iterations: Vec::new(),
        },
    )?;
    let ac = &t.policy.ac;
    Ok(policy_file::save(&out.join("policy"), &ac.actor, ac.estimator.as_ref(), &t.policy.normalizer, meta)?)
}

/// The policy of a kept checkpoint (its sidecar); the provenance is the checkpoint's (its iteration, samples and
/// wall time so far).
pub fn checkpoint_policy(sidecar: &Path) -> Result<Policy> {
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
            averaged_iterations: Vec::new(),
        },
    )?;
    Ok(checkpoint::policy(&side, &loaded, meta)?)
}

/// Exports the policy of a kept checkpoint (its sidecar) as `<stem>.{safetensors,json}`, e.g. to evaluate a run
/// part-way.
pub fn export_checkpoint(sidecar: &Path, stem: &Path) -> Result<PathBuf> {
    Ok(checkpoint_policy(sidecar)?.save(stem)?)
}

/// The run's kept checkpoint sidecars whose iteration is a multiple of `every`, and its last one, in iteration
/// order.
pub fn kept_checkpoints(run: &Path, every: usize) -> Result<Vec<(usize, PathBuf)>> {
    if every == 0 {
        return Err(Error::Invalid(
            "--every must be at least 1 (an iteration step between the checkpoints taken)".into(),
        ));
    }
    let dir = run.join("checkpoints");
    let entries = std::fs::read_dir(&dir).map_err(|source| Error::Io {
        action: "no checkpoints folder (pass a `topa train --out` folder):",
        path: dir.clone(),
        source,
    })?;
    let mut all: Vec<(usize, PathBuf)> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter_map(|p| {
            let name = p.file_name()?.to_str()?;
            let it = name.strip_prefix("ckpt_")?.strip_suffix(".json")?.parse().ok()?;
            Some((it, p))
        })
        .collect();
    all.sort();
    let Some(last) = all.last().cloned() else {
        return Err(Error::Run(format!("{} holds no checkpoint (ckpt_<iteration>.json)", dir.display())));
    };
    let mut picked: Vec<(usize, PathBuf)> = all.into_iter().filter(|(it, _)| it % every == 0).collect();
    if picked.last().is_none_or(|p| p.0 != last.0) {
        picked.push(last);
    }
    Ok(picked)
}

/// The weight average (`trainer::weight_average`) of the run's kept checkpoints from iteration `from` on (those at
/// multiples of `every`, and the last), written as `<stem>.{safetensors,json}`; returns the file and the
/// iterations averaged.
pub fn average_run(run: &Path, from: usize, every: usize, stem: &Path) -> Result<(PathBuf, Vec<usize>)> {
    let picked: Vec<(usize, PathBuf)> = kept_checkpoints(run, every)?.into_iter().filter(|c| c.0 >= from).collect();
    if picked.len() < 2 {
        return Err(Error::Run(format!(
            "{} keeps {} checkpoint(s) from iteration {from} at multiples of {every}: averaging needs two or more \
             (train with `[run] keep_checkpoints = 0` to keep them all, or pass a smaller --from or --every)",
            run.display(),
            picked.len()
        )));
    }
    let policies = picked.iter().map(|(_, p)| checkpoint_policy(p)).collect::<Result<Vec<_>>>()?;
    let names: Vec<String> = picked.iter().map(|(_, p)| p.display().to_string()).collect();
    let mut mean = trainer::weight_average::average(&policies, &names)?;
    let iterations: Vec<usize> = picked.iter().map(|c| c.0).collect();
    mean.meta.provenance.averaged_iterations = iterations.clone();
    Ok((mean.save(stem)?, iterations))
}

/// Today's date (UTC) as YYYY-MM-DD, for provenance records.
pub fn today() -> String {
    let days =
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs() / 86400) as i64;
    // Howard Hinnant's civil-from-days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + if m <= 2 { 1 } else { 0 };
    format!("{y:04}-{m:02}-{d:02}")
}
