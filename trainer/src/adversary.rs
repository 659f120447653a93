//! The adversary's side of the cyclic training: its bounded perturbations (tanh-scaled to the bounds of the
//! task's perturbation channels) and its reward, the negative of the policy's task reward minus an optional
//! cost on perturbation size.
//!
//! It observes exactly what the policy observes (perturbed command and gravity included): that is enough to
//! time attacks to the gait phase and to the command, and keeps it deployable on the same signals.

use crate::symmetry::SignedPermutation;
use crate::vec_env::PerturbationChannel;

/// How every other env is attacked through the mirror (`adversary.mirror_attacks`): the adversary sees the mirror
/// image of an odd env's observation, and that env gets the mirror image of the adversary's perturbation. The
/// adversary's view stays one consistent world (it never sees both images of one state as different states), while
/// the attacks the policy meets become left↔right symmetric: an adversary that learned to attack one side does so
/// on both. Exact, not approximate: mirroring the world twice is the identity.
#[derive(Debug, Clone)]
pub struct AttackMirror {
    obs: SignedPermutation,
    perturbation: SignedPermutation,
}

impl AttackMirror {
    /// Checks the task's maps: the sizes, both involutions, and bounds the mirror maps onto themselves (a mirrored
    /// perturbation stays inside them).
    pub fn new(
        obs: SignedPermutation,
        perturbation: SignedPermutation,
        obs_dim: usize,
        bounds: &[f32],
    ) -> crate::error::Result<Self> {
        if obs.len() != obs_dim || perturbation.len() != bounds.len() {
            return Err(crate::error::Error::Invalid(format!(
                "the task's mirrors cover {} observation and {} perturbation values, it has {obs_dim} and {}",
                obs.len(),
                perturbation.len(),
                bounds.len()
            )));
        }
        if !obs.is_involution() || !perturbation.is_involution() {
            return Err(crate::error::Error::Invalid(
                "the task's observation or perturbation mirror is not its own inverse".into(),
            ));
        }
        if let Some(i) = (0..bounds.len()).find(|&i| bounds[perturbation.perm[i]] != bounds[i]) {
            return Err(crate::error::Error::Invalid(format!(
                "perturbation value {i} is bounded at {} and its mirror image at {}: mirrored attacks need equal bounds",
                bounds[i],
                bounds[perturbation.perm[i]]
            )));
        }
        Ok(AttackMirror { obs, perturbation })
    }

    /// Whether env `e` is attacked through the mirror: the odd ones, so that in phase 3 half of the attacked
    /// share (the first envs) is mirrored too.
    pub fn mirrors(e: usize) -> bool {
        e % 2 == 1
    }

    /// The adversary's view of observation rows: `dst` = `src` with the rows of mirrored envs mirrored; row `i`
    /// belongs to env `env_of_row(i)`.
    pub fn view(&self, src: &[f32], dst: &mut Vec<f32>, env_of_row: impl Fn(usize) -> usize) {
        let d = self.obs.len();
        dst.clear();
        dst.extend_from_slice(src);
        for (i, (s, o)) in src.chunks_exact(d).zip(dst.chunks_exact_mut(d)).enumerate() {
            if Self::mirrors(env_of_row(i)) {
                self.obs.apply(s, o);
            }
        }
    }

    /// Mirrors, in place, the perturbation rows (one per env) of the mirrored envs.
    pub fn apply(&self, p: &mut [f32]) {
        let d = self.perturbation.len();
        let mut row = vec![0.0; d];
        for (e, r) in p.chunks_exact_mut(d).enumerate() {
            if Self::mirrors(e) {
                self.perturbation.apply(r, &mut row);
                r.copy_from_slice(&row);
            }
        }
    }
}

/// The bound of every value of the perturbation vector, channel after channel.
pub fn bounds(channels: &[PerturbationChannel]) -> Vec<f32> {
    channels.iter().flat_map(|c| c.bounds.iter().copied()).collect()
}

/// perturbation = bound ⊙ tanh(raw action), row by row.
pub fn squash(raw: &[f32], bounds: &[f32], out: &mut [f32]) {
    let d = bounds.len();
    for (i, (o, r)) in out.iter_mut().zip(raw).enumerate() {
        *o = bounds[i % d] * r.tanh();
    }
}

/// Mean magnitude of each channel over a batch of perturbation rows: the mean Euclidean norm of the channel's
/// groups (e.g. the mean of both feet's force norms), averaged over rows.
pub fn magnitudes(p: &[f32], channels: &[PerturbationChannel]) -> Vec<f64> {
    let dim: usize = channels.iter().map(PerturbationChannel::dim).sum();
    let mut out = vec![0.0; channels.len()];
    if dim == 0 || p.is_empty() {
        return out;
    }
    let norm = |s: &[f32]| s.iter().map(|x| (*x as f64).powi(2)).sum::<f64>().sqrt();
    let rows = p.len() / dim;
    for row in p.chunks_exact(dim) {
        let mut at = 0;
        for (c, m) in channels.iter().zip(out.iter_mut()) {
            let block = &row[at..at + c.dim()];
            let groups = block.chunks(c.group);
            let k = groups.len().max(1) as f64;
            *m += groups.map(norm).sum::<f64>() / k;
            at += c.dim();
        }
    }
    out.iter().map(|x| x / rows as f64).collect()
}

/// The adversary's reward for one env: −(task reward) − cost·‖perturbation / bound‖². A value bounded at 0 is
/// switched off (a config that removes a channel): it is always 0 and costs nothing.
pub fn reward(task_reward: f32, perturbation: &[f32], bounds: &[f32], cost: f64) -> f32 {
    let size: f64 =
        perturbation.iter().zip(bounds).filter(|(_, b)| **b > 0.0).map(|(p, b)| ((*p / *b) as f64).powi(2)).sum();
    (-(task_reward as f64) - cost * size) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_attack_mirror_maps_odd_envs_only_and_refuses_inconsistent_maps() {
        let sign = |s: &[f32]| SignedPermutation { perm: (0..s.len()).collect(), sign: s.to_vec() };
        let swap = SignedPermutation { perm: vec![1, 0], sign: vec![1.0, 1.0] };
        let m = AttackMirror::new(sign(&[1.0, -1.0]), swap.clone(), 2, &[1.0, 1.0]).unwrap();
        let mut view = Vec::new();
        m.view(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], &mut view, |i| i);
        assert_eq!(view, [1.0, 2.0, 3.0, -4.0, 5.0, 6.0]);
        // Rows of envs 3 and 4 (e.g. the time-outs of one step): env 3's row mirrored.
        m.view(&[1.0, 2.0, 3.0, 4.0], &mut view, |i| [3, 4][i]);
        assert_eq!(view, [1.0, -2.0, 3.0, 4.0]);
        let mut p = [0.1, 0.2, 0.3, 0.4];
        m.apply(&mut p);
        assert_eq!(p, [0.1, 0.2, 0.4, 0.3]);
        let err = AttackMirror::new(sign(&[1.0, -1.0]), swap.clone(), 2, &[1.0, 2.0]).unwrap_err().to_string();
        assert!(err.contains("bounded at 1") && err.contains("equal bounds"), "{err}");
        assert!(AttackMirror::new(sign(&[1.0]), swap.clone(), 2, &[1.0, 1.0])
            .unwrap_err()
            .to_string()
            .contains("cover 1"));
        let not_inverse = SignedPermutation { perm: vec![1, 0], sign: vec![1.0, -1.0] };
        assert!(AttackMirror::new(sign(&[1.0, 1.0]), not_inverse, 2, &[1.0, 1.0]).is_err());
    }

    #[test]
    fn a_channel_bounded_at_zero_is_off_and_costs_nothing() {
        let bounds = [0.0, 0.0, 2.0];
        let mut p = [0.0f32; 3];
        squash(&[0.7, -1.3, 0.5], &bounds, &mut p);
        assert_eq!(&p[..2], &[0.0, 0.0]);
        let r = reward(1.0, &p, &bounds, 0.5);
        let want = -1.0 - 0.5 * (0.5f64.tanh()).powi(2);
        assert!(r.is_finite() && (r as f64 - want).abs() < 1e-6, "{r} vs {want}");
    }

    #[test]
    fn squashed_values_stay_inside_their_bounds() {
        let b = [0.5f32, 2.0, 10.0];
        let raw = [1e6f32, -3.0, 0.1, -1e9, 0.0, 40.0];
        let mut out = [0.0; 6];
        squash(&raw, &b, &mut out);
        for (i, o) in out.iter().enumerate() {
            assert!(o.abs() <= b[i % 3], "{o}");
        }
        assert_eq!(out[0], 0.5);
        assert!((out[2] - 10.0 * 0.1f32.tanh()).abs() < 1e-6);
    }

    #[test]
    fn magnitudes_are_mean_group_norms_per_channel() {
        let ch = vec![PerturbationChannel::new("a", vec![1.0; 2], 2), PerturbationChannel::new("f", vec![1.0; 6], 3)];
        // Two rows: channel a norms 5 and 0; channel f foot norms (3, 0) and (2, 2).
        let p = [3.0, 4.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 2.0, 0.0];
        let m = magnitudes(&p, &ch);
        assert!((m[0] - 2.5).abs() < 1e-12);
        assert!((m[1] - (1.5 + 2.0) / 2.0).abs() < 1e-12);
        assert_eq!(bounds(&ch).len(), 8);
    }

    #[test]
    fn reward_is_the_negative_task_reward_minus_the_cost() {
        assert_eq!(reward(2.0, &[0.0; 3], &[1.0; 3], 5.0), -2.0);
        assert!((reward(1.0, &[0.5, 0.0], &[1.0, 1.0], 2.0) - (-1.5)).abs() < 1e-6);
    }
}
