//! `adversary.mirror_attacks`: the odd envs are attacked through the mirror, so robots that are each other's mirror
//! image meet attacks that are each other's mirror image; a task without the mirror is refused.

mod common;

use std::sync::{Arc, Mutex};

use anyhow::Result;
use common::{cartpole_config, cartpole_trainer, set_push_bound};
use trainer::config::TrainConfig;
use trainer::vec_env::{EnvSnapshot, EpisodeStats, PerturbationChannel, VecEnv};
use trainer::{SignedPermutation, Symmetry, Trainer};

/// Every perturbation vector the trainer set, in order.
type Applied = Arc<Mutex<Vec<Vec<f32>>>>;

/// The cart-pole batch seen in pairs: each odd env observes the mirror image of the env before it (both its
/// current and its terminal observation). Records every perturbation the trainer sets.
struct MirrorPairs {
    inner: Box<dyn VecEnv>,
    sym: Symmetry,
    with_mirror: bool,
    obs: Vec<f32>,
    terminal: Vec<f32>,
    applied: Applied,
}

impl MirrorPairs {
    fn paired(&self, src: &[f32]) -> Vec<f32> {
        let d = self.sym.obs.len();
        let mut out = src.to_vec();
        for pair in out.chunks_exact_mut(2 * d) {
            let (even, odd) = pair.split_at_mut(d);
            self.sym.obs.apply(even, odd);
        }
        out
    }
    fn refresh(&mut self) {
        self.obs = self.paired(self.inner.obs());
        self.terminal = self.paired(self.inner.terminal_obs());
    }
}

impl VecEnv for MirrorPairs {
    fn num_envs(&self) -> usize {
        self.inner.num_envs()
    }
    fn obs_dim(&self) -> usize {
        self.inner.obs_dim()
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
        Some(self.sym.clone())
    }
    fn perturbation_channels(&self) -> Vec<PerturbationChannel> {
        self.inner.perturbation_channels()
    }
    fn perturbation_mirror(&self) -> Option<SignedPermutation> {
        self.inner.perturbation_mirror().filter(|_| self.with_mirror)
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

/// One cycle of one iteration per phase; phase 3 attacks every env with the adversary's mean (deterministic).
fn config(mirror_attacks: bool) -> TrainConfig {
    let mut c = cartpole_config(3, 3);
    let a = &mut c.adversary;
    (a.phase1_policy_iters, a.phase2_adversary_iters, a.phase3_policy_iters, a.cycles) = (1, 1, 1, 1);
    a.hidden = vec![32, 32];
    (a.sample_when_frozen, a.attack_share, a.mirror_attacks) = (false, 1.0, mirror_attacks);
    set_push_bound(&mut c, 1.5);
    c
}

fn paired_trainer(cfg: &TrainConfig, with_mirror: bool) -> Result<(Trainer, Applied)> {
    let inner = cartpole_trainer(cfg, false).env;
    let applied = Arc::new(Mutex::new(Vec::new()));
    let mut env = MirrorPairs {
        sym: inner.symmetry().unwrap(),
        inner,
        with_mirror,
        obs: vec![],
        terminal: vec![],
        applied: applied.clone(),
    };
    env.refresh();
    Ok((Trainer::new(cfg.clone(), Box::new(env), true)?, applied))
}

/// Phase 3's perturbations (the last rollout's), as (even env, odd env) pairs, one per pair of envs and step.
fn phase3_pairs(cfg: &TrainConfig) -> Vec<(f32, f32)> {
    let (mut t, applied) = paired_trainer(cfg, true).unwrap();
    while t.iterate().unwrap().is_some() {}
    let applied = applied.lock().unwrap();
    let steps = cfg.run.steps_per_env;
    assert!(applied.len() >= steps);
    applied[applied.len() - steps..].iter().flat_map(|p| p.chunks_exact(2).map(|c| (c[0], c[1]))).collect()
}

#[test]
fn mirror_image_robots_meet_mirror_image_attacks() {
    let pairs = phase3_pairs(&config(true));
    assert!(pairs.iter().all(|&(even, _)| even != 0.0), "the adversary attacks every env");
    for (even, odd) in &pairs {
        assert_eq!(*odd, -*even, "the mirror image of a push on the pole is the opposite push");
    }
    // Without the mirror the adversary answers the mirror image with whatever it learned for it.
    let pairs = phase3_pairs(&config(false));
    assert!(pairs.iter().any(|&(even, odd)| odd != -even), "an unmirrored adversary happened to be odd");
}

#[test]
fn mirrored_attacks_need_the_tasks_perturbation_mirror() {
    let err = paired_trainer(&config(true), false).err().expect("refused").to_string();
    assert!(err.contains("mirror_attacks") && err.contains("set it to false"), "{err}");
    assert!(paired_trainer(&config(false), false).is_ok(), "no mirror needed without mirrored attacks");
}
