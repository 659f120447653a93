//! The adversary's side of the cyclic training: its bounded perturbations (tanh-scaled to the bounds of the
//! task's perturbation channels) and its reward, the negative of the policy's task reward minus an optional
//! cost on perturbation size.
//!
//! It observes exactly what the policy observes (perturbed command and gravity included): that is enough to
//! time attacks to the gait phase and to the command, and keeps it deployable on the same signals.

use crate::vec_env::PerturbationChannel;

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
