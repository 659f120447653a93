//! AdamW (zero weight decay, as the paper's rsl_rl-style PPO) with its moments in plain vectors, so they can be
//! checkpointed and restored exactly (candle-nn's optimiser keeps them private), plus the global gradient-norm
//! clip, which candle does not have. It implements `candle_nn::Optimizer`, so candle code can drive it.

use candle_core::backprop::GradStore;
use candle_core::{Result, Tensor, Var};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdamParams {
    pub beta1: f64,
    pub beta2: f64,
    pub eps: f64,
    pub weight_decay: f64,
    /// Used by `candle_nn::Optimizer::step` (PPO passes its adaptive rate to `clipped_step` instead).
    pub learning_rate: f64,
    /// Global gradient-norm clip of `candle_nn::Optimizer::step` (infinite: none).
    pub max_grad_norm: f64,
}

impl Default for AdamParams {
    /// PyTorch's defaults; weight decay 0 (the paper's "decay" is the separate last-layer loss).
    fn default() -> Self {
        AdamParams {
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
            weight_decay: 0.0,
            learning_rate: 1e-3,
            max_grad_norm: f64::INFINITY,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct AdamState {
    pub step: u64,
    /// First and second moments, one flat vector per parameter, in `vars` order.
    pub m: Vec<Vec<f32>>,
    pub v: Vec<Vec<f32>>,
}

pub struct AdamW {
    vars: Vec<Var>,
    pub params: AdamParams,
    pub state: AdamState,
}

/// What one clipped step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepInfo {
    /// Global L2 norm of the gradient before clipping.
    pub grad_norm: f64,
    /// The norm actually used (≤ max_norm).
    pub clipped_norm: f64,
    /// False if the gradient was not finite and the step was skipped (weights unchanged).
    pub applied: bool,
}

impl AdamW {
    pub fn new(vars: Vec<Var>, params: AdamParams) -> Self {
        let zeros: Vec<Vec<f32>> = vars.iter().map(|v| vec![0.0; v.elem_count()]).collect();
        AdamW { state: AdamState { step: 0, m: zeros.clone(), v: zeros }, vars, params }
    }

    pub fn vars(&self) -> &[Var] {
        &self.vars
    }

    /// Flattened gradients of every var (zeros where a var got none).
    pub fn gradients(&self, grads: &GradStore) -> Result<Vec<Vec<f32>>> {
        self.gradients_of(&[grads])
    }

    /// As [`Self::gradients`], each variable's gradient taken from the first store that has one (the stores of
    /// losses with disjoint variables).
    pub fn gradients_of(&self, stores: &[&GradStore]) -> Result<Vec<Vec<f32>>> {
        self.vars
            .iter()
            .map(|v| match stores.iter().find_map(|s| s.get(v.as_tensor())) {
                Some(g) => g.flatten_all()?.to_vec1::<f32>(),
                None => Ok(vec![0.0; v.elem_count()]),
            })
            .collect()
    }

    /// Clips the gradients to `max_norm` (global L2 norm over all vars) and takes one Adam step with `lr`.
    /// A non-finite gradient skips the step and leaves weights and moments untouched.
    pub fn clipped_step(&mut self, grads: &GradStore, lr: f64, max_norm: f64) -> Result<StepInfo> {
        self.clipped_step_on(self.gradients(grads)?, lr, max_norm)
    }

    /// As `clipped_step`, on gradients already taken out of the graph (one vector per variable).
    pub fn clipped_step_on(&mut self, mut g: Vec<Vec<f32>>, lr: f64, max_norm: f64) -> Result<StepInfo> {
        let norm = global_norm(&g);
        if !norm.is_finite() {
            return Ok(StepInfo { grad_norm: norm, clipped_norm: 0.0, applied: false });
        }
        let scale = if norm > max_norm { max_norm / (norm + 1e-6) } else { 1.0 };
        if scale != 1.0 {
            for gi in &mut g {
                gi.iter_mut().for_each(|x| *x = (*x as f64 * scale) as f32);
            }
        }
        self.apply(&g, lr)?;
        Ok(StepInfo { grad_norm: norm, clipped_norm: global_norm(&g), applied: true })
    }

    /// One Adam step from flat gradients (already clipped).
    pub fn apply(&mut self, grads: &[Vec<f32>], lr: f64) -> Result<()> {
        let p = self.params;
        self.state.step += 1;
        let t = self.state.step as i32;
        let (bc1, bc2) = (1.0 - p.beta1.powi(t), 1.0 - p.beta2.powi(t));
        for (i, var) in self.vars.iter().enumerate() {
            let mut w = var.as_tensor().flatten_all()?.to_vec1::<f32>()?;
            let (m, v) = (&mut self.state.m[i], &mut self.state.v[i]);
            for j in 0..w.len() {
                let gj = grads[i][j] as f64;
                let mj = p.beta1 * m[j] as f64 + (1.0 - p.beta1) * gj;
                let vj = p.beta2 * v[j] as f64 + (1.0 - p.beta2) * gj * gj;
                m[j] = mj as f32;
                v[j] = vj as f32;
                let mut wj = w[j] as f64;
                wj -= lr * p.weight_decay * wj;
                wj -= lr * (mj / bc1) / ((vj / bc2).sqrt() + p.eps);
                w[j] = wj as f32;
            }
            var.set(&Tensor::from_vec(w, var.shape(), var.device())?)?;
        }
        Ok(())
    }

    /// Restores moments saved from an optimiser over the same vars.
    pub fn set_state(&mut self, state: AdamState) -> crate::error::Result<()> {
        let shapes_ok = state.m.len() == self.vars.len()
            && state.v.len() == self.vars.len()
            && self
                .vars
                .iter()
                .enumerate()
                .all(|(i, v)| state.m[i].len() == v.elem_count() && state.v[i].len() == v.elem_count());
        if !shapes_ok {
            return Err(crate::error::Error::bad_file("optimizer moments do not match the network's parameters"));
        }
        self.state = state;
        Ok(())
    }
}

impl candle_nn::Optimizer for AdamW {
    type Config = AdamParams;

    fn new(vars: Vec<Var>, config: AdamParams) -> Result<Self> {
        Ok(AdamW::new(vars, config))
    }

    fn step(&mut self, grads: &GradStore) -> Result<()> {
        let (lr, clip) = (self.params.learning_rate, self.params.max_grad_norm);
        self.clipped_step(grads, lr, clip).map(|_| ())
    }

    fn learning_rate(&self) -> f64 {
        self.params.learning_rate
    }

    fn set_learning_rate(&mut self, lr: f64) {
        self.params.learning_rate = lr;
    }
}

pub fn global_norm(g: &[Vec<f32>]) -> f64 {
    g.iter().flatten().map(|&x| (x as f64) * (x as f64)).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use candle_core::Device;

    #[test]
    fn clipping_bounds_the_norm_and_adam_moves_against_the_gradient() {
        let w = Var::from_vec(vec![1.0f32, -2.0, 3.0], 3, &Device::Cpu).unwrap();
        let mut opt = AdamW::new(vec![w.clone()], AdamParams::default());
        // loss = 100 · Σ w² → gradient 200 w, norm ≫ 0.5.
        let loss = (w.as_tensor().sqr().unwrap().sum_all().unwrap() * 100.0).unwrap();
        let grads = loss.backward().unwrap();
        let info = opt.clipped_step(&grads, 0.1, 0.5).unwrap();
        assert!(info.grad_norm > 100.0);
        assert!(info.clipped_norm <= 0.5 + 1e-6, "{info:?}");
        let after = w.as_tensor().to_vec1::<f32>().unwrap();
        // Adam's first step moves each weight by ≈ lr against the sign of its gradient.
        for (a, b) in after.iter().zip([1.0f32, -2.0, 3.0]) {
            assert!(((b - a) - 0.1 * b.signum()).abs() < 1e-4, "{a} from {b}");
        }
    }

    #[test]
    fn through_candle_nn_optimizer_it_matches_candle_nn_adamw() {
        use candle_nn::Optimizer;
        let start = [0.5f32, -1.5, 2.0, 0.1];
        let ours_w = Var::from_vec(start.to_vec(), 4, &Device::Cpu).unwrap();
        let theirs_w = Var::from_vec(start.to_vec(), 4, &Device::Cpu).unwrap();
        let params = AdamParams { learning_rate: 0.05, ..Default::default() };
        let mut ours = <AdamW as Optimizer>::new(vec![ours_w.clone()], params).unwrap();
        let cfg = candle_nn::ParamsAdamW { lr: 0.05, beta1: 0.9, beta2: 0.999, eps: 1e-8, weight_decay: 0.0 };
        let mut theirs = candle_nn::AdamW::new(vec![theirs_w.clone()], cfg).unwrap();
        // A quartic bowl: the gradient changes every step, so the moments matter.
        let loss = |w: &Var| w.as_tensor().sqr().unwrap().sqr().unwrap().sum_all().unwrap();
        let first = loss(&ours_w).to_scalar::<f32>().unwrap();
        for _ in 0..50 {
            ours.backward_step(&loss(&ours_w)).unwrap();
            theirs.backward_step(&loss(&theirs_w)).unwrap();
        }
        let (a, b) = (ours_w.as_tensor().to_vec1::<f32>().unwrap(), theirs_w.as_tensor().to_vec1::<f32>().unwrap());
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-5, "ours {a:?} vs candle-nn {b:?}");
        }
        assert!(loss(&ours_w).to_scalar::<f32>().unwrap() < 0.1 * first);
        ours.set_learning_rate(0.01);
        assert_eq!(ours.learning_rate(), 0.01);
    }

    #[test]
    fn a_nan_gradient_skips_the_step() {
        let w = Var::from_vec(vec![1.0f32, 2.0], 2, &Device::Cpu).unwrap();
        let mut opt = AdamW::new(vec![w.clone()], AdamParams::default());
        let loss = (w.as_tensor().sqrt().unwrap() * f64::NAN).unwrap().sum_all().unwrap();
        let grads = loss.backward().unwrap();
        let info = opt.clipped_step(&grads, 0.1, 1.0).unwrap();
        assert!(!info.applied);
        assert_eq!(w.as_tensor().to_vec1::<f32>().unwrap(), vec![1.0, 2.0]);
        assert_eq!(opt.state.step, 0);
    }
}
