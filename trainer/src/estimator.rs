//! The concurrent estimator's learning (Ji et al., "Concurrent Training of a Control Policy and a State Estimator
//! for Dynamic and Robust Legged Locomotion", 2022): a regression of the observation row's estimated columns
//! (values the simulator knows, e.g. the base velocity) on the actor's inputs, one step per PPO minibatch on the
//! same rows, with its own Adam and learning rate. The policy's loss does not reach it: the actor learns on the
//! estimates it acted on (stored in the rollout), so PPO's probability ratios stay those of the actor alone.
//! Inputs and targets are normalised by the agent's observation normaliser, so the estimate is what the actor
//! would read of the true value.

use candle_core::{Result, Tensor};

use crate::actor_view::ActorView;
use crate::comm::Comm;
use crate::nn::Mlp;
use crate::optim::{AdamParams, AdamW};

/// The estimator's optimiser.
pub struct EstimatorLearner {
    pub opt: AdamW,
    pub learning_rate: f64,
    pub max_grad_norm: f64,
}

/// One minibatch's regression: the mean squared error in normalised units and the root mean squared error in the
/// estimated values' own units (e.g. m/s).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EstimatorStep {
    pub loss: f64,
    pub rmse: f64,
    /// False when the loss or the gradient was not finite (the weights were kept).
    pub applied: bool,
}

impl EstimatorLearner {
    pub fn new(net: &Mlp, learning_rate: f64, max_grad_norm: f64) -> Self {
        EstimatorLearner { opt: AdamW::new(net.vars(), AdamParams::default()), learning_rate, max_grad_norm }
    }

    /// One step on `obs` (normalised rows × the view's `obs_dim`); `scale` converts a normalised estimate of each
    /// estimated column back to its units. Gradients are averaged over `comm`'s ranks (every rank takes the same
    /// step, and skips it together when any rank's loss is not finite).
    pub fn step(
        &mut self,
        net: &Mlp,
        view: &ActorView,
        obs: &Tensor,
        scale: &[f32],
        comm: &dyn Comm,
    ) -> Result<EstimatorStep> {
        let Some(cols) = &view.estimate else { return Ok(EstimatorStep::default()) };
        let inputs = obs.narrow(1, 0, view.inputs)?.contiguous()?;
        let target = obs.narrow(1, cols.start, cols.len())?.contiguous()?;
        let error = (net.forward(&inputs)? - target)?;
        let loss = error.sqr()?.mean_all()?;
        let value = loss.to_scalar::<f32>()? as f64;
        let mut g = if value.is_finite() {
            self.opt.gradients(&loss.backward()?)?
        } else {
            self.opt.vars().iter().map(|v| vec![0.0; v.elem_count()]).collect()
        };
        let mut flat = g.concat();
        comm.sum_f32(&mut flat);
        let mut failed = [if value.is_finite() { 0.0 } else { 1.0 }];
        comm.sum_f64(&mut failed);
        let size = comm.size() as f64;
        let mut at = 0;
        for gi in &mut g {
            for (x, s) in gi.iter_mut().zip(&flat[at..]) {
                *x = (*s as f64 / size) as f32;
            }
            at += gi.len();
        }
        let e = error.flatten_all()?.to_vec1::<f32>()?;
        let d = scale.len();
        let sq: f64 = e.iter().enumerate().map(|(i, x)| (*x as f64 * scale[i % d] as f64).powi(2)).sum();
        let rmse = (sq / e.len().max(1) as f64).sqrt();
        if failed[0] > 0.0 {
            log::warn!("estimator: non-finite loss, its step skipped on every rank (weights kept)");
            return Ok(EstimatorStep { loss: value, rmse, applied: false });
        }
        let info = self.opt.clipped_step_on(g, self.learning_rate, self.max_grad_norm)?;
        Ok(EstimatorStep { loss: value, rmse, applied: info.applied })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::comm::Single;
    use candle_core::Device;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The estimated column is a linear function of the inputs: the regression drives its error down by far.
    #[test]
    fn the_estimator_learns_a_value_the_inputs_determine() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let view = ActorView { obs_dim: 4, inputs: 3, estimate: Some(3..4) };
        let net = Mlp::new(&[3, 32, 1], &mut rng).unwrap();
        let mut learner = EstimatorLearner::new(&net, 3e-3, 1.0);
        let rows = 256;
        let mut first = None;
        let mut last = EstimatorStep::default();
        for _ in 0..400 {
            let obs: Vec<f32> = (0..rows)
                .flat_map(|_| {
                    let x: [f32; 3] = [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random()];
                    [x[0], x[1], x[2], 0.8 * x[0] - 0.5 * x[1]]
                })
                .collect();
            let t = Tensor::from_vec(obs, (rows, 4), &Device::Cpu).unwrap();
            last = learner.step(&net, &view, &t, &[2.0], &Single).unwrap();
            assert!(last.applied);
            first.get_or_insert(last);
        }
        let first = first.unwrap();
        assert!(last.loss < 0.02 * first.loss, "loss {} → {}", first.loss, last.loss);
        // The RMSE is in the column's units: twice the normalised error here.
        assert!((last.rmse - 2.0 * last.loss.sqrt()).abs() < 1e-3 * last.rmse.max(1e-6));
    }
}
