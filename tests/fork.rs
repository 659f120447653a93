//! `--init-from` into a task with more inputs (a height scan added to a blind policy): the forked policy acts
//! exactly as its source whatever the new inputs hold, then learns to use them; sizes that do not add up are refused.

mod common;

use anyhow::Result;
use common::{cartpole_config, cartpole_trainer};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use trainer::checkpoint;
use trainer::ppo::ActOutput;
use trainer::vec_env::{EnvSnapshot, EpisodeStats, PerturbationChannel, VecEnv};
use trainer::{symmetry::Symmetry, Trainer};

/// The cart-pole with `extra` more observation values after its own, which reveal the pole's angular velocity
/// again (so that a policy has something to learn from them).
struct Widened {
    inner: Box<dyn VecEnv>,
    extra: usize,
    obs: Vec<f32>,
    terminal: Vec<f32>,
}

impl Widened {
    fn new(inner: Box<dyn VecEnv>, extra: usize) -> Self {
        let mut w = Widened { inner, extra, obs: vec![], terminal: vec![] };
        w.refresh();
        w
    }
    fn widen(src: &[f32], d: usize, extra: usize) -> Vec<f32> {
        src.chunks_exact(d).flat_map(|r| r.iter().copied().chain(std::iter::repeat_n(r[d - 1], extra))).collect()
    }
    fn refresh(&mut self) {
        let d = self.inner.obs_dim();
        self.obs = Self::widen(self.inner.obs(), d, self.extra);
        self.terminal = Self::widen(self.inner.terminal_obs(), d, self.extra);
    }
}

impl VecEnv for Widened {
    fn num_envs(&self) -> usize {
        self.inner.num_envs()
    }
    fn obs_dim(&self) -> usize {
        self.inner.obs_dim() + self.extra
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
        None
    }
    fn perturbation_channels(&self) -> Vec<PerturbationChannel> {
        vec![]
    }
    fn set_perturbations(&mut self, p: &[f32]) -> Result<()> {
        self.inner.set_perturbations(p)
    }
    fn save_state(&self) -> EnvSnapshot {
        self.inner.save_state()
    }
    fn load_state(&mut self, s: &EnvSnapshot) -> Result<()> {
        self.inner.load_state(s)
    }
}

fn first_layer(t: &Trainer) -> Vec<f32> {
    t.policy.ac.actor.layers[0].weight.as_tensor().flatten_all().unwrap().to_vec1::<f32>().unwrap()
}

#[test]
fn a_policy_forked_with_added_inputs_acts_as_its_source_then_learns_them() {
    const EXTRA: usize = 3;
    let cfg = cartpole_config(5, 30);
    let mut source = cartpole_trainer(&cfg, false);
    for _ in 0..3 {
        source.iterate().unwrap();
    }
    let dir = std::env::temp_dir().join(format!("topa-fork-widen-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    checkpoint::save(&source, &dir, "test", 0).unwrap();
    let (side, loaded) = checkpoint::read_sidecar(&checkpoint::latest(&dir).unwrap()).unwrap();

    let mut forked =
        Trainer::new(cfg.clone(), Box::new(Widened::new(cartpole_trainer(&cfg, false).env, EXTRA)), false).unwrap();
    let err = checkpoint::init_policy_from(&mut forked, &side, &loaded, 0).unwrap_err().to_string();
    assert!(err.contains("4→1") && err.contains("7→1"), "{err}");
    checkpoint::init_policy_from(&mut forked, &side, &loaded, EXTRA).unwrap();
    let (d, n) = (4, 64);

    // The same actions and values on any observation, whatever the added inputs hold.
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let obs: Vec<f32> = (0..n * d).map(|_| rng.random_range(-2.0..2.0)).collect();
    let wide: Vec<f32> = obs
        .chunks_exact(d)
        .flat_map(|r| r.iter().copied().chain((0..EXTRA).map(|_| rng.random_range(-50.0f32..50.0))).collect::<Vec<_>>())
        .collect();
    let act = |t: &mut Trainer, o: &[f32]| -> (Vec<f32>, Vec<f32>) {
        t.policy.normalizer.frozen = true;
        let (mut norm, mut a, mut m, mut lp, mut v) =
            (vec![0.0; o.len()], vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let out = ActOutput { obs_norm: &mut norm, actions: &mut a, means: &mut m, log_probs: &mut lp, values: &mut v };
        t.policy.act(o, &mut ChaCha8Rng::seed_from_u64(1), false, out).unwrap();
        t.policy.normalizer.frozen = false;
        (m, v)
    };
    let (ms, vs) = act(&mut source, &obs);
    let (mf, vf) = act(&mut forked, &wide);
    for (a, b) in ms.iter().zip(&mf).chain(vs.iter().zip(&vf)) {
        assert!((a - b).abs() <= 1e-5 * (1.0 + a.abs()), "source {a} vs forked {b}");
    }
    assert_eq!(forked.iteration, source.iteration);
    let w = first_layer(&forked);
    assert!(w.chunks_exact(d + EXTRA).all(|r| r[d..].iter().all(|&x| x == 0.0)), "added columns start at zero");

    // Training moves the added inputs' weights and statistics (they copy the pole's angular velocity).
    for _ in 0..5 {
        forked.iterate().unwrap();
    }
    let w = first_layer(&forked);
    assert!(w.chunks_exact(d + EXTRA).any(|r| r[d..].iter().any(|&x| x != 0.0)), "added columns still zero");
    let norm = &forked.policy.normalizer;
    let var = |i: usize| norm.m2[i] / norm.count;
    let real = var(d - 1);
    for k in 0..EXTRA {
        assert!((norm.mean[d + k] - norm.mean[d - 1]).abs() < 0.5 * real.sqrt(), "mean of added input {k}");
        // From the prior (variance 1) most of the way to the input it copies.
        assert!((var(d + k) - real).abs() < 0.3 * (1.0 - real).abs(), "variance {} against {real}", var(d + k));
    }
    std::fs::remove_dir_all(dir).ok();
}
