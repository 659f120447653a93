//! The actor–critic: a Gaussian policy (MLP mean, learned state-independent log-std) and a value MLP, plus the
//! plain-vector helpers the rollout uses (sampling with our own seeded RNG, log-probabilities, KL).

use candle_core::{Device, Result, Tensor, Var};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;

use crate::actor_view::ActorView;
use crate::nn::{layer_dims, Mlp, MlpScratch};

pub struct ActorCritic {
    pub actor: Mlp,
    pub critic: Mlp,
    /// log σ per action dimension.
    pub log_std: Var,
    /// Values in the observation row (the critic's input).
    pub obs_dim: usize,
    pub act_dim: usize,
    /// What the actor reads of the row (all of it unless the task says otherwise).
    pub view: ActorView,
    /// The concurrent estimator of the view's estimated columns, from the actor's inputs (Ji et al., 2022).
    pub estimator: Option<Mlp>,
}

impl ActorCritic {
    /// The networks for `view` (its `obs_dim` is the critic's input, its `dim()` the actor's); an estimator with
    /// `estimator_hidden` layers when the view has estimated columns. The draws are those of the paper's networks
    /// (actor, critic, then the estimator's), so a whole view builds the same weights as before views existed.
    pub fn new(
        view: ActorView,
        act_dim: usize,
        actor_hidden: &[usize],
        critic_hidden: &[usize],
        estimator_hidden: &[usize],
        init_std: f64,
        rng: &mut ChaCha8Rng,
    ) -> Result<Self> {
        let dims = layer_dims;
        let obs_dim = view.obs_dim;
        let actor = Mlp::new(&dims(view.dim(), actor_hidden, act_dim), rng)?;
        let critic = Mlp::new(&dims(obs_dim, critic_hidden, 1), rng)?;
        let log_std = Var::from_vec(vec![init_std.ln() as f32; act_dim], act_dim, &Device::Cpu)?;
        let estimator = match view.estimate_dim() {
            0 => None,
            e => Some(Mlp::new(&dims(view.inputs, estimator_hidden, e), rng)?),
        };
        Ok(ActorCritic { actor, critic, log_std, obs_dim, act_dim, view, estimator })
    }

    /// The estimator's variables with their names in checkpoints and policy files (none without one).
    pub fn named_estimator_vars(&self) -> Vec<(String, Var)> {
        self.estimator.as_ref().map_or(Vec::new(), |e| named_mlp("estimator", e))
    }

    /// Every trainable variable with a stable name (the names used in checkpoints and policy files).
    pub fn named_vars(&self) -> Vec<(String, Var)> {
        let mut out = named_mlp("actor", &self.actor);
        out.push(("log_std".into(), self.log_std.clone()));
        out.extend(named_mlp("critic", &self.critic));
        out
    }

    pub fn vars(&self) -> Vec<Var> {
        self.named_vars().into_iter().map(|(_, v)| v).collect()
    }

    pub fn std(&self) -> Result<Vec<f32>> {
        self.log_std.as_tensor().exp()?.to_vec1::<f32>()
    }
}

pub fn named_mlp(prefix: &str, mlp: &Mlp) -> Vec<(String, Var)> {
    mlp.layers
        .iter()
        .enumerate()
        .flat_map(|(i, l)| {
            [(format!("{prefix}.{i}.weight"), l.weight.clone()), (format!("{prefix}.{i}.bias"), l.bias.clone())]
        })
        .collect()
}

/// Buffers of the actor's inference (reused every call): its scratch and, when its view is not the whole
/// observation, its rows, the estimator's inputs, scratch and outputs.
#[derive(Default)]
pub struct ActorBuffers {
    pub actor: MlpScratch,
    pub estimator: MlpScratch,
    pub actor_in: Vec<f32>,
    pub estimator_in: Vec<f32>,
    /// The estimator's outputs of the last call (rows × its size; empty without an estimator).
    pub estimate: Vec<f32>,
}

/// The actor's means for `rows` normalised observation rows `norm` through `view`: the rows themselves for a whole
/// view; else the actor's inputs, then the estimator's estimate of the view's columns when there is an estimator.
/// The one forward pass of rollouts and of loaded policies.
pub fn actor_forward(
    view: &ActorView,
    actor: &Mlp,
    estimator: Option<&Mlp>,
    norm: &[f32],
    rows: usize,
    mean: &mut Vec<f32>,
    b: &mut ActorBuffers,
) {
    if view.is_whole() {
        return actor.forward_inference(norm, rows, mean, &mut b.actor);
    }
    b.estimate.clear();
    if let Some(e) = estimator {
        view.inputs_of(norm, &mut b.estimator_in);
        e.forward_inference(&b.estimator_in, rows, &mut b.estimate, &mut b.estimator);
    }
    view.assemble(norm, &b.estimate, &mut b.actor_in);
    actor.forward_inference(&b.actor_in, rows, mean, &mut b.actor);
}

/// Buffers for batched inference during rollouts (reused every step).
#[derive(Default)]
pub struct InferenceBuffers {
    pub actor: ActorBuffers,
    pub critic: MlpScratch,
    pub mean: Vec<f32>,
    pub value: Vec<f32>,
}

/// A standard normal draw (Box–Muller on our seeded stream: candle's CPU RNG cannot be seeded).
pub fn standard_normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Samples `mean + std ⊙ ε` row by row into `actions`.
pub fn sample_actions(mean: &[f32], std: &[f32], rng: &mut ChaCha8Rng, actions: &mut [f32]) {
    let d = std.len();
    for (i, (a, m)) in actions.iter_mut().zip(mean).enumerate() {
        *a = m + std[i % d] * standard_normal(rng) as f32;
    }
}

const HALF_LN_2PI: f64 = 0.918_938_533_204_672_7;

/// log N(a; mean, diag(std²)) per row.
pub fn log_prob(actions: &[f32], mean: &[f32], log_std: &[f32], out: &mut [f32]) {
    let d = log_std.len();
    for (r, o) in out.iter_mut().enumerate() {
        let mut s = 0.0f64;
        for j in 0..d {
            let z = (actions[r * d + j] - mean[r * d + j]) as f64 / (log_std[j] as f64).exp();
            s += -0.5 * z * z - log_std[j] as f64 - HALF_LN_2PI;
        }
        *o = s as f32;
    }
}

/// Mean over rows of KL(old ‖ new) for diagonal Gaussians (closed form), as rsl_rl's adaptive schedule uses.
pub fn mean_kl(old_mean: &[f32], old_std: &[f32], new_mean: &[f32], new_std: &[f32]) -> f64 {
    let d = old_std.len();
    let rows = old_mean.len() / d;
    let mut total = 0.0f64;
    for r in 0..rows {
        for j in 0..d {
            let (so, sn) = (old_std[j] as f64, new_std[j] as f64);
            let dm = (old_mean[r * d + j] - new_mean[r * d + j]) as f64;
            total += (sn / so).ln() + (so * so + dm * dm) / (2.0 * sn * sn) - 0.5;
        }
    }
    total / rows.max(1) as f64
}

/// Differentiable log N(a; μ, σ²) per row: `actions`, `mean` [rows, d], `log_std` [d] → [rows].
pub fn log_prob_tensor(actions: &Tensor, mean: &Tensor, log_std: &Tensor) -> Result<Tensor> {
    let d = log_std.dims1()?;
    let z = actions.sub(mean)?.broadcast_div(&log_std.exp()?)?;
    let quad = (z.sqr()?.sum(1)? * -0.5)?;
    quad.broadcast_sub(&(log_std.sum_all()? + HALF_LN_2PI * d as f64)?)
}

/// Entropy of the diagonal Gaussian (state-independent σ): Σ (½ + ½ ln 2π + log σ).
pub fn entropy_tensor(log_std: &Tensor) -> Result<Tensor> {
    let d = log_std.dims1()?;
    log_std.sum_all()? + (0.5 + HALF_LN_2PI) * d as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn normal_draws_have_unit_moments() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let xs: Vec<f64> = (0..200_000).map(|_| standard_normal(&mut rng)).collect();
        let m = xs.iter().sum::<f64>() / xs.len() as f64;
        let v = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / xs.len() as f64;
        assert!(m.abs() < 0.01 && (v - 1.0).abs() < 0.01, "mean {m} var {v}");
    }

    #[test]
    fn log_prob_and_kl_match_closed_forms() {
        let (a, m, ls) = ([0.5f32, -1.0], [0.0f32, 0.0], [0.0f32, (2.0f32).ln()]);
        let mut lp = [0.0f32];
        log_prob(&a, &m, &ls, &mut lp);
        let expect = -0.5 * 0.25 - 0.5 * 0.25 - (2.0f64).ln() - 2.0 * HALF_LN_2PI;
        assert!((lp[0] as f64 - expect).abs() < 1e-6);
        let t = log_prob_tensor(
            &Tensor::new(&[a], &Device::Cpu).unwrap(),
            &Tensor::new(&[m], &Device::Cpu).unwrap(),
            &Tensor::new(&ls, &Device::Cpu).unwrap(),
        )
        .unwrap()
        .to_vec1::<f32>()
        .unwrap();
        assert!((t[0] - lp[0]).abs() < 1e-6);
        assert_eq!(mean_kl(&[1.0, 2.0], &[0.5, 1.0], &[1.0, 2.0], &[0.5, 1.0]), 0.0);
        // KL(N(0,1) ‖ N(1,1)) = ½.
        assert!((mean_kl(&[0.0], &[1.0], &[1.0], &[1.0]) - 0.5).abs() < 1e-12);
    }
}
