//! Cart-pole balance on MuJoCo: observation (x, θ, ẋ, θ̇), action a force in [−1, 1] × 10 N, reward 1 per step
//! alive; the episode ends when |θ| > 0.2 rad or |x| > 2.4 m, or after `max_steps`. A random policy survives a
//! couple of dozen steps; a trained one the whole episode. Mirror symmetry x → −x negates everything.

use std::sync::Arc;

use mujoco::{Data, Model, ObjType};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{EnvError, Result};
use crate::symmetry::{SignedPermutation, Symmetry};
use crate::task::{self, StepOutcome, Task};

const XML: &str = include_str!("../../../assets/mjcf/cartpole.xml");
const TERMS: [&str; 1] = ["alive"];

/// Compiles the bundled cart-pole MJCF.
pub fn model() -> Result<Arc<Model>> {
    Ok(Arc::new(Model::from_xml_string(XML, std::env::temp_dir())?))
}

pub struct CartPole {
    data: Data,
    rng: ChaCha8Rng,
    slider: (usize, usize),
    hinge: (usize, usize),
    pole_body: usize,
    decimation: usize,
    max_steps: usize,
    steps: usize,
    terms: [f64; 1],
    /// Adversary's horizontal force on the pole, N, and its bound.
    push: f64,
    push_bound: f64,
}

impl CartPole {
    /// `max_steps` policy steps of 0.02 s per episode; an adversary may push the pole with up to `push_bound` N.
    pub fn new(model: Arc<Model>, seed: u64, index: u64, max_steps: usize, push_bound: f64) -> Result<Self> {
        let adr = |name: &str| -> Result<(usize, usize)> {
            let j = model.id(ObjType::Joint, name)?;
            Ok((model.jnt_qposadr_of(j), model.jnt_dofadr_of(j)))
        };
        let (slider, hinge) = (adr("slider")?, adr("hinge")?);
        let pole_body = model.id(ObjType::Body, "pole")?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(index);
        if max_steps == 0 {
            return Err(EnvError::Config("cart-pole max_steps must be at least 1".into()));
        }
        Ok(CartPole {
            data: Data::new(model)?,
            rng,
            slider,
            hinge,
            pole_body,
            decimation: 2,
            max_steps,
            steps: 0,
            terms: [0.0],
            push: 0.0,
            push_bound,
        })
    }

    fn write_obs(&self, obs: &mut [f32]) {
        let (q, v) = (self.data.qpos(), self.data.qvel());
        obs[0] = q[self.slider.0] as f32;
        obs[1] = q[self.hinge.0] as f32;
        obs[2] = v[self.slider.1] as f32;
        obs[3] = v[self.hinge.1] as f32;
    }
}

impl Task for CartPole {
    fn obs_dim(&self) -> usize {
        4
    }
    fn action_dim(&self) -> usize {
        1
    }
    fn reset(&mut self, obs: &mut [f32]) -> Result<()> {
        self.data.reset()?;
        for (q, d) in [(self.slider.0, self.slider.1), (self.hinge.0, self.hinge.1)] {
            self.data.qpos_mut()[q] = self.rng.random_range(-0.05..0.05);
            self.data.qvel_mut()[d] = self.rng.random_range(-0.05..0.05);
        }
        self.data.forward()?;
        self.steps = 0;
        self.write_obs(obs);
        Ok(())
    }
    fn step(&mut self, action: &[f32], obs: &mut [f32]) -> StepOutcome {
        let a = action[0] as f64;
        self.data.ctrl_mut()[0] = if a.is_finite() { a.clamp(-1.0, 1.0) } else { 0.0 };
        let push = self.push;
        let pole = self.pole_body;
        for _ in 0..self.decimation {
            self.data.xfrc_applied_mut()[pole][0] = push;
            if self.data.step().is_err() {
                return StepOutcome { reward: 0.0, done: true, time_out: false, diverged: true };
            }
        }
        if self.data.is_unstable() {
            return StepOutcome { reward: 0.0, done: true, time_out: false, diverged: true };
        }
        self.steps += 1;
        self.write_obs(obs);
        let fell = obs[1].abs() > 0.2 || obs[0].abs() > 2.4;
        let time_out = !fell && self.steps >= self.max_steps;
        self.terms = [1.0];
        StepOutcome { reward: 1.0, done: fell || time_out, time_out, diverged: false }
    }
    fn term_names(&self) -> &'static [&'static str] {
        &TERMS
    }
    fn terms(&self) -> &[f64] {
        &self.terms
    }
    fn symmetry(&self) -> Option<Symmetry> {
        Some(Symmetry {
            obs: SignedPermutation { perm: (0..4).collect(), sign: vec![-1.0; 4] },
            act: SignedPermutation { perm: vec![0], sign: vec![-1.0] },
        })
    }
    fn perturbation_channels(&self) -> Vec<trainer::PerturbationChannel> {
        vec![trainer::PerturbationChannel::new("push", vec![self.push_bound as f32], 1)]
    }
    fn set_perturbation(&mut self, p: &[f32]) {
        self.push = p[0] as f64;
    }
    fn perturbation_mirror(&self) -> Option<SignedPermutation> {
        Some(SignedPermutation { perm: vec![0], sign: vec![-1.0] })
    }
    fn save_state(&self, f: &mut Vec<f64>, u: &mut Vec<u64>) {
        self.data.save_state(f);
        f.push(self.push);
        u.push(self.steps as u64);
        task::save_rng(&self.rng, u);
    }
    fn load_state(&mut self, f: &[f64], u: &[u64]) -> Result<(usize, usize)> {
        let need = self.data.state_len() + 1;
        if f.len() < need || u.len() < 1 + task::RNG_WORDS {
            return Err(EnvError::Shape("cart-pole snapshot too short".into()));
        }
        let i = self.data.load_state(f)?;
        self.push = f[i];
        self.steps = u[0] as usize;
        self.rng = task::load_rng(&u[1..]);
        Ok((need, 1 + task::RNG_WORDS))
    }
}
