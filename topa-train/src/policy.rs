//! Policy files of a run: the latest policy exported beside the checkpoints, or a kept checkpoint's, with the
//! task's robot, sizes and control settings in the sidecar and the full resolved config in its provenance.

use std::path::{Path, PathBuf};

use crate::error::Result;
use topa_env::observation::ObsLayout;
use topa_env::TaskKind;
use trainer::checkpoint;
use trainer::policy_file::{self, PolicyMeta, Provenance};
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
        },
    )?;
    let ac = &t.policy.ac;
    Ok(policy_file::save(&out.join("policy"), &ac.actor, ac.estimator.as_ref(), &t.policy.normalizer, meta)?)
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
    Ok(checkpoint::save_policy(&side, &loaded, stem, meta)?)
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
