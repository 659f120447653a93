//! What the learner needs from an environment, and nothing about any robot (as rsl_rl's `VecEnv`): a batch of
//! envs stepped together, episode statistics, a complete snapshot to resume from, the task's mirror maps, and
//! the channels an adversary may perturb with their bounds and log names.

pub use crate::error::EnvFailure;

use crate::actor_view::ActorView;
use crate::symmetry::{SignedPermutation, Symmetry};

/// Statistics of the episodes that ended since the last `take_episode_stats`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EpisodeStats {
    pub episodes: usize,
    pub mean_return: f64,
    pub mean_length: f64,
    /// Share of finished episodes that ended by time-out (not a fall).
    pub time_out_share: f64,
    /// Mean episode sum of each reward term, in `term_names` order.
    pub mean_terms: Vec<f64>,
    /// Envs reset because their simulation failed or blew up.
    pub diverged: usize,
    /// Mean curriculum level over the envs now (e.g. the terrain row), when the task has a curriculum.
    pub curriculum_level: Option<f64>,
}

/// Where the time of `step` went since the last `take_step_timing` (for `topa bench train`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepTiming {
    /// Calls of `step`.
    pub steps: u64,
    /// Wall time of `step`, s.
    pub wall_s: f64,
    /// Summed over envs (CPU time on the workers): stepping the tasks, of which physics, and resetting them, s.
    pub task_s: f64,
    pub physics_s: f64,
    pub reset_s: f64,
}

/// A batch's state: per-env f64 and u64 rows of fixed width, plus the observation buffer.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EnvSnapshot {
    pub f64_width: usize,
    pub f64s: Vec<f64>,
    pub u64_width: usize,
    pub u64s: Vec<u64>,
    pub obs: Vec<f32>,
}

/// One block of the adversary's perturbation vector: a name for logs, the bound of each value (the adversary's
/// tanh output is scaled by it), and the size of the groups whose Euclidean norms are logged (e.g. 3 for a
/// force; the logged magnitude is the mean norm over the channel's groups).
#[derive(Debug, Clone, PartialEq)]
pub struct PerturbationChannel {
    pub name: String,
    pub bounds: Vec<f32>,
    pub group: usize,
}

impl PerturbationChannel {
    pub fn new(name: &str, bounds: Vec<f32>, group: usize) -> Self {
        PerturbationChannel { name: name.into(), bounds, group: group.max(1) }
    }
    pub fn dim(&self) -> usize {
        self.bounds.len()
    }
}

/// The total size of a set of channels.
pub fn perturbation_dim(channels: &[PerturbationChannel]) -> usize {
    channels.iter().map(PerturbationChannel::dim).sum()
}

pub trait VecEnv: Send {
    fn num_envs(&self) -> usize;
    fn obs_dim(&self) -> usize;
    fn action_dim(&self) -> usize;
    /// Resets every env.
    fn reset(&mut self) -> Result<(), EnvFailure>;
    /// One policy step for all envs (`actions`: num_envs × action_dim, row-major). Finished envs are reset: their
    /// row of `obs` is the new episode's first observation, and `terminal_obs` holds the last one.
    fn step(&mut self, actions: &[f32]) -> Result<(), EnvFailure>;
    fn obs(&self) -> &[f32];
    fn rewards(&self) -> &[f32];
    /// 1.0 where the episode ended this step.
    fn dones(&self) -> &[f32];
    /// 1.0 where it ended by time-out only.
    fn time_outs(&self) -> &[f32];
    /// The final observation of episodes that ended this step (rows where `dones` is 1; others stale).
    fn terminal_obs(&self) -> &[f32];
    fn term_names(&self) -> Vec<String>;
    fn take_episode_stats(&mut self) -> EpisodeStats;
    fn symmetry(&self) -> Option<Symmetry>;
    /// What the actor reads of the observation row: all of it (the default), or its first values and the
    /// estimate of privileged columns that close it (an asymmetric actor–critic with a concurrent estimator).
    fn actor_view(&self) -> ActorView {
        ActorView::whole(self.obs_dim())
    }
    /// What an adversary may perturb, in the order of the perturbation vector (empty: nothing).
    fn perturbation_channels(&self) -> Vec<PerturbationChannel>;
    /// Sets every env's perturbation (num_envs × the channels' total size).
    fn set_perturbations(&mut self, p: &[f32]) -> Result<(), EnvFailure>;
    /// The left↔right mirror of a perturbation vector, matching `symmetry`'s mirror of the observation: the
    /// perturbation of the mirror-image world (None: the task has none).
    fn perturbation_mirror(&self) -> Option<SignedPermutation> {
        None
    }
    /// The complete state of all envs (to resume bit for bit).
    fn save_state(&self) -> EnvSnapshot;
    fn load_state(&mut self, s: &EnvSnapshot) -> Result<(), EnvFailure>;
    /// Where `step`'s time went since the last call.
    fn take_step_timing(&mut self) -> StepTiming {
        StepTiming::default()
    }
}
