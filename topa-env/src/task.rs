//! The single-environment interface every task implements (TopA, and the tiny test tasks); `BatchEnv` turns any
//! `Task` into a parallel `VecEnv`.

use trainer::{PerturbationChannel, SignedPermutation, Symmetry};

use crate::error::Result;

/// What one step did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepOutcome {
    pub reward: f64,
    /// The episode ended (fall, time-out or divergence).
    pub done: bool,
    /// It ended only because time ran out (bootstrap the value).
    pub time_out: bool,
    /// The simulation failed or blew up; the batch resets the task and counts it.
    pub diverged: bool,
}

pub trait Task: Send {
    fn obs_dim(&self) -> usize;
    fn action_dim(&self) -> usize;
    /// Starts a new episode and writes its first observation.
    fn reset(&mut self, obs: &mut [f32]) -> Result<()>;
    /// Applies `action`, advances one policy step, writes the next observation.
    fn step(&mut self, action: &[f32], obs: &mut [f32]) -> StepOutcome;
    /// Names of the reward terms, in the order of `terms`.
    fn term_names(&self) -> &'static [&'static str];
    /// The last step's weighted reward terms (they sum to its reward).
    fn terms(&self) -> &[f64];
    /// The left↔right mirror of observations and actions, if the task has one.
    fn symmetry(&self) -> Option<Symmetry>;
    /// What the learner's actor reads of the observation row (default: all of it).
    fn actor_view(&self) -> trainer::actor_view::ActorView {
        trainer::actor_view::ActorView::whole(self.obs_dim())
    }
    /// What an adversary may perturb (empty: nothing), in the order of the perturbation vector.
    fn perturbation_channels(&self) -> Vec<PerturbationChannel> {
        Vec::new()
    }
    /// Sets the adversary's perturbation (the channels' values, in order), held until changed.
    fn set_perturbation(&mut self, _p: &[f32]) {}
    /// The perturbation's left↔right mirror, the one `symmetry` applies to the world (None: none).
    fn perturbation_mirror(&self) -> Option<SignedPermutation> {
        None
    }
    /// Appends the task's complete state (to continue bit for bit after a restore).
    fn save_state(&self, f64s: &mut Vec<f64>, u64s: &mut Vec<u64>);
    /// Restores what `save_state` wrote; returns how many of each it consumed.
    fn load_state(&mut self, f64s: &[f64], u64s: &[u64]) -> Result<(usize, usize)>;
    /// An error that must stop the run rather than reset the env (a model too small for the simulation), raised
    /// during the last `step`.
    fn take_fatal(&mut self) -> Option<crate::error::EnvError> {
        None
    }
    /// Nanoseconds spent inside the physics engine since the last call (0 if the task does not measure it).
    fn take_physics_ns(&mut self) -> u64 {
        0
    }
    /// Where a curriculum has put this task (e.g. the terrain row), if the task has one.
    fn curriculum_level(&self) -> Option<f64> {
        None
    }
}

pub use trainer::rng::{load_rng, save_rng, RNG_WORDS};
