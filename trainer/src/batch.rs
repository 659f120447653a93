//! One PPO minibatch gathered from a rollout into contiguous buffers, and its mirror image.

use crate::actor_view::ActorView;
use crate::storage::Rollout;
use crate::symmetry::{SignedPermutation, Symmetry};

/// One minibatch gathered into contiguous buffers (obs normalised).
#[derive(Debug, Clone, Default)]
pub struct Batch {
    pub rows: usize,
    /// The second half of the rows is the mirror image of the first (`losses.symmetry_augmentation`).
    pub mirrored: bool,
    pub obs: Vec<f32>,
    /// The actor's rows (its view of `obs` with the rollout's estimates) when its view is not the whole row;
    /// empty otherwise (the actor reads `obs`).
    pub actor_obs: Vec<f32>,
    pub actions: Vec<f32>,
    pub means: Vec<f32>,
    pub log_probs: Vec<f32>,
    pub values: Vec<f32>,
    pub returns: Vec<f32>,
    pub advantages: Vec<f32>,
}

impl Batch {
    pub fn with_capacity(rows: usize, od: usize, ad: usize) -> Self {
        Batch {
            rows,
            mirrored: false,
            obs: Vec::with_capacity(rows * od),
            actor_obs: Vec::new(),
            actions: Vec::with_capacity(rows * ad),
            means: Vec::with_capacity(rows * ad),
            log_probs: Vec::with_capacity(rows),
            values: Vec::with_capacity(rows),
            returns: Vec::with_capacity(rows),
            advantages: Vec::with_capacity(rows),
        }
    }

    /// Copies rollout rows `idx` in; the actor's rows through `view`.
    pub fn gather(&mut self, r: &Rollout, idx: &[usize], view: &ActorView) {
        let (od, ad) = (r.obs_dim, r.act_dim);
        self.rows = idx.len();
        self.mirrored = false;
        for v in [
            &mut self.obs,
            &mut self.actor_obs,
            &mut self.actions,
            &mut self.means,
            &mut self.log_probs,
            &mut self.values,
            &mut self.returns,
            &mut self.advantages,
        ] {
            v.clear();
        }
        for &i in idx {
            self.obs.extend_from_slice(&r.obs[i * od..(i + 1) * od]);
            self.actions.extend_from_slice(&r.actions[i * ad..(i + 1) * ad]);
            self.means.extend_from_slice(&r.means[i * ad..(i + 1) * ad]);
            self.log_probs.push(r.log_probs[i]);
            self.values.push(r.values[i]);
            self.returns.push(r.returns[i]);
            self.advantages.push(r.advantages[i]);
        }
        if !view.is_whole() {
            let ed = r.est_dim;
            let estimates: Vec<f32> = idx.iter().flat_map(|&i| &r.estimates[i * ed..(i + 1) * ed]).copied().collect();
            view.assemble(&self.obs, &estimates, &mut self.actor_obs);
        }
    }

    /// Appends the mirror image of every row: S_o(o) (the normaliser is symmetric, so normalised observations
    /// mirror directly), S_a(a) and S_a(μ_old), the same old log-probability, value, return and advantage — what the
    /// mirrored robot would have seen, done and earned, valid as far as the rollout policy was symmetric. The
    /// actor's rows mirror with `actor`, the actor's view of `sym.obs` (see [`ActorView::mirror`]).
    pub fn append_mirror(&mut self, sym: &Symmetry, actor: &SignedPermutation) {
        assert!(!self.mirrored, "a batch is mirrored once");
        let n = self.rows;
        for (v, map) in [
            (&mut self.obs, &sym.obs),
            (&mut self.actor_obs, actor),
            (&mut self.actions, &sym.act),
            (&mut self.means, &sym.act),
        ] {
            let len = v.len();
            v.resize(2 * len, 0.0);
            let (orig, mirror) = v.split_at_mut(len);
            map.apply_rows(orig, mirror);
        }
        for v in [&mut self.log_probs, &mut self.values, &mut self.returns, &mut self.advantages] {
            v.extend_from_within(..n);
        }
        self.rows = 2 * n;
        self.mirrored = true;
    }

    /// The actor's input rows.
    pub fn actor_rows(&self) -> &[f32] {
        if self.actor_obs.is_empty() {
            &self.obs
        } else {
            &self.actor_obs
        }
    }

    /// The rows that came from the rollout (the first half of a mirrored batch).
    pub fn sampled_rows(&self) -> usize {
        if self.mirrored {
            self.rows / 2
        } else {
            self.rows
        }
    }
}
