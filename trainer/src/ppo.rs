//! PPO (rsl_rl-style) for one agent: acting during rollouts, and the update — clipped surrogate, clipped value
//! loss, entropy bonus, the paper's symmetry and last-layer decay losses, adaptive learning rate from the
//! closed-form KL, global gradient-norm clipping, AdamW.

use candle_core::{Device, Result, Tensor};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use topa_env::Symmetry;

use crate::actor_critic::{self, ActorCritic, InferenceBuffers};
use crate::config::{LossConfig, PpoConfig};
use crate::normalizer::Normalizer;
use crate::optim::{AdamParams, AdamW};
use crate::storage::Rollout;

/// Mean losses and diagnostics of one update.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct UpdateStats {
    pub surrogate: f64,
    pub value_loss: f64,
    pub entropy: f64,
    pub symmetry_loss: f64,
    pub decay_loss: f64,
    pub kl: f64,
    pub clip_fraction: f64,
    pub grad_norm: f64,
    /// Learning rate after the update.
    pub learning_rate: f64,
    /// Minibatches skipped because the loss or gradient was not finite.
    pub skipped: usize,
    pub minibatches: usize,
}

/// A policy (or adversary) with everything it learns with.
pub struct Agent {
    pub ac: ActorCritic,
    pub normalizer: Normalizer,
    pub opt: AdamW,
    pub lr: f64,
    pub ppo: PpoConfig,
    pub losses: LossConfig,
    /// Mirror maps for the symmetry loss (None: no symmetry term).
    pub symmetry: Option<Symmetry>,
    buffers: InferenceBuffers,
}

/// What the agent did for one batch of observations.
pub struct ActOutput<'a> {
    pub obs_norm: &'a mut [f32],
    pub actions: &'a mut [f32],
    pub means: &'a mut [f32],
    pub log_probs: &'a mut [f32],
    pub values: &'a mut [f32],
}

impl Agent {
    pub fn new(ac: ActorCritic, ppo: PpoConfig, losses: LossConfig, symmetry: Option<Symmetry>) -> Self {
        let normalizer = Normalizer::new(ac.obs_dim, symmetry.as_ref().map(|s| s.obs.clone()));
        let opt = AdamW::new(ac.vars(), AdamParams::default());
        Agent {
            lr: ppo.learning_rate,
            ac,
            normalizer,
            opt,
            ppo,
            losses,
            symmetry,
            buffers: InferenceBuffers::default(),
        }
    }

    /// Normalises `raw_obs` (updating the statistics first unless frozen), then samples actions (or takes the
    /// mean when `explore` is false) and evaluates log-probabilities and values.
    pub fn act(&mut self, raw_obs: &[f32], rng: &mut ChaCha8Rng, explore: bool, out: ActOutput<'_>) -> Result<()> {
        let rows = raw_obs.len() / self.ac.obs_dim;
        self.normalizer.update(raw_obs);
        self.normalizer.normalize(raw_obs, out.obs_norm);
        let b = &mut self.buffers;
        self.ac.actor.forward_inference(out.obs_norm, rows, &mut b.mean, &mut b.actor);
        self.ac.critic.forward_inference(out.obs_norm, rows, &mut b.value, &mut b.critic);
        out.means.copy_from_slice(&b.mean);
        out.values.copy_from_slice(&b.value);
        let log_std = self.ac.log_std.as_tensor().to_vec1::<f32>()?;
        if explore {
            let std: Vec<f32> = log_std.iter().map(|l| l.exp()).collect();
            actor_critic::sample_actions(&b.mean, &std, rng, out.actions);
        } else {
            out.actions.copy_from_slice(&b.mean);
        }
        actor_critic::log_prob(out.actions, &b.mean, &log_std, out.log_probs);
        Ok(())
    }

    /// Values of raw observations (normalised with the current statistics, which are not updated).
    pub fn values(&mut self, raw_obs: &[f32], out: &mut [f32]) {
        let rows = raw_obs.len() / self.ac.obs_dim;
        let mut norm = vec![0.0; raw_obs.len()];
        self.normalizer.normalize(raw_obs, &mut norm);
        self.ac.critic.forward_inference(&norm, rows, &mut self.buffers.value, &mut self.buffers.critic);
        out.copy_from_slice(&self.buffers.value[..rows]);
    }

    /// One PPO update on a full rollout (returns already computed).
    pub fn update(&mut self, r: &Rollout, rng: &mut ChaCha8Rng) -> Result<UpdateStats> {
        let n = r.len();
        let mb = n / self.ppo.minibatches;
        let (od, ad) = (r.obs_dim, r.act_dim);
        let mut stats = UpdateStats::default();
        let mut idx: Vec<usize> = (0..n).collect();
        let mut buf = Minibatch::with_capacity(mb, od, ad);
        for _ in 0..self.ppo.epochs {
            // Fisher–Yates with our stream, so the minibatches are part of the seeded run.
            for i in (1..n).rev() {
                idx.swap(i, rng.random_range(0..=i));
            }
            for k in 0..self.ppo.minibatches {
                buf.gather(r, &idx[k * mb..(k + 1) * mb]);
                self.minibatch_step(&buf, &r.std, &mut stats)?;
            }
        }
        let m = stats.minibatches.max(1) as f64;
        for v in [
            &mut stats.surrogate,
            &mut stats.value_loss,
            &mut stats.entropy,
            &mut stats.symmetry_loss,
            &mut stats.decay_loss,
            &mut stats.kl,
            &mut stats.clip_fraction,
            &mut stats.grad_norm,
        ] {
            *v /= m;
        }
        stats.learning_rate = self.lr;
        Ok(stats)
    }

    fn minibatch_step(&mut self, b: &Minibatch, old_std: &[f32], stats: &mut UpdateStats) -> Result<()> {
        let cpu = Device::Cpu;
        let rows = b.rows;
        let (od, ad) = (self.ac.obs_dim, self.ac.act_dim);
        let obs = Tensor::from_slice(&b.obs, (rows, od), &cpu)?;
        let mean = self.ac.actor.forward(&obs)?;
        let value = self.ac.critic.forward(&obs)?.squeeze(1)?;
        let log_std = self.ac.log_std.as_tensor();

        // Adaptive learning rate from the KL between the rollout policy and the current one (rsl_rl's rule).
        let kl = actor_critic::mean_kl(
            &b.means,
            old_std,
            &mean.flatten_all()?.to_vec1::<f32>()?,
            &log_std.exp()?.to_vec1::<f32>()?,
        );
        if self.ppo.adaptive_lr && kl.is_finite() {
            if kl > 2.0 * self.ppo.desired_kl {
                self.lr = (self.lr / 1.5).max(self.ppo.lr_min);
            } else if kl < self.ppo.desired_kl / 2.0 && kl > 0.0 {
                self.lr = (self.lr * 1.5).min(self.ppo.lr_max);
            }
        }

        let actions = Tensor::from_slice(&b.actions, (rows, ad), &cpu)?;
        let old_logp = Tensor::from_slice(&b.log_probs, rows, &cpu)?;
        let adv = Tensor::from_slice(&b.advantages, rows, &cpu)?;
        let ret = Tensor::from_slice(&b.returns, rows, &cpu)?;
        let old_v = Tensor::from_slice(&b.values, rows, &cpu)?;
        let clip = self.ppo.clip;

        let logp = actor_critic::log_prob_tensor(&actions, &mean, log_std)?;
        let ratio = (logp - old_logp)?.exp()?;
        let surr = ratio.mul(&adv)?.minimum(&ratio.clamp(1.0 - clip, 1.0 + clip)?.mul(&adv)?)?;
        let surrogate = surr.mean_all()?.neg()?;
        let value_loss = if self.ppo.clip_value_loss {
            let clipped = (&old_v + (&value - &old_v)?.clamp(-clip, clip)?)?;
            (&value - &ret)?.sqr()?.maximum(&(clipped - &ret)?.sqr()?)?.mean_all()?
        } else {
            (&value - &ret)?.sqr()?.mean_all()?
        };
        let entropy = actor_critic::entropy_tensor(log_std)?;
        let mut loss =
            ((&surrogate + (&value_loss * self.ppo.value_loss_coef)?)? - (&entropy * self.ppo.entropy_coef)?)?;

        let mut sym_value = 0.0;
        if let (Some(sym), true) = (&self.symmetry, self.losses.symmetry_coef > 0.0) {
            let sym_loss = symmetry_loss(&self.ac, sym, &b.obs, &mean, rows)?;
            sym_value = sym_loss.to_scalar::<f32>()? as f64;
            loss = (loss + (sym_loss * self.losses.symmetry_coef)?)?;
        }
        let mut decay_value = 0.0;
        if self.losses.decay_coef > 0.0 {
            let decay = (decay_loss(&self.ac)? * self.losses.decay_coef)?;
            decay_value = decay.to_scalar::<f32>()? as f64;
            loss = (loss + decay)?;
        }

        stats.minibatches += 1;
        let loss_value = loss.to_scalar::<f32>()?;
        if !loss_value.is_finite() {
            stats.skipped += 1;
            log::warn!("PPO: non-finite loss, minibatch skipped (weights kept)");
            return Ok(());
        }
        let grads = loss.backward()?;
        let info = self.opt.clipped_step(&grads, self.lr, self.ppo.max_grad_norm)?;
        if !info.applied {
            stats.skipped += 1;
            log::warn!("PPO: non-finite gradient, minibatch skipped (weights kept)");
            return Ok(());
        }
        let ratios = ratio.to_vec1::<f32>()?;
        stats.clip_fraction += ratios.iter().filter(|r| (**r as f64 - 1.0).abs() > clip).count() as f64 / rows as f64;
        stats.surrogate += surrogate.to_scalar::<f32>()? as f64;
        stats.value_loss += value_loss.to_scalar::<f32>()? as f64;
        stats.entropy += entropy.to_scalar::<f32>()? as f64;
        stats.symmetry_loss += sym_value;
        stats.decay_loss += decay_value;
        stats.kl += kl;
        stats.grad_norm += info.grad_norm;
        Ok(())
    }
}

/// L_symmetry = MSE(S_a(π(o)), π(S_o(o))) on the action means (paper, eq. "symmetry"); `obs` are normalised
/// observations, which the symmetric normaliser lets us mirror directly.
pub fn symmetry_loss(ac: &ActorCritic, sym: &Symmetry, obs: &[f32], mean: &Tensor, rows: usize) -> Result<Tensor> {
    let mut mirrored = vec![0.0f32; obs.len()];
    sym.obs.apply_rows(obs, &mut mirrored);
    let mean_of_mirror = ac.actor.forward(&Tensor::from_vec(mirrored, (rows, ac.obs_dim), &Device::Cpu)?)?;
    mirror_actions(sym, mean)?.sub(&mean_of_mirror)?.sqr()?.mean_all()
}

/// S_a applied to a [rows, act_dim] tensor (a signed column permutation).
pub fn mirror_actions(sym: &Symmetry, a: &Tensor) -> Result<Tensor> {
    let cpu = Device::Cpu;
    let perm: Vec<u32> = sym.act.perm.iter().map(|&p| p as u32).collect();
    let sign = Tensor::from_slice(&sym.act.sign, sym.act.len(), &cpu)?;
    a.index_select(&Tensor::from_vec(perm, sym.act.len(), &cpu)?, 1)?.broadcast_mul(&sign)
}

/// ‖θ_last‖² of the actor's output layer (weights and bias), before the λ factor.
pub fn decay_loss(ac: &ActorCritic) -> Result<Tensor> {
    let last = ac.actor.last_layer();
    last.weight.as_tensor().sqr()?.sum_all()? + last.bias.as_tensor().sqr()?.sum_all()?
}

/// One minibatch gathered into contiguous buffers.
struct Minibatch {
    rows: usize,
    obs: Vec<f32>,
    actions: Vec<f32>,
    means: Vec<f32>,
    log_probs: Vec<f32>,
    values: Vec<f32>,
    returns: Vec<f32>,
    advantages: Vec<f32>,
}

impl Minibatch {
    fn with_capacity(rows: usize, od: usize, ad: usize) -> Self {
        Minibatch {
            rows,
            obs: Vec::with_capacity(rows * od),
            actions: Vec::with_capacity(rows * ad),
            means: Vec::with_capacity(rows * ad),
            log_probs: Vec::with_capacity(rows),
            values: Vec::with_capacity(rows),
            returns: Vec::with_capacity(rows),
            advantages: Vec::with_capacity(rows),
        }
    }

    fn gather(&mut self, r: &Rollout, idx: &[usize]) {
        let (od, ad) = (r.obs_dim, r.act_dim);
        self.rows = idx.len();
        for v in [
            &mut self.obs,
            &mut self.actions,
            &mut self.means,
            &mut self.log_probs,
            &mut self.values,
            &mut self.returns,
            &mut self.advantages,
        ] {
            v.clear();
        }
        for &i in idx {
            self.obs.extend_from_slice(&r.obs[i * od..(i + 1) * od]);
            self.actions.extend_from_slice(&r.actions[i * ad..(i + 1) * ad]);
            self.means.extend_from_slice(&r.means[i * ad..(i + 1) * ad]);
            self.log_probs.push(r.log_probs[i]);
            self.values.push(r.values[i]);
            self.returns.push(r.returns[i]);
            self.advantages.push(r.advantages[i]);
        }
    }
}
