//! Rollout storage: `steps × envs` transitions in flat buffers, GAE(γ, λ) returns and normalised advantages.

/// What an agent did for one batch of observations: where it writes them (a rollout's step, or scratch rows).
pub struct ActOutput<'a> {
    pub obs_norm: &'a mut [f32],
    pub actions: &'a mut [f32],
    pub means: &'a mut [f32],
    pub log_probs: &'a mut [f32],
    pub values: &'a mut [f32],
    /// The concurrent estimator's outputs the actor read (rows × its size; empty without an estimator).
    pub estimates: &'a mut [f32],
}

#[derive(Debug, Clone, Default)]
pub struct Rollout {
    pub steps: usize,
    pub envs: usize,
    pub obs_dim: usize,
    pub act_dim: usize,
    /// Normalised observations the policy acted on.
    pub obs: Vec<f32>,
    pub actions: Vec<f32>,
    pub log_probs: Vec<f32>,
    pub values: Vec<f32>,
    /// Rewards, already including γ·V(terminal) on time-outs.
    pub rewards: Vec<f32>,
    pub dones: Vec<f32>,
    /// Action means at rollout time (for the KL of the adaptive learning rate).
    pub means: Vec<f32>,
    /// Values the concurrent estimator gave the actor, per transition (`est_dim` each; none without one).
    pub est_dim: usize,
    pub estimates: Vec<f32>,
    /// The policy's σ during the rollout (state-independent).
    pub std: Vec<f32>,
    pub returns: Vec<f32>,
    pub advantages: Vec<f32>,
    filled: usize,
}

impl Rollout {
    pub fn new(steps: usize, envs: usize, obs_dim: usize, act_dim: usize) -> Self {
        let n = steps * envs;
        Rollout {
            steps,
            envs,
            obs_dim,
            act_dim,
            obs: vec![0.0; n * obs_dim],
            actions: vec![0.0; n * act_dim],
            log_probs: vec![0.0; n],
            values: vec![0.0; n],
            rewards: vec![0.0; n],
            dones: vec![0.0; n],
            means: vec![0.0; n * act_dim],
            est_dim: 0,
            estimates: Vec::new(),
            std: vec![0.0; act_dim],
            returns: vec![0.0; n],
            advantages: vec![0.0; n],
            filled: 0,
        }
    }

    /// The same, storing `est_dim` estimator outputs per transition.
    pub fn with_estimates(mut self, est_dim: usize) -> Self {
        self.est_dim = est_dim;
        self.estimates = vec![0.0; self.len() * est_dim];
        self
    }

    pub fn len(&self) -> usize {
        self.steps * self.envs
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn clear(&mut self) {
        self.filled = 0;
    }

    /// The next step's rows of every buffer (all envs), for the acting agent to fill.
    pub fn next_step(&mut self) -> ActOutput<'_> {
        assert!(self.filled < self.steps, "rollout is full");
        let (k, n, od, ad, ed) = (self.filled, self.envs, self.obs_dim, self.act_dim, self.est_dim);
        self.filled += 1;
        ActOutput {
            obs_norm: &mut self.obs[k * n * od..(k + 1) * n * od],
            actions: &mut self.actions[k * n * ad..(k + 1) * n * ad],
            means: &mut self.means[k * n * ad..(k + 1) * n * ad],
            log_probs: &mut self.log_probs[k * n..(k + 1) * n],
            values: &mut self.values[k * n..(k + 1) * n],
            estimates: &mut self.estimates[k * n * ed..(k + 1) * n * ed],
        }
    }

    /// The actions of the last step filled (all envs).
    pub fn last_actions(&self) -> &[f32] {
        let (k, n, ad) = (self.filled - 1, self.envs, self.act_dim);
        &self.actions[k * n * ad..(k + 1) * n * ad]
    }

    /// GAE(γ, λ) from the stored values and `last_values` (values of the observations after the last step),
    /// then advantages normalised to zero mean and unit std over the whole rollout.
    pub fn compute_returns(&mut self, last_values: &[f32], gamma: f64, lambda: f64) {
        let (t_max, n) = (self.steps, self.envs);
        let mut gae = vec![0.0f64; n];
        for t in (0..t_max).rev() {
            for e in 0..n {
                let i = t * n + e;
                let next_value = if t + 1 == t_max { last_values[e] } else { self.values[i + n] } as f64;
                let not_done = 1.0 - self.dones[i] as f64;
                let delta = self.rewards[i] as f64 + gamma * next_value * not_done - self.values[i] as f64;
                gae[e] = delta + gamma * lambda * not_done * gae[e];
                self.returns[i] = (gae[e] + self.values[i] as f64) as f32;
            }
        }
        let len = self.len() as f64;
        for i in 0..self.len() {
            self.advantages[i] = self.returns[i] - self.values[i];
        }
        let mean = self.advantages.iter().map(|&a| a as f64).sum::<f64>() / len;
        let var = self.advantages.iter().map(|&a| (a as f64 - mean).powi(2)).sum::<f64>() / (len - 1.0).max(1.0);
        let inv = 1.0 / (var.sqrt() + 1e-8);
        for a in &mut self.advantages {
            *a = ((*a as f64 - mean) * inv) as f32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gae_with_lambda_one_is_the_discounted_return_and_dones_cut_it() {
        let mut r = Rollout::new(3, 1, 1, 1);
        r.rewards = vec![1.0, 1.0, 1.0];
        r.values = vec![0.0, 0.0, 0.0];
        r.dones = vec![0.0, 1.0, 0.0];
        r.compute_returns(&[10.0], 0.5, 1.0);
        // t=2: 1 + 0.5·10 = 6; t=1: done → 1; t=0: 1 + 0.5·1 = 1.5.
        assert_eq!(r.returns, vec![1.5, 1.0, 6.0]);
        let mean: f32 = r.advantages.iter().sum::<f32>() / 3.0;
        assert!(mean.abs() < 1e-6);
    }

    #[test]
    fn gae_with_lambda_zero_is_the_one_step_td_target() {
        let mut r = Rollout::new(2, 2, 1, 1);
        r.rewards = vec![1.0, 2.0, 3.0, 4.0];
        r.values = vec![0.5, 0.5, 1.0, 2.0];
        r.dones = vec![0.0; 4];
        r.compute_returns(&[3.0, 5.0], 0.9, 0.0);
        let expect = [1.0 + 0.9 * 1.0, 2.0 + 0.9 * 2.0, 3.0 + 0.9 * 3.0, 4.0 + 0.9 * 5.0];
        for (a, b) in r.returns.iter().zip(expect) {
            assert!((a - b).abs() < 1e-6);
        }
    }
}
