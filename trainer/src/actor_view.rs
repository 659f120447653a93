//! What the actor reads of the observation row (an asymmetric actor–critic). The whole row is the critic's input;
//! the actor reads its first `inputs` values and, with a concurrent estimator, the estimate of the row's
//! `estimate` columns after them: values the simulator knows and a robot does not measure (the base velocity),
//! which close the row. A task says which with [`crate::VecEnv::actor_view`]; the default is the whole row.

use std::ops::Range;

use serde::{Deserialize, Serialize};

use crate::error::{invalid, Result};
use crate::symmetry::SignedPermutation;

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActorView {
    /// Values in the observation row (the critic's input).
    pub obs_dim: usize,
    /// The actor reads the row's first `inputs` values.
    pub inputs: usize,
    /// Columns of the row (after `inputs`) that a concurrent estimator learns from the first `inputs` values; the
    /// actor reads the estimate after them. None: no estimator.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimate: Option<Range<usize>>,
}

impl ActorView {
    /// The actor reads what the critic reads (the paper's networks).
    pub fn whole(obs_dim: usize) -> Self {
        ActorView { obs_dim, inputs: obs_dim, estimate: None }
    }

    /// True when the actor's input is the observation row itself.
    pub fn is_whole(&self) -> bool {
        self.inputs == self.obs_dim && self.estimate.is_none()
    }

    /// Values the estimator outputs (0: none).
    pub fn estimate_dim(&self) -> usize {
        self.estimate.as_ref().map_or(0, |r| r.len())
    }

    /// The actor's input size.
    pub fn dim(&self) -> usize {
        self.inputs + self.estimate_dim()
    }

    /// Checks the sizes: the actor reads something, and the estimated columns lie in the row after its inputs.
    pub fn validate(&self) -> Result<()> {
        if self.inputs == 0 || self.inputs > self.obs_dim {
            invalid!("actor view: the actor reads {} of {} observation values", self.inputs, self.obs_dim);
        }
        if let Some(r) = &self.estimate {
            if r.is_empty() || r.start < self.inputs || r.end > self.obs_dim {
                invalid!(
                    "actor view: the estimated columns {r:?} must be non-empty and lie after the actor's {} inputs, within the \
                     row's {}",
                    self.inputs, self.obs_dim
                );
            }
        }
        Ok(())
    }

    /// The actor's mirror map from the row's `row` map: the row's map on the first `inputs` values, and on the
    /// estimate the map of the columns it estimates. Both must map into themselves (they do when every block of
    /// the observation mirrors within itself).
    pub fn mirror(&self, row: &SignedPermutation) -> Result<SignedPermutation> {
        let mut m = SignedPermutation::identity(self.dim());
        for i in 0..self.inputs {
            let p = row.perm[i];
            if p >= self.inputs {
                invalid!("actor view: the mirror maps the actor's input {i} to {p}, outside its {}", self.inputs);
            }
            (m.perm[i], m.sign[i]) = (p, row.sign[i]);
        }
        if let Some(r) = &self.estimate {
            for (j, c) in r.clone().enumerate() {
                let p = row.perm[c];
                if !r.contains(&p) {
                    invalid!("actor view: the mirror maps the estimated column {c} to {p}, outside {r:?}");
                }
                (m.perm[self.inputs + j], m.sign[self.inputs + j]) = (self.inputs + p - r.start, row.sign[c]);
            }
        }
        Ok(m)
    }

    /// The first `inputs` values of every row of `obs` into `out` (rows × inputs).
    pub fn inputs_of(&self, obs: &[f32], out: &mut Vec<f32>) {
        out.clear();
        out.extend(obs.chunks_exact(self.obs_dim).flat_map(|r| &r[..self.inputs]));
    }

    /// The estimated columns of every row of `obs` into `out` (rows × estimate_dim).
    pub fn targets_of(&self, obs: &[f32], out: &mut Vec<f32>) {
        out.clear();
        if let Some(c) = &self.estimate {
            out.extend(obs.chunks_exact(self.obs_dim).flat_map(|r| &r[c.clone()]));
        }
    }

    /// The actor's rows: each row's first `inputs` values, then its estimate (rows × estimate_dim, empty without
    /// an estimator), into `out` (rows × dim).
    pub fn assemble(&self, obs: &[f32], estimates: &[f32], out: &mut Vec<f32>) {
        out.clear();
        let e = self.estimate_dim();
        for (k, r) in obs.chunks_exact(self.obs_dim).enumerate() {
            out.extend_from_slice(&r[..self.inputs]);
            out.extend_from_slice(&estimates[k * e..(k + 1) * e]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Row: [a0 a1 | x | v0 v1] — the actor reads a0 a1 and the estimate of v0 v1; x is privileged and not
    /// estimated.
    fn view() -> ActorView {
        ActorView { obs_dim: 5, inputs: 2, estimate: Some(3..5) }
    }

    #[test]
    fn the_actor_reads_its_inputs_then_the_estimate() {
        let v = view();
        assert_eq!(v.dim(), 4);
        v.validate().unwrap();
        let obs = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0];
        let mut out = Vec::new();
        v.assemble(&obs, &[0.1, 0.2, 0.3, 0.4], &mut out);
        assert_eq!(out, [1.0, 2.0, 0.1, 0.2, 6.0, 7.0, 0.3, 0.4]);
        v.targets_of(&obs, &mut out);
        assert_eq!(out, [4.0, 5.0, 9.0, 10.0]);
        v.inputs_of(&obs, &mut out);
        assert_eq!(out, [1.0, 2.0, 6.0, 7.0]);
    }

    #[test]
    fn the_actor_mirror_follows_the_row_mirror_and_stays_an_involution() {
        let mut row = SignedPermutation::identity(5);
        row.set_block(0, &[1, 0], &[1.0, 1.0]);
        row.set_block(3, &[0, 1], &[1.0, -1.0]);
        let m = view().mirror(&row).unwrap();
        assert!(m.is_involution());
        let mut out = [0.0; 4];
        m.apply(&[1.0, 2.0, 0.1, 0.2], &mut out);
        assert_eq!(out, [2.0, 1.0, 0.1, -0.2]);
        // A row mirror that mixes the actor's inputs with a privileged value cannot be restricted.
        let mut mixing = SignedPermutation::identity(5);
        mixing.set_block(1, &[1, 0], &[1.0, 1.0]);
        assert!(view().mirror(&mixing).unwrap_err().to_string().contains("outside"));
    }

    #[test]
    fn bad_views_are_refused() {
        for bad in [
            ActorView { obs_dim: 5, inputs: 0, estimate: None },
            ActorView { obs_dim: 5, inputs: 6, estimate: None },
            ActorView { obs_dim: 5, inputs: 3, estimate: Some(2..4) },
            ActorView { obs_dim: 5, inputs: 2, estimate: Some(4..6) },
            ActorView { obs_dim: 5, inputs: 2, estimate: Some(3..3) },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
        assert!(ActorView::whole(5).is_whole() && ActorView::whole(5).validate().is_ok());
    }
}
