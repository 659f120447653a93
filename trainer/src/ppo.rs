//! PPO (rsl_rl-style) for one agent: acting during rollouts, and the update — clipped surrogate, clipped value
//! loss, entropy bonus, the paper's symmetry and last-layer decay losses, adaptive learning rate from the
//! closed-form KL, global gradient-norm clipping, AdamW.

use crate::symmetry::Symmetry;
use candle_core::{Device, Result, Tensor};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;

use std::rc::Rc;

use crate::actor_critic::{self, ActorCritic, InferenceBuffers};
pub use crate::batch::Batch;
use crate::comm::{Comm, Single};
use crate::config::{LossConfig, PpoConfig};
use crate::estimator::EstimatorLearner;
use crate::normalizer::{Moments, Normalizer};
use crate::optim::{AdamParams, AdamW};
pub use crate::storage::ActOutput;
use crate::storage::Rollout;

/// Mean losses and diagnostics of one update.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct UpdateStats {
    pub surrogate: f64,
    pub value_loss: f64,
    pub entropy: f64,
    pub symmetry_loss: f64,
    pub decay_loss: f64,
    /// The concurrent estimator's regression (0 without one): MSE in normalised units, RMSE in the estimated
    /// values' units (m/s for the base velocity), on the minibatches before each step.
    pub estimator_loss: f64,
    pub estimator_rmse: f64,
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
    /// The same maps as the actor sees them (its view of the observation; equal to `symmetry` for a whole view).
    pub actor_symmetry: Option<Symmetry>,
    /// The concurrent estimator's optimiser (when the actor–critic has an estimator).
    pub estimator: Option<EstimatorLearner>,
    /// The ranks of a multi-process run: gradients, KL and normaliser statistics are combined over them.
    pub comm: Rc<dyn Comm>,
    buffers: InferenceBuffers,
}

impl Agent {
    /// The agent for `ac`; its estimator (if any) learns at `estimator_lr`. Fails when the mirror maps cannot be
    /// restricted to the actor's view of the observation.
    pub fn new(
        ac: ActorCritic,
        ppo: PpoConfig,
        losses: LossConfig,
        symmetry: Option<Symmetry>,
        estimator_lr: f64,
    ) -> crate::error::Result<Self> {
        let normalizer = Normalizer::new(ac.obs_dim, symmetry.as_ref().map(|s| s.obs.clone()));
        let opt = AdamW::new(ac.vars(), AdamParams::default());
        let actor_symmetry = match &symmetry {
            Some(s) if !ac.view.is_whole() => {
                let obs = ac.view.mirror(&s.obs)?;
                Some(Symmetry { obs, act: s.act.clone() })
            }
            s => s.clone(),
        };
        let estimator = ac.estimator.as_ref().map(|e| EstimatorLearner::new(e, estimator_lr, ppo.max_grad_norm));
        Ok(Agent {
            lr: ppo.learning_rate,
            ac,
            normalizer,
            opt,
            ppo,
            losses,
            symmetry,
            actor_symmetry,
            estimator,
            comm: Rc::new(Single),
            buffers: InferenceBuffers::default(),
        })
    }

    /// Normalises `raw_obs` (updating the statistics first unless frozen), then samples actions (or takes the
    /// mean when `explore` is false) and evaluates log-probabilities and values.
    pub fn act(&mut self, raw_obs: &[f32], rng: &mut ChaCha8Rng, explore: bool, out: ActOutput<'_>) -> Result<()> {
        let rows = raw_obs.len() / self.ac.obs_dim;
        self.update_normalizer(raw_obs);
        self.normalizer.normalize(raw_obs, out.obs_norm);
        let (ac, b) = (&self.ac, &mut self.buffers);
        actor_critic::actor_forward(
            &ac.view,
            &ac.actor,
            ac.estimator.as_ref(),
            out.obs_norm,
            rows,
            &mut b.mean,
            &mut b.actor,
        );
        out.estimates.copy_from_slice(&b.actor.estimate);
        ac.critic.forward_inference(out.obs_norm, rows, &mut b.value, &mut b.critic);
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
    /// Adds this step's observations of every rank, merged in rank order (the same statistics on all ranks).
    fn update_normalizer(&mut self, raw_obs: &[f32]) {
        if self.normalizer.frozen {
            return;
        }
        let local = self.normalizer.batch_moments(raw_obs).to_flat();
        for m in self.comm.all_gather_f64(&local).chunks_exact(local.len()) {
            self.normalizer.merge(&Moments::from_flat(m));
        }
    }

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
        let augment = self.symmetry.clone().filter(|_| self.losses.symmetry_augmentation);
        let mut buf = Batch::with_capacity(if augment.is_some() { 2 * mb } else { mb }, od, ad);
        let scale = estimate_scale(&self.normalizer, &self.ac.view);
        for _ in 0..self.ppo.epochs {
            // Fisher–Yates with our stream, so the minibatches are part of the seeded run.
            for i in (1..n).rev() {
                idx.swap(i, rng.random_range(0..=i));
            }
            for k in 0..self.ppo.minibatches {
                buf.gather(r, &idx[k * mb..(k + 1) * mb], &self.ac.view);
                if let (Some(sym), Some(actor)) = (&augment, &self.actor_symmetry) {
                    buf.append_mirror(sym, &actor.obs);
                }
                self.minibatch_step(&buf, &r.std, &scale, &mut stats)?;
            }
        }
        let m = stats.minibatches.max(1) as f64;
        for v in [
            &mut stats.surrogate,
            &mut stats.value_loss,
            &mut stats.entropy,
            &mut stats.symmetry_loss,
            &mut stats.decay_loss,
            &mut stats.estimator_loss,
            &mut stats.estimator_rmse,
            &mut stats.kl,
            &mut stats.clip_fraction,
            &mut stats.grad_norm,
        ] {
            *v /= m;
        }
        stats.learning_rate = self.lr;
        Ok(stats)
    }

    /// `scale`: the estimated columns' normaliser scale (the normaliser does not change during an update).
    fn minibatch_step(&mut self, b: &Batch, old_std: &[f32], scale: &[f32], stats: &mut UpdateStats) -> Result<()> {
        let rows = b.rows;
        let obs = Tensor::from_slice(&b.obs, (rows, self.ac.obs_dim), &Device::Cpu)?;
        let actor_obs = if self.ac.view.is_whole() {
            obs.clone()
        } else {
            Tensor::from_slice(&b.actor_obs, (rows, self.ac.view.dim()), &Device::Cpu)?
        };
        // The actor's loss and the critic's share no parameter, so their forward and backward passes run side by
        // side: with two threads each pass keeps a thread busy between the other's short parallel regions. Each
        // backward is the one the summed loss would give (same graph below each root), so the arithmetic does not
        // depend on the thread count.
        let (ac, ppo, losses, sym) = (&self.ac, &self.ppo, &self.losses, self.actor_symmetry.as_ref());
        let (actor, critic) = rayon::join(
            || -> Result<_> {
                let mean = ac.actor.forward(&actor_obs)?;
                let terms = actor_terms(ac, ppo, losses, sym, b, &mean)?;
                let grads = backward_if_finite(&terms.total)?;
                Ok((mean, terms, grads))
            },
            || -> Result<_> {
                let value = critic_loss(ac, ppo, b, &obs)?;
                let scaled = (&value * ppo.value_loss_coef)?;
                let grads = backward_if_finite(&scaled)?;
                Ok((value, grads))
            },
        );
        let ((mean, terms, actor_grads), (value_loss, critic_grads)) = (actor?, critic?);
        // Adaptive learning rate from the KL between the rollout policy and the current one (rsl_rl's rule).
        let new_mean = mean.flatten_all()?.to_vec1::<f32>()?;
        let new_std = self.ac.log_std.as_tensor().exp()?.to_vec1::<f32>()?;
        // On the rollout's own rows: their mirror images were never acted on.
        let kl = actor_critic::mean_kl(&b.means[..b.sampled_rows() * self.ac.act_dim], old_std, &new_mean, &new_std);
        stats.minibatches += 1;
        if let (Some(learner), Some(net)) = (&mut self.estimator, &self.ac.estimator) {
            let step = learner.step(net, &self.ac.view, &obs, scale, self.comm.as_ref())?;
            stats.estimator_loss += step.loss;
            stats.estimator_rmse += step.rmse;
        }
        let finite = actor_grads.is_some() && critic_grads.is_some();
        // All ranks take the same step: the mean gradient, the mean KL, and a skip if any rank's loss failed
        // (with one process the sums are the identity).
        let mut g = match (&actor_grads, &critic_grads) {
            (Some(a), Some(c)) => self.opt.gradients_of(&[a, c])?,
            _ => self.opt.vars().iter().map(|v| vec![0.0; v.elem_count()]).collect(),
        };
        let mut flat = g.concat();
        self.comm.sum_f32(&mut flat);
        let mut scalars = [kl, if finite { 0.0 } else { 1.0 }];
        self.comm.sum_f64(&mut scalars);
        let size = self.comm.size() as f64;
        let kl = scalars[0] / size;
        if self.ppo.adaptive_lr {
            self.lr = adapt_learning_rate(self.lr, kl, &self.ppo);
        }
        if scalars[1] > 0.0 {
            stats.skipped += 1;
            log::warn!("PPO: non-finite loss, minibatch skipped on every rank (weights kept)");
            return Ok(());
        }
        let mut at = 0;
        for gi in &mut g {
            for (x, s) in gi.iter_mut().zip(&flat[at..]) {
                *x = (*s as f64 / size) as f32;
            }
            at += gi.len();
        }
        let info = self.opt.clipped_step_on(g, self.lr, self.ppo.max_grad_norm)?;
        if !info.applied {
            stats.skipped += 1;
            log::warn!("PPO: non-finite gradient, minibatch skipped (weights kept)");
            return Ok(());
        }
        let clip = self.ppo.clip;
        let ratios = terms.ratio.to_vec1::<f32>()?;
        stats.clip_fraction += ratios.iter().filter(|r| (**r as f64 - 1.0).abs() > clip).count() as f64 / rows as f64;
        let scalar = |t: &Option<Tensor>| -> Result<f64> {
            Ok(match t {
                Some(t) => t.to_scalar::<f32>()? as f64,
                None => 0.0,
            })
        };
        stats.surrogate += terms.surrogate.to_scalar::<f32>()? as f64;
        stats.value_loss += value_loss.to_scalar::<f32>()? as f64;
        stats.entropy += terms.entropy.to_scalar::<f32>()? as f64;
        stats.symmetry_loss += scalar(&terms.symmetry)?;
        stats.decay_loss += scalar(&terms.decay)?;
        stats.kl += kl;
        stats.grad_norm += info.grad_norm;
        Ok(())
    }

    /// The paper's total loss L = L_actor + L_critic + L_symmetry + L_decay and its parts, for one batch
    /// (`obs` and `mean` = π(obs) already computed). L_actor is the clipped surrogate minus the entropy bonus;
    /// symmetry and decay carry their coefficients. (The update takes the actor's and the critic's parts apart.)
    pub fn loss_terms(&self, b: &Batch, obs: &Tensor, mean: &Tensor) -> Result<LossTerms> {
        let a = actor_terms(&self.ac, &self.ppo, &self.losses, self.actor_symmetry.as_ref(), b, mean)?;
        let value = critic_loss(&self.ac, &self.ppo, b, obs)?;
        let total = (&a.total + (&value * self.ppo.value_loss_coef)?)?;
        Ok(LossTerms {
            total,
            surrogate: a.surrogate,
            value,
            entropy: a.entropy,
            symmetry: a.symmetry,
            decay: a.decay,
            ratio: a.ratio,
        })
    }
}

/// What one normalised unit of each estimated column is in the column's own units (the normaliser's scale).
fn estimate_scale(n: &Normalizer, view: &crate::actor_view::ActorView) -> Vec<f32> {
    let std = n.std();
    view.estimate.clone().map_or(Vec::new(), |c| c.map(|i| (std[i] + crate::normalizer::STD_EPS) as f32).collect())
}

/// The gradients of `loss`, or None when its value is not finite.
fn backward_if_finite(loss: &Tensor) -> Result<Option<candle_core::backprop::GradStore>> {
    if loss.to_scalar::<f32>()?.is_finite() {
        Ok(Some(loss.backward()?))
    } else {
        Ok(None)
    }
}

/// The actor's part of the loss: the clipped surrogate minus the entropy bonus, plus symmetry and decay (with their
/// coefficients); `total` is their sum.
fn actor_terms(
    ac: &ActorCritic,
    ppo: &PpoConfig,
    losses: &LossConfig,
    sym: Option<&Symmetry>,
    b: &Batch,
    mean: &Tensor,
) -> Result<ActorTerms> {
    let cpu = Device::Cpu;
    let rows = b.rows;
    let log_std = ac.log_std.as_tensor();
    let actions = Tensor::from_slice(&b.actions, (rows, ac.act_dim), &cpu)?;
    let old_logp = Tensor::from_slice(&b.log_probs, rows, &cpu)?;
    let adv = Tensor::from_slice(&b.advantages, rows, &cpu)?;
    let clip = ppo.clip;
    let logp = actor_critic::log_prob_tensor(&actions, mean, log_std)?;
    let ratio = (logp - old_logp)?.exp()?;
    let surr = ratio.mul(&adv)?.minimum(&ratio.clamp(1.0 - clip, 1.0 + clip)?.mul(&adv)?)?;
    let surrogate = surr.mean_all()?.neg()?;
    let entropy = actor_critic::entropy_tensor(log_std)?;
    let mut total = (&surrogate - (&entropy * ppo.entropy_coef)?)?;
    let symmetry = match (sym, losses.symmetry_coef > 0.0) {
        (Some(sym), true) => {
            let l = if b.mirrored {
                // π(S_o(o)) is already the second half of `mean`.
                let n = rows / 2;
                mirror_mse(sym, &mean.narrow(0, 0, n)?, &mean.narrow(0, n, n)?)?
            } else {
                symmetry_loss(ac, sym, b.actor_rows(), mean, rows)?
            };
            Some((l * losses.symmetry_coef)?)
        }
        _ => None,
    };
    if let Some(s) = &symmetry {
        total = (total + s)?;
    }
    let decay = if losses.decay_coef > 0.0 { Some((decay_loss(ac)? * losses.decay_coef)?) } else { None };
    if let Some(d) = &decay {
        total = (total + d)?;
    }
    Ok(ActorTerms { total, surrogate, entropy, symmetry, decay, ratio })
}

/// The critic's loss: the (optionally clipped) squared error of the value against the return.
fn critic_loss(ac: &ActorCritic, ppo: &PpoConfig, b: &Batch, obs: &Tensor) -> Result<Tensor> {
    let cpu = Device::Cpu;
    let rows = b.rows;
    let value = ac.critic.forward(obs)?.squeeze(1)?;
    let ret = Tensor::from_slice(&b.returns, rows, &cpu)?;
    if ppo.clip_value_loss {
        let old_v = Tensor::from_slice(&b.values, rows, &cpu)?;
        let clip = ppo.clip;
        let clipped = (&old_v + (&value - &old_v)?.clamp(-clip, clip)?)?;
        (&value - &ret)?.sqr()?.maximum(&(clipped - &ret)?.sqr()?)?.mean_all()
    } else {
        (&value - &ret)?.sqr()?.mean_all()
    }
}

struct ActorTerms {
    total: Tensor,
    surrogate: Tensor,
    entropy: Tensor,
    symmetry: Option<Tensor>,
    decay: Option<Tensor>,
    ratio: Tensor,
}

/// rsl_rl's adaptive schedule: divide by 1.5 when the KL exceeds twice the target, multiply by 1.5 when it is
/// below half of it, within [lr_min, lr_max].
pub fn adapt_learning_rate(lr: f64, kl: f64, ppo: &PpoConfig) -> f64 {
    if !kl.is_finite() {
        lr
    } else if kl > 2.0 * ppo.desired_kl {
        (lr / 1.5).max(ppo.lr_min)
    } else if kl < ppo.desired_kl / 2.0 && kl > 0.0 {
        (lr * 1.5).min(ppo.lr_max)
    } else {
        lr
    }
}

/// The loss and its parts (scalars), plus the probability ratios (for the clip fraction).
pub struct LossTerms {
    pub total: Tensor,
    pub surrogate: Tensor,
    pub value: Tensor,
    pub entropy: Tensor,
    /// coef × L_symmetry, when there is a symmetry and a positive coefficient.
    pub symmetry: Option<Tensor>,
    /// λ‖θ_last‖², when λ > 0.
    pub decay: Option<Tensor>,
    pub ratio: Tensor,
}

/// L_symmetry = MSE(S_a(π(o)), π(S_o(o))) on the action means (paper, eq. "symmetry"); `obs` are the actor's
/// normalised input rows, which the symmetric normaliser lets us mirror directly (`sym.obs` is the actor's map).
pub fn symmetry_loss(ac: &ActorCritic, sym: &Symmetry, obs: &[f32], mean: &Tensor, rows: usize) -> Result<Tensor> {
    let mut mirrored = vec![0.0f32; obs.len()];
    sym.obs.apply_rows(obs, &mut mirrored);
    let mean_of_mirror = ac.actor.forward(&Tensor::from_vec(mirrored, (rows, ac.view.dim()), &Device::Cpu)?)?;
    mirror_mse(sym, mean, &mean_of_mirror)
}

/// MSE(S_a(π(o)), π(S_o(o))) from the two action means.
fn mirror_mse(sym: &Symmetry, mean: &Tensor, mean_of_mirror: &Tensor) -> Result<Tensor> {
    mirror_actions(sym, mean)?.sub(mean_of_mirror)?.sqr()?.mean_all()
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::actor_view::ActorView;
    use crate::symmetry::SignedPermutation;
    use rand::SeedableRng;

    /// The update's two backward passes (actor, critic) give the summed loss's gradient bit for bit: the split is a
    /// matter of scheduling, not of arithmetic.
    #[test]
    fn the_split_losses_have_the_summed_losses_gradient_exactly() {
        let (od, ad, rows) = (6, 4, 96);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let ac = ActorCritic::new(ActorView::whole(od), ad, &[32, 16], &[32, 16], &[], 0.7, &mut rng).unwrap();
        let mut obs_map = SignedPermutation::identity(od);
        obs_map.set_block(0, &[1, 0], &[1.0, -1.0]);
        let mut act_map = SignedPermutation::identity(ad);
        act_map.set_block(2, &[1, 0], &[-1.0, 1.0]);
        let sym = Symmetry { obs: obs_map, act: act_map };
        let losses = LossConfig { symmetry_coef: 0.7, decay_coef: 0.05, symmetry_augmentation: false };
        let ppo = PpoConfig { value_loss_coef: 0.8, entropy_coef: 0.01, ..PpoConfig::default() };
        let agent = Agent::new(ac, ppo, losses, Some(sym), 0.0).unwrap();
        let mut v = |n: usize, s: f32| -> Vec<f32> { (0..n).map(|_| rng.random_range(-s..s)).collect() };
        let b = Batch {
            rows,
            mirrored: false,
            obs: v(rows * od, 1.0),
            actor_obs: Vec::new(),
            actions: v(rows * ad, 1.0),
            means: v(rows * ad, 0.5),
            log_probs: v(rows, 1.0).iter().map(|x| x - 5.0).collect(),
            values: v(rows, 1.0),
            returns: v(rows, 2.0),
            advantages: v(rows, 1.5),
        };
        let obs = Tensor::from_slice(&b.obs, (rows, od), &Device::Cpu).unwrap();
        let mean = agent.ac.actor.forward(&obs).unwrap();
        let summed =
            agent.opt.gradients(&agent.loss_terms(&b, &obs, &mean).unwrap().total.backward().unwrap()).unwrap();
        let a = actor_terms(&agent.ac, &agent.ppo, &agent.losses, agent.symmetry.as_ref(), &b, &mean).unwrap();
        let c = (critic_loss(&agent.ac, &agent.ppo, &b, &obs).unwrap() * agent.ppo.value_loss_coef).unwrap();
        let (ga, gc) = (backward_if_finite(&a.total).unwrap().unwrap(), backward_if_finite(&c).unwrap().unwrap());
        let split = agent.opt.gradients_of(&[&ga, &gc]).unwrap();
        assert!(summed.iter().all(|g| g.iter().any(|x| *x != 0.0)), "every variable has a gradient");
        for (s, p) in summed.iter().zip(&split) {
            let bits = |g: &[f32]| g.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(s), bits(p));
        }
    }
}
