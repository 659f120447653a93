//! `BatchEnv`: N tasks stepped in parallel on a rayon pool with auto-reset, flat f32 buffers and no allocation
//! per step — the learner's `VecEnv` for any `Task`. Each task owns its random stream, so the result of a seed
//! does not depend on the thread count. And the constructors of a batch of envs of the robot a config names.

use std::sync::Arc;
use std::time::Instant;

use rayon::prelude::*;
use trainer::vec_env::{
    perturbation_dim, EnvFailure, EnvSnapshot, EpisodeStats, PerturbationChannel, StepTiming, VecEnv,
};
use trainer::{SignedPermutation, Symmetry};

use crate::error::{EnvError, Result};
use crate::task::Task;
use mujoco::Model;

use crate::assets::load_robot;
use crate::config::{EnvConfig, TaskKind};
use crate::env::RobotEnv;
use crate::indices::RobotIndices;
use crate::spec::RobotSpec;

/// Per-env running episode sums.
#[derive(Debug, Clone, Default)]
struct Episode {
    ret: f64,
    len: usize,
    terms: Vec<f64>,
}

/// What finished, collected per step without allocation.
#[derive(Debug, Clone, Default)]
struct Finished {
    episodes: usize,
    time_outs: usize,
    ret: f64,
    len: f64,
    terms: Vec<f64>,
    diverged: usize,
}

pub struct BatchEnv<T: Task> {
    tasks: Vec<T>,
    episodes: Vec<Episode>,
    obs: Vec<f32>,
    terminal_obs: Vec<f32>,
    rewards: Vec<f32>,
    dones: Vec<f32>,
    time_outs: Vec<f32>,
    /// Per-env flags set during a step (episode ended, and how), reduced afterwards.
    ended: Vec<(bool, bool, bool)>,
    /// Per-env (step, physics, reset) nanoseconds of the last step, reduced afterwards.
    times: Vec<[u64; 3]>,
    timing: StepTiming,
    finished: Finished,
    pool: Option<rayon::ThreadPool>,
    obs_dim: usize,
    act_dim: usize,
    reset_errors: Vec<Option<EnvError>>,
    /// Envs left out of `step` (their state, observation and episode stand still), e.g. an evaluation's finished runs.
    parked: Vec<bool>,
}

impl<T: Task> BatchEnv<T> {
    /// A batch of `tasks`, stepped on a pool of `threads` (0 = rayon's global pool).
    pub fn new(tasks: Vec<T>, threads: usize) -> Result<Self> {
        let first = tasks.first().ok_or_else(|| EnvError::Config("a batch needs at least one env".into()))?;
        let (obs_dim, act_dim, nterms) = (first.obs_dim(), first.action_dim(), first.term_names().len());
        let n = tasks.len();
        let pool = if threads == 0 {
            None
        } else {
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .map_err(|e| EnvError::Config(format!("thread pool: {e}")))?,
            )
        };
        Ok(BatchEnv {
            tasks,
            episodes: vec![Episode { terms: vec![0.0; nterms], ..Default::default() }; n],
            obs: vec![0.0; n * obs_dim],
            terminal_obs: vec![0.0; n * obs_dim],
            rewards: vec![0.0; n],
            dones: vec![0.0; n],
            time_outs: vec![0.0; n],
            ended: vec![(false, false, false); n],
            times: vec![[0; 3]; n],
            timing: StepTiming::default(),
            finished: Finished { terms: vec![0.0; nterms], ..Default::default() },
            pool,
            obs_dim,
            act_dim,
            reset_errors: (0..n).map(|_| None).collect(),
            parked: vec![false; n],
        })
    }

    pub fn tasks(&self) -> &[T] {
        &self.tasks
    }
    /// Env `i` with its observation row, e.g. to reset it somewhere of the caller's choosing.
    pub fn env_mut(&mut self, i: usize) -> (&mut T, &mut [f32]) {
        let d = self.obs_dim;
        (&mut self.tasks[i], &mut self.obs[i * d..(i + 1) * d])
    }
    pub fn tasks_mut(&mut self) -> &mut [T] {
        &mut self.tasks
    }
    /// Leaves env `i` out of the following steps (or takes it back): an evaluation's finished run then costs nothing
    /// while the others go on, and their results do not change (envs are independent).
    pub fn set_parked(&mut self, i: usize, parked: bool) {
        self.parked[i] = parked;
    }
}

impl<T: Task> VecEnv for BatchEnv<T> {
    fn num_envs(&self) -> usize {
        self.tasks.len()
    }
    fn obs_dim(&self) -> usize {
        self.obs_dim
    }
    fn action_dim(&self) -> usize {
        self.act_dim
    }

    fn reset(&mut self) -> std::result::Result<(), EnvFailure> {
        let od = self.obs_dim;
        let (tasks, obs, episodes) = (&mut self.tasks, &mut self.obs, &mut self.episodes);
        let run = || {
            tasks.par_iter_mut().zip(obs.par_chunks_mut(od)).zip(episodes.par_iter_mut()).try_for_each(|((t, o), e)| {
                e.ret = 0.0;
                e.len = 0;
                e.terms.iter_mut().for_each(|x| *x = 0.0);
                t.reset(o)
            })
        };
        Ok(run_on(&self.pool, run)?)
    }

    fn step(&mut self, actions: &[f32]) -> std::result::Result<(), EnvFailure> {
        let (n, od, ad) = (self.tasks.len(), self.obs_dim, self.act_dim);
        if actions.len() != n * ad {
            return Err(
                EnvError::Shape(format!("actions hold {} values, expected {n} envs × {ad}", actions.len())).into()
            );
        }
        let start = Instant::now();
        let BatchEnv {
            tasks,
            episodes,
            obs,
            terminal_obs,
            rewards,
            dones,
            time_outs,
            ended,
            times,
            reset_errors,
            parked,
            pool,
            ..
        } = self;
        let work = || {
            tasks
                .par_iter_mut()
                .zip(actions.par_chunks(ad))
                .zip(obs.par_chunks_mut(od))
                .zip(terminal_obs.par_chunks_mut(od))
                .zip(episodes.par_iter_mut())
                .zip(rewards.par_iter_mut())
                .zip(dones.par_iter_mut())
                .zip(time_outs.par_iter_mut())
                .zip(ended.par_iter_mut())
                .zip(times.par_iter_mut())
                .zip(reset_errors.par_iter_mut())
                .zip(parked.par_iter())
                .for_each(|(((((((((((t, a), o), term), e), r), d), to), end), tm), err), &park)| {
                    if park {
                        (*r, *d, *to, *end, *tm) = (0.0, 0.0, 0.0, (false, false, false), [0; 3]);
                        return;
                    }
                    let t0 = Instant::now();
                    let out = t.step(a, o);
                    let t1 = Instant::now();
                    if let Some(x) = t.take_fatal() {
                        *err = Some(x);
                    }
                    e.ret += out.reward;
                    e.len += 1;
                    for (sum, v) in e.terms.iter_mut().zip(t.terms()) {
                        *sum += v;
                    }
                    *r = out.reward as f32;
                    *d = if out.done { 1.0 } else { 0.0 };
                    *to = if out.time_out && !out.diverged { 1.0 } else { 0.0 };
                    *end = (out.done, out.time_out && !out.diverged, out.diverged);
                    let mut reset_ns = 0;
                    if out.done {
                        term.copy_from_slice(o);
                        if let Err(x) = t.reset(o) {
                            *err = Some(x);
                        }
                        reset_ns = t1.elapsed().as_nanos() as u64;
                    }
                    *tm = [(t1 - t0).as_nanos() as u64, t.take_physics_ns(), reset_ns];
                })
        };
        run_on(pool, work);
        let tm = &mut self.timing;
        tm.steps += 1;
        tm.wall_s += start.elapsed().as_secs_f64();
        let sum = self.times.iter().fold([0u64; 3], |a, t| [a[0] + t[0], a[1] + t[1], a[2] + t[2]]);
        tm.task_s += (sum[0] + sum[2]) as f64 * 1e-9;
        tm.physics_s += sum[1] as f64 * 1e-9;
        tm.reset_s += sum[2] as f64 * 1e-9;
        Ok(self.collect_finished()?)
    }

    fn obs(&self) -> &[f32] {
        &self.obs
    }
    fn rewards(&self) -> &[f32] {
        &self.rewards
    }
    fn dones(&self) -> &[f32] {
        &self.dones
    }
    fn time_outs(&self) -> &[f32] {
        &self.time_outs
    }
    fn terminal_obs(&self) -> &[f32] {
        &self.terminal_obs
    }
    fn term_names(&self) -> Vec<String> {
        self.tasks[0].term_names().iter().map(|s| s.to_string()).collect()
    }

    fn take_episode_stats(&mut self) -> EpisodeStats {
        let f = std::mem::replace(
            &mut self.finished,
            Finished { terms: vec![0.0; self.tasks[0].term_names().len()], ..Default::default() },
        );
        let k = f.episodes.max(1) as f64;
        EpisodeStats {
            episodes: f.episodes,
            mean_return: f.ret / k,
            mean_length: f.len / k,
            time_out_share: f.time_outs as f64 / k,
            mean_terms: f.terms.iter().map(|t| t / k).collect(),
            diverged: f.diverged,
            curriculum_level: mean_level(&self.tasks),
        }
    }

    fn symmetry(&self) -> Option<Symmetry> {
        self.tasks[0].symmetry()
    }
    fn actor_view(&self) -> trainer::actor_view::ActorView {
        self.tasks[0].actor_view()
    }
    fn perturbation_channels(&self) -> Vec<PerturbationChannel> {
        self.tasks[0].perturbation_channels()
    }
    fn perturbation_mirror(&self) -> Option<SignedPermutation> {
        self.tasks[0].perturbation_mirror()
    }
    fn set_perturbations(&mut self, p: &[f32]) -> std::result::Result<(), EnvFailure> {
        let pd = perturbation_dim(&self.perturbation_channels());
        if pd == 0 || p.len() != pd * self.tasks.len() {
            return Err(EnvError::Shape(format!(
                "perturbations hold {} values, expected {} envs × {pd}",
                p.len(),
                self.tasks.len()
            ))
            .into());
        }
        for (t, row) in self.tasks.iter_mut().zip(p.chunks_exact(pd)) {
            t.set_perturbation(row);
        }
        Ok(())
    }

    fn save_state(&self) -> EnvSnapshot {
        let mut s = EnvSnapshot { obs: self.obs.clone(), ..Default::default() };
        for (i, t) in self.tasks.iter().enumerate() {
            let (f0, u0) = (s.f64s.len(), s.u64s.len());
            t.save_state(&mut s.f64s, &mut s.u64s);
            let e = &self.episodes[i];
            s.f64s.push(e.ret);
            s.f64s.extend_from_slice(&e.terms);
            s.u64s.push(e.len as u64);
            if i == 0 {
                s.f64_width = s.f64s.len() - f0;
                s.u64_width = s.u64s.len() - u0;
            }
        }
        s
    }

    fn take_step_timing(&mut self) -> StepTiming {
        std::mem::take(&mut self.timing)
    }

    fn load_state(&mut self, s: &EnvSnapshot) -> std::result::Result<(), EnvFailure> {
        let n = self.tasks.len();
        if s.obs.len() != self.obs.len() || s.f64s.len() != n * s.f64_width || s.u64s.len() != n * s.u64_width {
            return Err(EnvError::Shape(format!(
                "env snapshot is for a different batch ({} observations for {n} envs × {})",
                s.obs.len() / self.obs_dim.max(1),
                self.obs_dim
            ))
            .into());
        }
        let nterms = self.tasks[0].term_names().len();
        for (i, t) in self.tasks.iter_mut().enumerate() {
            let f = &s.f64s[i * s.f64_width..(i + 1) * s.f64_width];
            let u = &s.u64s[i * s.u64_width..(i + 1) * s.u64_width];
            // Each row: the task's own values, then its episode's return and reward terms (length, in u64s).
            let (Some(task_f), Some(task_u)) = (f.len().checked_sub(1 + nterms), u.len().checked_sub(1)) else {
                return Err(EnvError::Shape("env snapshot rows have the wrong width for this task".into()).into());
            };
            let (fi, ui) = t.load_state(&f[..task_f], &u[..task_u])?;
            if fi != task_f || ui != task_u {
                return Err(EnvError::Shape("env snapshot rows have the wrong width for this task".into()).into());
            }
            let e = &mut self.episodes[i];
            e.ret = f[fi];
            e.terms.copy_from_slice(&f[fi + 1..]);
            e.len = u[ui] as usize;
        }
        self.obs.copy_from_slice(&s.obs);
        Ok(())
    }
}

/// Runs `f` on the batch's own pool, or on rayon's global pool.
fn run_on<R: Send>(pool: &Option<rayon::ThreadPool>, f: impl FnOnce() -> R + Send) -> R {
    match pool {
        Some(p) => p.install(f),
        None => f(),
    }
}

impl<T: Task> BatchEnv<T> {
    /// Folds the per-env end flags into the statistics and surfaces reset errors (after the parallel part).
    fn collect_finished(&mut self) -> Result<()> {
        for i in 0..self.tasks.len() {
            let (done, time_out, diverged) = self.ended[i];
            if let Some(e) = self.reset_errors[i].take() {
                return Err(e);
            }
            if !done {
                continue;
            }
            let e = &mut self.episodes[i];
            if diverged {
                self.finished.diverged += 1;
            } else {
                self.finished.episodes += 1;
                self.finished.time_outs += time_out as usize;
                self.finished.ret += e.ret;
                self.finished.len += e.len as f64;
                for (sum, v) in self.finished.terms.iter_mut().zip(&e.terms) {
                    *sum += v;
                }
            }
            e.ret = 0.0;
            e.len = 0;
            e.terms.iter_mut().for_each(|x| *x = 0.0);
        }
        Ok(())
    }
}

/// The tasks' mean curriculum level, if they have one.
fn mean_level<T: Task>(tasks: &[T]) -> Option<f64> {
    let levels: Vec<f64> = tasks.iter().filter_map(|t| t.curriculum_level()).collect();
    (!levels.is_empty()).then(|| levels.iter().sum::<f64>() / levels.len() as f64)
}

/// The batched envs of a task's config, the robot's or the cart-pole's: envs `first`, `first + 1`, … of a run
/// seeded `seed` (`first` = 0 for a whole run, `rank · n` for one MPI rank's share, so a seed names the same env
/// streams whatever the rank layout), stepped on `threads` threads (0 = rayon's global pool).
pub fn task_batch(cfg: &EnvConfig, first: u64, n: usize, seed: u64, threads: usize) -> Result<Box<dyn VecEnv>> {
    Ok(match cfg.task {
        TaskKind::Robot => {
            let (spec, model) = load_robot(cfg)?;
            Box::new(robot_batch_from(model, &spec, cfg, first, n, seed, threads)?)
        }
        TaskKind::Cartpole => {
            let model = crate::tasks::cartpole::model()?;
            let bound = cfg.adversary.generic_bound;
            let tasks = (0..n as u64)
                .map(|i| crate::tasks::CartPole::new(model.clone(), seed, first + i, CARTPOLE_STEPS, bound))
                .collect::<Result<Vec<_>>>()?;
            Box::new(BatchEnv::new(tasks, threads)?)
        }
    })
}

/// The cart-pole's episode length, steps: long enough that a balancing policy is told apart from a falling one.
pub const CARTPOLE_STEPS: usize = 200;

/// `n` envs of the robot `cfg.robot` names, env `i` seeded with (`seed`, stream `i`), stepped on `threads`
/// threads (0 = rayon's global pool). The model is compiled once and checked against the spec once.
pub fn robot_batch(cfg: &EnvConfig, n: usize, seed: u64, threads: usize) -> Result<BatchEnv<RobotEnv>> {
    let (spec, model) = load_robot(cfg)?;
    robot_batch_from(model, &spec, cfg, 0, n, seed, threads)
}

/// As `robot_batch`, on an already loaded model of the robot (e.g. a variant of its MJCF).
pub fn robot_batch_on(
    model: Arc<Model>,
    cfg: &EnvConfig,
    n: usize,
    seed: u64,
    threads: usize,
) -> Result<BatchEnv<RobotEnv>> {
    let (spec, _) = load_robot(cfg)?;
    robot_batch_from(model, &spec, cfg, 0, n, seed, threads)
}

/// `n` envs seeded as envs `first`, `first + 1`, … of a larger batch (one MPI rank's share of a run).
pub fn robot_batch_from(
    model: Arc<Model>,
    spec: &Arc<RobotSpec>,
    cfg: &EnvConfig,
    first: u64,
    n: usize,
    seed: u64,
    threads: usize,
) -> Result<BatchEnv<RobotEnv>> {
    cfg.validate()?;
    // Configure the model once, so the envs share it until randomisation copies it.
    let mut model = model;
    crate::env::configure_model(&mut model, cfg)?;
    let cfg = Arc::new(cfg.clone());
    let idx = Arc::new(RobotIndices::resolve(&model, spec)?);
    let envs = (0..n)
        .map(|i| RobotEnv::with_indices(model.clone(), cfg.clone(), idx.clone(), seed, first + i as u64))
        .collect::<Result<Vec<_>>>()?;
    BatchEnv::new(envs, threads)
}
