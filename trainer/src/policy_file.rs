//! The deployable policy: the actor's weights and the frozen observation normaliser (safetensors) plus a JSON
//! sidecar saying what it is (the robot spec it was trained on, sizes, control settings) and how it was made (command,
//! config, seed, iterations, samples, wall time). Loading validates everything before use: files are data.

use std::path::{Path, PathBuf};

use crate::error::{bad_file, Error, Result};
use candle_core::{Device, Tensor};
use serde::{Deserialize, Serialize};

use crate::actor_critic::{actor_forward, named_mlp, ActorBuffers};
use crate::actor_view::ActorView;
use crate::nn::{layer_dims, Activation, Linear, Mlp};
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
    /// The iterations whose weights this policy averages (`topa average`); empty: the policy of `iterations`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub averaged_iterations: Vec<usize>,
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
    /// What the actor reads of the observation row (none: all of it, as the paper's policies).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub actor_view: Option<ActorView>,
    /// The concurrent estimator's hidden layers (with an actor view that estimates values).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimator_hidden: Option<Vec<usize>>,
    pub weights: String,
    pub weights_crc32: u32,
    pub provenance: Provenance,
}

/// Buffers of the forward pass (reused every call).
#[derive(Default)]
struct InferenceBuffers {
    norm: Vec<f32>,
    actor: ActorBuffers,
}

/// A loaded policy: deterministic actions (the Gaussian's mean) from raw observations.
pub struct Policy {
    pub meta: PolicyMeta,
    view: ActorView,
    actor: Mlp,
    estimator: Option<Mlp>,
    normalizer: Normalizer,
    buffers: InferenceBuffers,
}

impl Clone for Policy {
    fn clone(&self) -> Self {
        Policy {
            meta: self.meta.clone(),
            view: self.view.clone(),
            actor: self.actor.clone(),
            estimator: self.estimator.clone(),
            normalizer: self.normalizer.clone(),
            buffers: InferenceBuffers::default(),
        }
    }
}

/// Writes `<stem>.safetensors` and `<stem>.json` (e.g. `assets/policies/C.safetensors`); the estimator with a
/// view that estimates values.
pub fn save(
    stem: &Path,
    actor: &Mlp,
    estimator: Option<&Mlp>,
    normalizer: &Normalizer,
    meta_in: PolicyMeta,
) -> Result<PathBuf> {
    let mut b = Bundle::default();
    let named =
        named_mlp("actor", actor).into_iter().chain(estimator.map_or(Vec::new(), |e| named_mlp("estimator", e)));
    for (name, var) in named {
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

/// The network `net` ("actor", "estimator") stored under `prefix` (`{prefix}{net}.{i}.weight` / `.bias`) with
/// layer sizes `dims` (inputs, hidden…, outputs); a layer beyond them is an error.
pub(crate) fn read_mlp(l: &Loaded, prefix: &str, net: &str, dims: &[usize]) -> Result<Mlp> {
    let layers = (0..dims.len() - 1)
        .map(|i| -> Result<Linear> {
            let w = l.f32(&format!("{prefix}{net}.{i}.weight"), &[dims[i + 1], dims[i]])?;
            let b = l.f32(&format!("{prefix}{net}.{i}.bias"), &[dims[i + 1]])?;
            Ok(Linear {
                weight: candle_core::Var::from_tensor(&Tensor::from_vec(w, (dims[i + 1], dims[i]), &Device::Cpu)?)?,
                bias: candle_core::Var::from_tensor(&Tensor::from_vec(b, dims[i + 1], &Device::Cpu)?)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    if l.shape(&format!("{prefix}{net}.{}.weight", dims.len() - 1)).is_some() {
        bad_file!("more {net} layers than the sidecar says");
    }
    Ok(Mlp { layers, hidden_activation: Activation::Elu })
}

/// The actor and (with an estimating view) the estimator of a policy described by `meta`, stored under `prefix`.
pub(crate) fn read_networks(l: &Loaded, prefix: &str, meta: &PolicyMeta) -> Result<(ActorView, Mlp, Option<Mlp>)> {
    let view = meta.actor_view.clone().unwrap_or_else(|| ActorView::whole(meta.obs_dim));
    if view.obs_dim != meta.obs_dim {
        bad_file!(
            "the actor view is of {} observation values, the policy's observation has {}",
            view.obs_dim,
            meta.obs_dim
        );
    }
    view.validate().map_err(|e| Error::bad_file(format!("actor_view: {e}")))?;
    let actor = read_mlp(l, prefix, "actor", &layer_dims(view.dim(), &meta.hidden, meta.action_dim))?;
    let estimator = match (view.estimate_dim(), &meta.estimator_hidden) {
        (0, _) => None,
        (e, Some(hidden)) => Some(read_mlp(l, prefix, "estimator", &layer_dims(view.inputs, hidden, e))?),
        (_, None) => bad_file!("the actor view estimates values and the sidecar gives no estimator_hidden"),
    };
    Ok((view, actor, estimator))
}

/// The sidecar of a policy named by either of its files.
pub fn sidecar_path(path: &Path) -> PathBuf {
    if path.extension().is_some_and(|e| e == "safetensors") {
        path.with_extension("json")
    } else {
        path.to_path_buf()
    }
}

/// The weights file of the policy whose sidecar is `json` and says `meta`.
pub fn weights_path(json: &Path, meta: &PolicyMeta) -> PathBuf {
    json.parent().unwrap_or(Path::new(".")).join(&meta.weights)
}

impl Policy {
    /// Loads `path` (the `.json` sidecar, or the `.safetensors` next to it), validating format, version,
    /// checksum, names, shapes and values.
    pub fn load(path: &Path) -> Result<Policy> {
        let json = sidecar_path(path);
        let kind = SidecarKind {
            kind: "policy",
            format: FORMAT,
            version: VERSION,
            hint: " (pass the .json sidecar or its .safetensors)",
        };
        let (meta, l): (PolicyMeta, Loaded) = read_sidecar(&json, &kind)?;
        let weights = weights_path(&json, &meta);
        let (view, actor, estimator) =
            read_networks(&l, "", &meta).map_err(|e| Error::file(weights.display().to_string(), e))?;
        let mut normalizer = Normalizer::new(meta.obs_dim, None);
        let count = l.f64("normalizer.count", &[1])?[0];
        normalizer
            .set_stats(l.f64("normalizer.mean", &[meta.obs_dim])?, l.f64("normalizer.m2", &[meta.obs_dim])?, count)
            .map_err(|e| Error::file(weights.display().to_string(), e))?;
        normalizer.frozen = true;
        Ok(Policy { meta, view, actor, estimator, normalizer, buffers: InferenceBuffers::default() })
    }

    pub fn obs_dim(&self) -> usize {
        self.meta.obs_dim
    }

    pub fn action_dim(&self) -> usize {
        self.meta.action_dim
    }

    /// Mean actions for `obs` (rows × obs_dim) into `actions` (rows × action_dim).
    /// With an actor view, the values after the actor's inputs (privileged, e.g. the true base velocity) are not
    /// read: any value there gives the same actions.
    pub fn act(&mut self, obs: &[f32], actions: &mut Vec<f32>) {
        let rows = obs.len() / self.meta.obs_dim;
        let b = &mut self.buffers;
        b.norm.resize(obs.len(), 0.0);
        self.normalizer.normalize(obs, &mut b.norm);
        actor_forward(&self.view, &self.actor, self.estimator.as_ref(), &b.norm, rows, actions, &mut b.actor);
    }

    /// The estimator's output for the last `act` (rows × its size, in the estimated values' units), if any.
    pub fn estimate(&self) -> Option<Vec<f64>> {
        let c = self.view.estimate.clone()?;
        let (mean, std) = (&self.normalizer.mean, self.normalizer_std());
        let e = c.len();
        Some(
            self.buffers
                .actor
                .estimate
                .iter()
                .enumerate()
                .map(|(i, x)| *x as f64 * std[c.start + i % e] + mean[c.start + i % e])
                .collect(),
        )
    }

    /// A policy from its parts (e.g. a weight average); `meta` must describe them.
    pub fn from_parts(
        meta: PolicyMeta,
        view: ActorView,
        actor: Mlp,
        estimator: Option<Mlp>,
        normalizer: Normalizer,
    ) -> Self {
        Policy { meta, view, actor, estimator, normalizer, buffers: InferenceBuffers::default() }
    }

    /// Writes the policy as `<stem>.safetensors` and `<stem>.json`.
    pub fn save(&self, stem: &Path) -> Result<PathBuf> {
        save(stem, &self.actor, self.estimator.as_ref(), &self.normalizer, self.meta.clone())
    }

    /// The frozen observation normaliser.
    pub fn normalizer(&self) -> &Normalizer {
        &self.normalizer
    }

    /// What the actor reads of the observation row.
    pub fn view(&self) -> &ActorView {
        &self.view
    }

    /// The concurrent estimator, if the policy has one.
    pub fn estimator(&self) -> Option<&Mlp> {
        self.estimator.as_ref()
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
