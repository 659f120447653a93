//! The adversary's side of the cyclic training: its bounded perturbations (tanh-scaled to configured limits)
//! and its reward, the negative of the policy's task reward minus an optional cost on perturbation size.
//!
//! It observes exactly what the policy observes (the 42-d observation, perturbed command and gravity
//! included): that is enough to time attacks to the gait phase and to the command, and keeps it deployable on
//! the same signals.

use topa_env::Perturbation;

use crate::config::AdversaryConfig;

/// Per-dimension bounds of the perturbation vector for a task with `dim` perturbation values.
///
/// TopA (12 values: command offset, gravity offset, left and right foot force): each command offset has its
/// own bound; each gravity component is bounded by sin(max tilt)/√3, so the offset's norm stays below
/// sin(max tilt) and the observed gravity tilts by at most the max tilt; each force component by
/// max force/√3, so each foot's force stays below the max force. Other tasks use `generic_bound` per value.
pub fn bounds(cfg: &AdversaryConfig, dim: usize) -> Vec<f32> {
    if dim == Perturbation::ADVERSARY_DIM {
        let g = (cfg.max_gravity_tilt.sin() / 3f64.sqrt()) as f32;
        let f = (cfg.max_foot_force / 3f64.sqrt()) as f32;
        let c = cfg.max_command_offset.map(|x| x as f32);
        vec![c[0], c[1], c[2], g, g, g, f, f, f, f, f, f]
    } else {
        vec![cfg.generic_bound as f32; dim]
    }
}

/// perturbation = bound ⊙ tanh(raw action), row by row.
pub fn squash(raw: &[f32], bounds: &[f32], out: &mut [f32]) {
    let d = bounds.len();
    for (i, (o, r)) in out.iter_mut().zip(raw).enumerate() {
        *o = bounds[i % d] * r.tanh();
    }
}

/// Mean magnitude of the three TopA perturbation groups over a batch: (|command offset|, |gravity offset|,
/// mean |foot force|). Zeros for other layouts.
pub fn magnitudes(p: &[f32], dim: usize) -> [f64; 3] {
    if dim != Perturbation::ADVERSARY_DIM || p.is_empty() {
        return [0.0; 3];
    }
    let norm = |s: &[f32]| s.iter().map(|x| (*x as f64).powi(2)).sum::<f64>().sqrt();
    let rows = p.len() / dim;
    let mut out = [0.0; 3];
    for row in p.chunks_exact(dim) {
        out[0] += norm(&row[0..3]);
        out[1] += norm(&row[3..6]);
        out[2] += 0.5 * (norm(&row[6..9]) + norm(&row[9..12]));
    }
    out.map(|x| x / rows as f64)
}

/// The adversary's reward for one env: −(task reward) − cost·‖perturbation / bound‖².
pub fn reward(task_reward: f32, perturbation: &[f32], bounds: &[f32], cost: f64) -> f32 {
    let size: f64 = perturbation.iter().zip(bounds).map(|(p, b)| ((*p / *b) as f64).powi(2)).sum();
    (-(task_reward as f64) - cost * size) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn perturbations_never_exceed_their_limits() {
        let cfg = AdversaryConfig::default();
        let b = bounds(&cfg, 12);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        for _ in 0..2000 {
            // Raw outputs of any size, including absurd ones.
            let scale: f32 = 10f32.powi(rng.random_range(-2..6));
            let raw: Vec<f32> = (0..12).map(|_| rng.random_range(-1.0..1.0) * scale).collect();
            let mut p = vec![0.0; 12];
            squash(&raw, &b, &mut p);
            for i in 0..3 {
                assert!(p[i].abs() <= cfg.max_command_offset[i] as f32);
            }
            let g = (p[3] as f64).hypot(p[4] as f64).hypot(p[5] as f64);
            assert!(g <= cfg.max_gravity_tilt.sin() + 1e-6);
            // The observed gravity (0,0,−1) + offset, renormalised, tilts by at most the max tilt.
            let tilted = [p[3] as f64, p[4] as f64, p[5] as f64 - 1.0];
            let n = (tilted[0].powi(2) + tilted[1].powi(2) + tilted[2].powi(2)).sqrt();
            assert!((-tilted[2] / n).acos() <= cfg.max_gravity_tilt + 1e-6);
            for foot in [&p[6..9], &p[9..12]] {
                let f = foot.iter().map(|x| (*x as f64).powi(2)).sum::<f64>().sqrt();
                assert!(f <= cfg.max_foot_force + 1e-4, "{f}");
            }
        }
    }

    #[test]
    fn reward_is_the_negative_task_reward_minus_the_cost() {
        assert_eq!(reward(2.0, &[0.0; 3], &[1.0; 3], 5.0), -2.0);
        assert!((reward(1.0, &[0.5, 0.0], &[1.0, 1.0], 2.0) - (-1.5)).abs() < 1e-6);
    }
}
