//! A batch of envs seen through a change of its observations, for tests that need the cart-pole to look like
//! another task (more inputs, mirror-image pairs); it records the perturbations the trainer sets.

use std::sync::{Arc, Mutex};

use trainer::vec_env::EnvFailure;

type Result<T> = std::result::Result<T, EnvFailure>;
use trainer::vec_env::{EnvSnapshot, EpisodeStats, PerturbationChannel, VecEnv};
use trainer::{SignedPermutation, Symmetry};

/// Maps a batch of the inner env's observation rows to the rows the trainer sees.
pub type RowMap = Box<dyn Fn(&[f32]) -> Vec<f32> + Send>;

/// Every perturbation vector the trainer set, in order.
pub type Applied = Arc<Mutex<Vec<Vec<f32>>>>;

pub struct ObsView {
    inner: Box<dyn VecEnv>,
    map: RowMap,
    obs_dim: usize,
    obs: Vec<f32>,
    terminal: Vec<f32>,
    /// What the view says of the task's mirror and perturbations (not necessarily the inner env's).
    pub symmetry: Option<Symmetry>,
    pub channels: Vec<PerturbationChannel>,
    pub perturbation_mirror: Option<SignedPermutation>,
    pub applied: Applied,
}

impl ObsView {
    /// `inner` seen through `map`, rows of `obs_dim`; no symmetry and no perturbations until set.
    pub fn new(inner: Box<dyn VecEnv>, obs_dim: usize, map: RowMap) -> Self {
        let mut v = ObsView {
            inner,
            map,
            obs_dim,
            obs: vec![],
            terminal: vec![],
            symmetry: None,
            channels: vec![],
            perturbation_mirror: None,
            applied: Applied::default(),
        };
        v.refresh();
        v
    }
    pub fn inner(&self) -> &dyn VecEnv {
        self.inner.as_ref()
    }
    fn refresh(&mut self) {
        self.obs = (self.map)(self.inner.obs());
        self.terminal = (self.map)(self.inner.terminal_obs());
    }
}

impl VecEnv for ObsView {
    fn num_envs(&self) -> usize {
        self.inner.num_envs()
    }
    fn obs_dim(&self) -> usize {
        self.obs_dim
    }
    fn action_dim(&self) -> usize {
        self.inner.action_dim()
    }
    fn reset(&mut self) -> Result<()> {
        self.inner.reset()?;
        self.refresh();
        Ok(())
    }
    fn step(&mut self, actions: &[f32]) -> Result<()> {
        self.inner.step(actions)?;
        self.refresh();
        Ok(())
    }
    fn obs(&self) -> &[f32] {
        &self.obs
    }
    fn rewards(&self) -> &[f32] {
        self.inner.rewards()
    }
    fn dones(&self) -> &[f32] {
        self.inner.dones()
    }
    fn time_outs(&self) -> &[f32] {
        self.inner.time_outs()
    }
    fn terminal_obs(&self) -> &[f32] {
        &self.terminal
    }
    fn term_names(&self) -> Vec<String> {
        self.inner.term_names()
    }
    fn take_episode_stats(&mut self) -> EpisodeStats {
        self.inner.take_episode_stats()
    }
    fn symmetry(&self) -> Option<Symmetry> {
        self.symmetry.clone()
    }
    fn perturbation_channels(&self) -> Vec<PerturbationChannel> {
        self.channels.clone()
    }
    fn perturbation_mirror(&self) -> Option<SignedPermutation> {
        self.perturbation_mirror.clone()
    }
    fn set_perturbations(&mut self, p: &[f32]) -> Result<()> {
        self.applied.lock().unwrap().push(p.to_vec());
        self.inner.set_perturbations(p)
    }
    fn save_state(&self) -> EnvSnapshot {
        self.inner.save_state()
    }
    fn load_state(&mut self, s: &EnvSnapshot) -> Result<()> {
        self.inner.load_state(s)
    }
}
