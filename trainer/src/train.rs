//! The training loop: rollouts on any `VecEnv`, PPO updates of whichever agent the schedule says learns, and
//! the cyclic adversary's perturbations. Everything random comes from one seeded stream, so a seed (plus a
//! checkpoint, when resuming) fixes the run.

use std::rc::Rc;
use std::time::Instant;

use crate::error::{invalid, Error, Result};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::actor_critic::ActorCritic;
use crate::actor_view::ActorView;
use crate::adversary;
use crate::comm::{Comm, CommStats, Single};
use crate::config::{LossConfig, TrainConfig};
use crate::ppo::{ActOutput, Agent, UpdateStats};
use crate::schedule::{Phase, Position, Schedule};
use crate::storage::Rollout;
use crate::vec_env::{perturbation_dim, EpisodeStats, PerturbationChannel, StepTiming, VecEnv};

/// The adversary agent, the task's perturbation channels and their bounds (flattened).
pub struct Adversary {
    pub agent: Agent,
    pub channels: Vec<PerturbationChannel>,
    pub bounds: Vec<f32>,
    /// Set by `adversary.mirror_attacks`: the odd envs are attacked through the mirror.
    pub mirror: Option<adversary::AttackMirror>,
}

impl Adversary {
    /// What the adversary observes of these observation rows (row `i` is env `env_of_row(i)`'s): the rows
    /// themselves, or, with mirrored attacks, `buf` holding them with the mirrored envs' rows mirrored.
    fn sees<'a>(&self, rows: &'a [f32], buf: &'a mut Vec<f32>, env_of_row: impl Fn(usize) -> usize) -> &'a [f32] {
        match &self.mirror {
            Some(m) => {
                m.view(rows, buf, env_of_row);
                buf
            }
            None => rows,
        }
    }
}

impl IterationLog {
    /// This iteration's wall time (collection and update), s.
    pub fn wall_time_delta(&self) -> f64 {
        self.collect_s + self.update_s
    }
}

/// What one iteration did (one row of the training log).
#[derive(Debug, Clone)]
pub struct IterationLog {
    pub iteration: usize,
    pub phase: Phase,
    pub cycle: usize,
    pub samples: u64,
    pub wall_time_s: f64,
    pub collect_s: f64,
    /// Part of `collect_s` spent in the networks (normalising, batched forward passes, sampling).
    pub inference_s: f64,
    pub update_s: f64,
    /// Environment samples per second over this iteration (collection + update).
    pub fps: f64,
    pub episodes: EpisodeStats,
    /// Where the environments' stepping time went (physics, resets, the rest).
    pub env_timing: StepTiming,
    /// Mean reward per step over the rollout (the policy's task reward, under attack in phase 3).
    pub mean_step_reward: f64,
    pub policy: Option<UpdateStats>,
    pub adversary: Option<UpdateStats>,
    /// Mean magnitude of each perturbation channel the adversary applied (zeros in phase 1; empty without an
    /// adversary), in the env's channel order.
    pub perturbation: Vec<f64>,
    pub action_std: f64,
    /// Time in collectives and bytes this rank sent and received (zero in a one-process run).
    pub comm: CommStats,
}

pub struct Trainer {
    pub cfg: TrainConfig,
    pub env: Box<dyn VecEnv>,
    pub policy: Agent,
    pub adversary: Option<Adversary>,
    pub schedule: Schedule,
    pub rng: ChaCha8Rng,
    /// Iterations done.
    pub iteration: usize,
    pub samples: u64,
    pub wall_time_s: f64,
    /// `wall_time_s` by machine and thread count (a resumed or forked run keeps its earlier stretches).
    pub segments: Vec<crate::segments::Segment>,
    /// This process's machine and worker threads, for `segments`.
    host: (String, usize),
    /// The ranks this run is spread over (`Single` unless launched under MPI).
    pub comm: Rc<dyn Comm>,
    policy_rollout: Rollout,
    adversary_rollout: Option<Rollout>,
    scratch: Scratch,
}

/// Per-step buffers for the agent that acts without learning, and for perturbations.
#[derive(Default)]
struct Scratch {
    raw_obs: Vec<f32>,
    obs_norm: Vec<f32>,
    actions: Vec<f32>,
    means: Vec<f32>,
    log_probs: Vec<f32>,
    values: Vec<f32>,
    estimates: Vec<f32>,
    adv_obs_norm: Vec<f32>,
    /// The adversary's view of `raw_obs` when it attacks through the mirror.
    adv_raw_obs: Vec<f32>,
    adv_actions: Vec<f32>,
    adv_means: Vec<f32>,
    adv_log_probs: Vec<f32>,
    adv_values: Vec<f32>,
    perturbation: Vec<f32>,
}

impl Trainer {
    /// A fresh run on `env`. With `with_adversary`, the paper's cyclic schedule from `cfg.adversary`; otherwise
    /// `cfg.run.iterations` of plain PPO.
    pub fn new(cfg: TrainConfig, env: Box<dyn VecEnv>, with_adversary: bool) -> Result<Self> {
        cfg.validate()?;
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.run.seed);
        let (n, od, ad) = (env.num_envs(), env.obs_dim(), env.action_dim());
        let net = &cfg.network;
        let view = env.actor_view();
        if view.obs_dim != od {
            invalid!("the task's actor view is of {} observation values, its observation has {od}", view.obs_dim);
        }
        view.validate()?;
        let ac = ActorCritic::new(
            view,
            ad,
            &net.actor_hidden,
            &net.critic_hidden,
            &net.estimator_hidden,
            net.init_noise_std,
            &mut rng,
        )?;
        let est_dim = ac.view.estimate_dim();
        let symmetry = env.symmetry();
        for (key, on) in [
            ("losses.symmetry_augmentation", cfg.losses.symmetry_augmentation),
            ("adversary.policy_symmetry_augmentation", with_adversary && cfg.adversary.policy_symmetry_augmentation),
        ] {
            if on && symmetry.is_none() {
                invalid!(
                    "{key} needs a task with a left↔right mirror of its observations and actions, and this one has \
                     none: set it to false"
                );
            }
        }
        let policy =
            Agent::new(ac, cfg.ppo.clone(), cfg.losses.clone(), symmetry.clone(), net.estimator_learning_rate)?;
        let (adversary, schedule) = if with_adversary {
            let channels = env.perturbation_channels();
            let pd = perturbation_dim(&channels);
            if pd == 0 {
                invalid!("this task takes no perturbations, so it cannot be trained with an adversary");
            }
            let a = &cfg.adversary;
            // The adversary reads the whole row, privileged values included: it is never deployed.
            let ac =
                ActorCritic::new(ActorView::whole(od), pd, &a.hidden, &a.hidden, &[], net.init_noise_std, &mut rng)?;
            let mut ppo = cfg.ppo.clone();
            ppo.learning_rate = a.learning_rate;
            ppo.entropy_coef = a.entropy_coef;
            // No symmetry or decay for the adversary: the paper applies them to the locomotion policy.
            let losses = LossConfig { symmetry_coef: 0.0, decay_coef: 0.0, symmetry_augmentation: false };
            let agent = Agent::new(ac, ppo, losses, None, 0.0)?;
            let sched = a.schedule();
            let bounds = adversary::bounds(&channels);
            let mirror = if a.mirror_attacks {
                let (Some(sym), Some(pm)) = (symmetry, env.perturbation_mirror()) else {
                    invalid!(
                        "adversary.mirror_attacks needs a task with a left↔right mirror of its observations and \
                         perturbations, and this one has none: set it to false"
                    );
                };
                let m = adversary::AttackMirror::new(sym.obs, pm, od, &bounds);
                Some(m.map_err(|e| Error::Invalid(format!("adversary.mirror_attacks: {e}")))?)
            } else {
                None
            };
            (Some(Adversary { agent, channels, bounds, mirror }), sched)
        } else {
            (None, Schedule::plain(cfg.run.iterations))
        };
        let steps = cfg.run.steps_per_env;
        let adversary_rollout = adversary.as_ref().map(|a| Rollout::new(steps, n, od, a.bounds.len()));
        let mut t = Trainer {
            policy_rollout: Rollout::new(steps, n, od, ad).with_estimates(est_dim),
            adversary_rollout,
            scratch: Scratch::default(),
            cfg,
            env,
            policy,
            adversary,
            schedule,
            rng,
            iteration: 0,
            samples: 0,
            wall_time_s: 0.0,
            segments: Vec::new(),
            host: (crate::segments::this_machine(), rayon::current_num_threads()),
            comm: Rc::new(Single),
        };
        t.env.reset().map_err(Error::env("resetting the environments"))?;
        Ok(t)
    }

    /// Spreads the run over `comm`'s ranks. Call right after `new`, before any iteration or restore: every rank
    /// starts from the same weights (the run seed made them), then draws its own actions and minibatches (its
    /// own stream of the seed; rank 0 keeps the one-process stream).
    pub fn set_comm(&mut self, comm: Rc<dyn Comm>) {
        if comm.rank() > 0 {
            self.rng.set_stream(comm.rank() as u64);
        }
        self.policy.comm = comm.clone();
        if let Some(a) = &mut self.adversary {
            a.agent.comm = comm.clone();
        }
        self.comm = comm;
    }

    pub fn total_iterations(&self) -> usize {
        self.schedule.total()
    }

    pub fn position(&self) -> Option<Position> {
        self.schedule.position(self.iteration)
    }

    pub fn is_done(&self) -> bool {
        self.position().is_none()
    }

    /// Runs one iteration (rollout + update of whichever agent learns in this phase); None when the schedule is
    /// complete.
    pub fn iterate(&mut self) -> Result<Option<IterationLog>> {
        let Some(pos) = self.position() else { return Ok(None) };
        let start = Instant::now();
        // Freeze what does not learn in this phase: no normaliser updates, no gradient work.
        self.policy.normalizer.frozen = !pos.phase.policy_learns();
        if let Some(a) = &mut self.adversary {
            a.agent.normalizer.frozen = pos.phase != Phase::Adversary;
        }
        let solo = self.comm.size() == 1;
        let (mean_step_reward, perturbation, inference_s) = on_worker_if(solo, || self.collect(pos.phase))?;
        let collect_s = start.elapsed().as_secs_f64();
        let t_update = Instant::now();
        let (mut policy_stats, mut adversary_stats) = (None, None);
        if pos.phase.policy_learns() {
            // The entropy schedule is the policy's (phase 3 has its own weight); the adversary's bonus stays
            // `adversary.entropy_coef`.
            self.policy.ppo.entropy_coef = match pos.phase {
                Phase::PolicyUnderAttack => self.cfg.adversary.policy_entropy_coef,
                _ => self.cfg.ppo.entropy_coef_at(self.iteration),
            };
            self.policy.losses.symmetry_augmentation = self.cfg.losses.symmetry_augmentation
                || (pos.phase == Phase::PolicyUnderAttack && self.cfg.adversary.policy_symmetry_augmentation);
            let (policy, rollout, rng) = (&mut self.policy, &self.policy_rollout, &mut self.rng);
            policy_stats = Some(on_worker_if(solo, || policy.update(rollout, rng))?);
        } else if let (Some(a), Some(r)) = (&mut self.adversary, &self.adversary_rollout) {
            let rng = &mut self.rng;
            adversary_stats = Some(on_worker_if(solo, || a.agent.update(r, rng))?);
        }
        let update_s = t_update.elapsed().as_secs_f64();
        let n = (self.env.num_envs() * self.cfg.run.steps_per_env * self.comm.size()) as u64;
        self.samples += n;
        self.iteration += 1;
        let elapsed = start.elapsed().as_secs_f64();
        self.wall_time_s += elapsed;
        crate::segments::record(&mut self.segments, &self.host.0, self.host.1, self.iteration - 1, elapsed);
        let std = self.policy.ac.std()?;
        let (episodes, mean_step_reward) = self.all_ranks_episodes(mean_step_reward);
        Ok(Some(IterationLog {
            iteration: self.iteration,
            phase: pos.phase,
            cycle: pos.cycle,
            samples: self.samples,
            wall_time_s: self.wall_time_s,
            collect_s,
            inference_s,
            update_s,
            fps: n as f64 / elapsed,
            episodes,
            env_timing: self.env.take_step_timing(),
            mean_step_reward,
            policy: policy_stats,
            adversary: adversary_stats,
            perturbation,
            action_std: std.iter().map(|&s| s as f64).sum::<f64>() / std.len() as f64,
            comm: self.comm.take_stats(),
        }))
    }

    /// This iteration's finished episodes and mean step reward over all ranks (for the log).
    fn all_ranks_episodes(&mut self, mean_step_reward: f64) -> (EpisodeStats, f64) {
        let mut e = self.env.take_episode_stats();
        e.mean_terms.resize(self.env.term_names().len(), 0.0);
        let size = self.comm.size();
        if size == 1 {
            return (e, mean_step_reward);
        }
        let k = e.episodes as f64;
        let mut v = vec![k, k * e.mean_return, k * e.mean_length, k * e.time_out_share, e.diverged as f64];
        v.push(mean_step_reward);
        // Ranks hold equal shares of the envs: the mean level is the mean of the ranks' means.
        v.extend(e.curriculum_level.map_or([0.0, 0.0], |l| [l, 1.0]));
        v.extend(e.mean_terms.iter().map(|t| k * t));
        self.comm.sum_f64(&mut v);
        let total = v[0].max(1.0);
        e.episodes = v[0] as usize;
        (e.mean_return, e.mean_length, e.time_out_share) = (v[1] / total, v[2] / total, v[3] / total);
        e.diverged = v[4] as usize;
        e.curriculum_level = (v[7] > 0.0).then(|| v[6] / v[7]);
        e.mean_terms = v[8..].iter().map(|t| t / total).collect();
        (e, v[5] / size as f64)
    }

    /// One rollout of `steps_per_env` steps; fills the learning agent's storage and computes its returns.
    fn collect(&mut self, phase: Phase) -> Result<(f64, Vec<f64>, f64)> {
        let (n, od, ad) = (self.env.num_envs(), self.env.obs_dim(), self.env.action_dim());
        let steps = self.cfg.run.steps_per_env;
        let gamma = self.cfg.ppo.gamma;
        let policy_learns = phase.policy_learns();
        let adversary_acts = phase.adversary_acts() && self.adversary.is_some();
        let pd = self.adversary.as_ref().map_or(0, |a| a.bounds.len());
        let s = &mut self.scratch;
        s.raw_obs.resize(n * od, 0.0);
        for (v, len) in
            [(&mut s.obs_norm, n * od), (&mut s.actions, n * ad), (&mut s.means, n * ad), (&mut s.adv_obs_norm, n * od)]
        {
            v.resize(len, 0.0);
        }
        for v in [&mut s.log_probs, &mut s.values, &mut s.adv_log_probs, &mut s.adv_values] {
            v.resize(n, 0.0);
        }
        for v in [&mut s.adv_actions, &mut s.adv_means, &mut s.perturbation] {
            v.resize(n * pd, 0.0);
        }
        s.estimates.resize(n * self.policy.ac.view.estimate_dim(), 0.0);
        if pd > 0 && !adversary_acts {
            self.env.set_perturbations(&vec![0.0; n * pd]).map_err(Error::env("clearing the perturbations"))?;
        }
        self.policy_rollout.clear();
        if let Some(r) = &mut self.adversary_rollout {
            r.clear();
        }
        let mut reward_sum = 0.0f64;
        let mut magnitude = vec![0.0f64; self.adversary.as_ref().map_or(0, |a| a.channels.len())];
        let mut inference = std::time::Duration::ZERO;
        for t in 0..steps {
            let t_act = Instant::now();
            let s = &mut self.scratch;
            s.raw_obs.copy_from_slice(self.env.obs());
            // The policy acts: sampling and storing when it learns, its mean action when frozen.
            if policy_learns {
                let r = &mut self.policy_rollout;
                self.policy.act(&s.raw_obs, &mut self.rng, true, r.next_step())?;
                s.actions.copy_from_slice(r.last_actions());
            } else {
                let out = ActOutput {
                    obs_norm: &mut s.obs_norm,
                    actions: &mut s.actions,
                    means: &mut s.means,
                    log_probs: &mut s.log_probs,
                    values: &mut s.values,
                    estimates: &mut s.estimates,
                };
                self.policy.act(&s.raw_obs, &mut self.rng, false, out)?;
            }
            // The adversary perturbs (phases 2 and 3): sampling while it learns; in phase 3 as configured.
            if adversary_acts {
                let a = self.adversary.as_mut().expect("adversary");
                let adv_obs = a.sees(&s.raw_obs, &mut s.adv_raw_obs, |e| e);
                if phase == Phase::Adversary {
                    let r = self.adversary_rollout.as_mut().expect("adversary rollout");
                    a.agent.act(adv_obs, &mut self.rng, true, r.next_step())?;
                    s.adv_actions.copy_from_slice(r.last_actions());
                } else {
                    let out = ActOutput {
                        obs_norm: &mut s.adv_obs_norm,
                        actions: &mut s.adv_actions,
                        means: &mut s.adv_means,
                        log_probs: &mut s.adv_log_probs,
                        values: &mut s.adv_values,
                        estimates: &mut [],
                    };
                    a.agent.act(adv_obs, &mut self.rng, self.cfg.adversary.sample_when_frozen, out)?;
                }
                adversary::squash(&s.adv_actions, &a.bounds, &mut s.perturbation);
                if let Some(m) = &a.mirror {
                    m.apply(&mut s.perturbation);
                }
                if phase == Phase::PolicyUnderAttack {
                    let attacked = (self.cfg.adversary.attack_share * n as f64).ceil() as usize;
                    s.perturbation[attacked.min(n) * pd..].fill(0.0);
                }
                let m = adversary::magnitudes(&s.perturbation, &a.channels);
                for (sum, x) in magnitude.iter_mut().zip(m) {
                    *sum += x / steps as f64;
                }
                self.env
                    .set_perturbations(&s.perturbation)
                    .map_err(Error::env("applying the adversary's perturbations"))?;
            }
            inference += t_act.elapsed();
            self.env.step(&s.actions).map_err(Error::env("stepping the environments"))?;
            reward_sum += self.env.rewards().iter().map(|&r| r as f64).sum::<f64>();
            self.store_rewards(t, phase, gamma)?;
        }
        // Bootstrap values of the observations after the last step.
        let mut last = vec![0.0f32; n];
        let final_obs = self.env.obs().to_vec();
        if policy_learns {
            self.policy.values(&final_obs, &mut last);
            self.policy_rollout.compute_returns(&last, gamma, self.cfg.ppo.gae_lambda);
        } else if let (Some(a), Some(r)) = (&mut self.adversary, &mut self.adversary_rollout) {
            let mut view = Vec::new();
            let adv_obs = a.sees(&final_obs, &mut view, |e| e);
            a.agent.values(adv_obs, &mut last);
            r.compute_returns(&last, gamma, self.cfg.ppo.gae_lambda);
        }
        Ok((reward_sum / (n * steps) as f64, magnitude, inference.as_secs_f64()))
    }

    /// Stores step `t`'s rewards and dones for the learning agent, adding γ·V(terminal observation) where an
    /// episode ended by time-out (it did not fail: its value is not zero).
    fn store_rewards(&mut self, t: usize, phase: Phase, gamma: f64) -> Result<()> {
        let n = self.env.num_envs();
        let od = self.env.obs_dim();
        let timed_out: Vec<usize> = (0..n).filter(|&e| self.env.time_outs()[e] > 0.5).collect();
        let mut boot = vec![0.0f32; n];
        if !timed_out.is_empty() {
            let term = self.env.terminal_obs();
            let rows: Vec<f32> = timed_out.iter().flat_map(|&e| term[e * od..(e + 1) * od].iter().copied()).collect();
            let mut v = vec![0.0f32; timed_out.len()];
            match (phase, &mut self.adversary) {
                (Phase::Adversary, Some(a)) => {
                    let mut view = Vec::new();
                    let adv_rows = a.sees(&rows, &mut view, |i| timed_out[i]);
                    a.agent.values(adv_rows, &mut v)
                }
                _ => self.policy.values(&rows, &mut v),
            }
            for (&e, &val) in timed_out.iter().zip(&v) {
                boot[e] = (gamma * val as f64) as f32;
            }
        }
        let rewards = self.env.rewards();
        let dones = self.env.dones();
        if phase.policy_learns() {
            let r = &mut self.policy_rollout;
            for e in 0..n {
                r.rewards[t * n + e] = rewards[e] + boot[e];
                r.dones[t * n + e] = dones[e];
            }
            r.std = self.policy.ac.std()?;
        } else if let (Some(a), Some(r)) = (&self.adversary, &mut self.adversary_rollout) {
            let pd = a.bounds.len();
            let cost = self.cfg.adversary.magnitude_cost;
            let p = &self.scratch.perturbation;
            for e in 0..n {
                let own = adversary::reward(rewards[e], &p[e * pd..(e + 1) * pd], &a.bounds, cost);
                r.rewards[t * n + e] = own + boot[e];
                r.dones[t * n + e] = dones[e];
            }
            r.std = a.agent.ac.std()?;
        }
        Ok(())
    }
}

/// `f` on a pool worker (see [`crate::nn::on_worker`]) for a single process; on the calling thread with several
/// ranks, because MPI is initialised `Funneled`: its calls (the update's gradient sums, the normaliser's all-gather)
/// must come from the main thread.
fn on_worker_if<R>(solo: bool, f: impl FnOnce() -> R) -> R {
    if solo {
        crate::nn::on_worker(f)
    } else {
        f()
    }
}
