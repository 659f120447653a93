//! The deployable policy: the actor's weights and the frozen observation normaliser (safetensors) plus a JSON
//! sidecar saying what it is (the robot spec it was trained on, sizes, control settings) and how it was made (command,
//! config, seed, iterations, samples, wall time). Loading validates everything before use: files are data.

use std::path::{Path, PathBuf};

use crate::error::{bad_file, Error, Result};
use candle_core::{Device, Tensor};
use serde::{Deserialize, Serialize};

use crate::actor_critic::named_mlp;
use crate::nn::{Activation, Linear, Mlp, MlpScratch};
use crate::normalizer::{Normalizer, STD_EPS};
use crate::tensorfile::{checksum, read_sidecar, write_atomic, Bundle, Loaded, SidecarKind};

pub const FORMAT: &str = "topa-policy";
pub const VERSION: u32 = 1;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Provenance {
    pub command: String,
    pub config: crate::config::TrainConfig,
    pub seed: u64,
    pub iterations: usize,
    pub samples: u64,
    pub wall_time_s: f64,
    pub with_adversary: bool,
    /// When and where it was trained (free text, e.g. "2026-11-23, 2-core AMD EPYC").
    pub trained_on: String,
    /// `wall_time_s` by machine and thread count, a forked run's source run first (empty in older files).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub segments: Vec<crate::segments::Segment>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolicyMeta {
    pub format: String,
    pub version: u32,
    /// The robot spec the policy was trained on, as the task names it (for TopA a spec file relative to the
    /// repository, e.g. `assets/robots/topa_closed.toml`); none for tasks without a robot.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robot: Option<String>,
    pub obs_dim: usize,
    pub action_dim: usize,
    pub hidden: Vec<usize>,
    pub activation: crate::config::HiddenActivation,
    /// Motor target = nominal + action_scale · action.
    pub action_scale: f64,
    pub action_clip: f64,
    /// Control period the policy was trained at, s.
    pub policy_dt: f64,
    pub weights: String,
    pub weights_crc32: u32,
    pub provenance: Provenance,
}

/// A loaded policy: deterministic actions (the Gaussian's mean) from raw observations.
pub struct Policy {
    pub meta: PolicyMeta,
    actor: Mlp,
    normalizer: Normalizer,
    scratch: MlpScratch,
    norm_buf: Vec<f32>,
}

impl Clone for Policy {
    fn clone(&self) -> Self {
        Policy {
            meta: self.meta.clone(),
            actor: self.actor.clone(),
            normalizer: self.normalizer.clone(),
            scratch: MlpScratch::default(),
            norm_buf: Vec::new(),
        }
    }
}

/// Writes `<stem>.safetensors` and `<stem>.json` (e.g. `assets/policies/C.safetensors`).
pub fn save(stem: &Path, actor: &Mlp, normalizer: &Normalizer, meta_in: PolicyMeta) -> Result<PathBuf> {
    let mut b = Bundle::default();
    for (name, var) in named_mlp("actor", actor) {
        b.add_f32(&name, var.dims(), &var.as_tensor().flatten_all()?.to_vec1::<f32>()?);
    }
    let d = normalizer.dim();
    b.add_f64("normalizer.mean", &[d], &normalizer.mean);
    b.add_f64("normalizer.m2", &[d], &normalizer.m2);
    b.add_f64("normalizer.count", &[1], &[normalizer.count]);
    let bytes = b.to_bytes(None)?;
    let weights = stem.with_extension("safetensors");
    write_atomic(&weights, &bytes)?;
    let mut meta = meta_in;
    meta.weights = weights.file_name().unwrap().to_string_lossy().into_owned();
    meta.weights_crc32 = checksum(&bytes);
    let json = stem.with_extension("json");
    write_atomic(&json, serde_json::to_string_pretty(&meta)?.as_bytes())?;
    Ok(json)
}

/// The actor stored under `prefix` (`{prefix}actor.{i}.weight` / `.bias`) with layer sizes `dims` (inputs,
/// hidden…, outputs); a layer beyond them is an error.
pub(crate) fn read_actor(l: &Loaded, prefix: &str, dims: &[usize]) -> Result<Mlp> {
    let layers = (0..dims.len() - 1)
        .map(|i| -> Result<Linear> {
            let w = l.f32(&format!("{prefix}actor.{i}.weight"), &[dims[i + 1], dims[i]])?;
            let b = l.f32(&format!("{prefix}actor.{i}.bias"), &[dims[i + 1]])?;
            Ok(Linear {
                weight: candle_core::Var::from_tensor(&Tensor::from_vec(w, (dims[i + 1], dims[i]), &Device::Cpu)?)?,
                bias: candle_core::Var::from_tensor(&Tensor::from_vec(b, dims[i + 1], &Device::Cpu)?)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    if l.shape(&format!("{prefix}actor.{}.weight", dims.len() - 1)).is_some() {
        bad_file!("more actor layers than the sidecar says");
    }
    Ok(Mlp { layers, hidden_activation: Activation::Elu })
}

impl Policy {
    /// Loads `path` (the `.json` sidecar, or the `.safetensors` next to it), validating format, version,
    /// checksum, names, shapes and values.
    pub fn load(path: &Path) -> Result<Policy> {
        let json = if path.extension().is_some_and(|e| e == "safetensors") {
            path.with_extension("json")
        } else {
            path.to_path_buf()
        };
        let kind = SidecarKind {
            kind: "policy",
            format: FORMAT,
            version: VERSION,
            hint: " (pass the .json sidecar or its .safetensors)",
        };
        let (meta, l): (PolicyMeta, Loaded) = read_sidecar(&json, &kind)?;
        let weights = json.parent().unwrap_or(Path::new(".")).join(&meta.weights);
        let dims: Vec<usize> = std::iter::once(meta.obs_dim)
            .chain(meta.hidden.iter().copied())
            .chain(std::iter::once(meta.action_dim))
            .collect();
        let actor = read_actor(&l, "", &dims).map_err(|e| Error::file(weights.display().to_string(), e))?;
        let mut normalizer = Normalizer::new(meta.obs_dim, None);
        let count = l.f64("normalizer.count", &[1])?[0];
        normalizer
            .set_stats(l.f64("normalizer.mean", &[meta.obs_dim])?, l.f64("normalizer.m2", &[meta.obs_dim])?, count)
            .map_err(|e| Error::file(weights.display().to_string(), e))?;
        normalizer.frozen = true;
        Ok(Policy { meta, actor, normalizer, scratch: MlpScratch::default(), norm_buf: Vec::new() })
    }

    pub fn obs_dim(&self) -> usize {
        self.meta.obs_dim
    }

    pub fn action_dim(&self) -> usize {
        self.meta.action_dim
    }

    /// Mean actions for `obs` (rows × obs_dim) into `actions` (rows × action_dim).
    pub fn act(&mut self, obs: &[f32], actions: &mut Vec<f32>) {
        let rows = obs.len() / self.meta.obs_dim;
        self.norm_buf.resize(obs.len(), 0.0);
        self.normalizer.normalize(obs, &mut self.norm_buf);
        self.actor.forward_inference(&self.norm_buf, rows, actions, &mut self.scratch);
    }

    /// The actor network.
    pub fn actor(&self) -> &Mlp {
        &self.actor
    }

    /// The normaliser as an affine map: normalised = (obs − mean) ⊙ scale, scale = 1 / (std + ε).
    pub fn normalizer_affine(&self) -> (Vec<f64>, Vec<f64>) {
        let scale = self.normalizer_std().iter().map(|s| 1.0 / s).collect();
        (self.normalizer.mean.clone(), scale)
    }

    /// The normaliser's standard deviation plus ε, for inspection.
    pub fn normalizer_std(&self) -> Vec<f64> {
        self.normalizer.std().iter().map(|s| s + STD_EPS).collect()
    }
}
