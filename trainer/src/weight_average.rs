//! Weight averaging: one policy from several policies of one run (its late checkpoints), the element-wise mean of
//! their actor and estimator weights (Nikishin et al. 2018, "Improving stability in deep reinforcement learning
//! with weight averaging"; Izmailov et al.'s SWA). PPO's last checkpoints swing around the policy the run
//! converges to; their mean is a draw from none of them.
//!
//! Each policy's observation normaliser is folded into the layers that read or write normalised values first
//! (exact: the normaliser is affine and unclipped), so policies whose running statistics drifted are averaged as
//! functions of the raw observation; the mean is unfolded with the last policy's normaliser, which it carries.

use crate::actor_view::ActorView;
use crate::error::{bad_file, invalid, Result};
use crate::nn::{Linear, Mlp};
use crate::policy_file::Policy;
use candle_core::{Device, Tensor, Var};

/// One layer as f64 row-major `[out][in]` weights and `[out]` bias.
struct Dense {
    w: Vec<Vec<f64>>,
    b: Vec<f64>,
}

impl Dense {
    fn of(l: &Linear) -> Result<Dense> {
        let (out, inp) = l.weight.as_tensor().dims2()?;
        let flat = l.weight.as_tensor().flatten_all()?.to_vec1::<f32>()?;
        let w = (0..out).map(|o| flat[o * inp..(o + 1) * inp].iter().map(|&x| x as f64).collect()).collect();
        Ok(Dense { w, b: l.bias.as_tensor().to_vec1::<f32>()?.iter().map(|&x| x as f64).collect() })
    }

    fn linear(&self) -> Result<Linear> {
        let (out, inp) = (self.w.len(), self.w.first().map_or(0, Vec::len));
        let flat: Vec<f32> = self.w.iter().flatten().map(|&x| x as f32).collect();
        let b: Vec<f32> = self.b.iter().map(|&x| x as f32).collect();
        Ok(Linear {
            weight: Var::from_tensor(&Tensor::from_vec(flat, (out, inp), &Device::Cpu)?)?,
            bias: Var::from_tensor(&Tensor::from_vec(b, out, &Device::Cpu)?)?,
        })
    }

    /// Input column `j` reads `(x − mean) · scale`: rewrite the layer to read `x` (`unfold`: the inverse).
    fn fold_input(&mut self, j: usize, mean: f64, scale: f64, unfold: bool) {
        for (row, b) in self.w.iter_mut().zip(&mut self.b) {
            if unfold {
                row[j] /= scale;
                *b += row[j] * scale * mean;
            } else {
                *b -= row[j] * scale * mean;
                row[j] *= scale;
            }
        }
    }

    /// Output `i` is a normalised value `(x − mean) · scale`: rewrite the layer to output `x` (`unfold`: the
    /// inverse).
    fn fold_output(&mut self, i: usize, mean: f64, scale: f64, unfold: bool) {
        if unfold {
            self.b[i] = (self.b[i] - mean) * scale;
            self.w[i].iter_mut().for_each(|w| *w *= scale);
        } else {
            self.b[i] = self.b[i] / scale + mean;
            self.w[i].iter_mut().for_each(|w| *w /= scale);
        }
    }
}

/// The policy's normaliser as `(mean, scale)` per observation column.
fn affine(p: &Policy) -> Vec<(f64, f64)> {
    let (mean, scale) = p.normalizer_affine();
    mean.into_iter().zip(scale).collect()
}

/// The actor and estimator layers of `p` with its normaliser folded in (`unfold` with `stats`: the inverse).
fn fold(view: &ActorView, actor: &mut [Dense], estimator: &mut [Dense], stats: &[(f64, f64)], unfold: bool) {
    // The order is the inverse's reversed: inputs before outputs when folding, outputs first when unfolding.
    let fold_inputs = |layers: &mut [Dense], columns: &mut dyn Iterator<Item = (usize, usize)>| {
        for (j, c) in columns {
            layers[0].fold_input(j, stats[c].0, stats[c].1, unfold);
        }
    };
    let estimated: Vec<usize> = view.estimate.clone().map_or(Vec::new(), |r| r.collect());
    let fold_estimate_out = |estimator: &mut [Dense]| {
        if let Some(last) = estimator.last_mut() {
            for (i, &c) in estimated.iter().enumerate() {
                last.fold_output(i, stats[c].0, stats[c].1, unfold);
            }
        }
    };
    if unfold {
        fold_estimate_out(estimator);
    }
    fold_inputs(
        actor,
        &mut (0..view.inputs).map(|j| (j, j)).chain(estimated.iter().enumerate().map(|(i, &c)| (view.inputs + i, c))),
    );
    if !estimator.is_empty() {
        fold_inputs(estimator, &mut (0..view.inputs).map(|j| (j, j)));
    }
    if !unfold {
        fold_estimate_out(estimator);
    }
}

fn dense(m: Option<&Mlp>) -> Result<Vec<Dense>> {
    m.map_or(Ok(Vec::new()), |m| m.layers.iter().map(Dense::of).collect())
}

fn mlp(layers: &[Dense], like: &Mlp) -> Result<Mlp> {
    Ok(Mlp {
        layers: layers.iter().map(Dense::linear).collect::<Result<_>>()?,
        hidden_activation: like.hidden_activation,
    })
}

/// Adds `x` into `sum` (same shapes: checked by the caller through the sidecars).
fn accumulate(sum: &mut [Dense], x: &[Dense]) {
    for (s, l) in sum.iter_mut().zip(x) {
        s.w.iter_mut().flatten().zip(l.w.iter().flatten()).for_each(|(a, b)| *a += b);
        s.b.iter_mut().zip(&l.b).for_each(|(a, b)| *a += b);
    }
}

/// The weight average of `policies` (named by `names` in errors), in the order given; the last one's normaliser
/// and sidecar are the result's. They must be one network: the same sizes, view and robot.
pub fn average(policies: &[Policy], names: &[String]) -> Result<Policy> {
    let Some(last) = policies.last() else { invalid!("weight averaging needs at least one policy") };
    let shape = |p: &Policy| (p.meta.obs_dim, p.meta.action_dim, p.meta.hidden.clone(), p.view().clone());
    for (p, name) in policies.iter().zip(names) {
        if shape(p) != shape(last)
            || p.meta.robot != last.meta.robot
            || p.meta.estimator_hidden != last.meta.estimator_hidden
        {
            bad_file!(
                "{name} is not the same network as {} (sizes, actor view or robot differ): average the checkpoints of \
                 one run",
                names.last().map_or("the last policy", String::as_str)
            );
        }
    }
    let view = last.view().clone();
    let (mut actor_sum, mut estimator_sum): (Option<Vec<Dense>>, Vec<Dense>) = (None, Vec::new());
    for p in policies {
        let (mut a, mut e) = (dense(Some(p.actor()))?, dense(p.estimator())?);
        fold(&view, &mut a, &mut e, &affine(p), false);
        match &mut actor_sum {
            None => (actor_sum, estimator_sum) = (Some(a), e),
            Some(s) => {
                accumulate(s, &a);
                accumulate(&mut estimator_sum, &e);
            }
        }
    }
    let n = policies.len() as f64;
    let mut actor = actor_sum.unwrap_or_default();
    for l in actor.iter_mut().chain(estimator_sum.iter_mut()) {
        l.w.iter_mut().flatten().chain(l.b.iter_mut()).for_each(|x| *x /= n);
    }
    fold(&view, &mut actor, &mut estimator_sum, &affine(last), true);
    let estimator = match last.estimator() {
        Some(like) => Some(mlp(&estimator_sum, like)?),
        None => None,
    };
    Ok(Policy::from_parts(last.meta.clone(), view, mlp(&actor, last.actor())?, estimator, last.normalizer().clone()))
}
