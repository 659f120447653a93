//! Perturbation hooks: what an adversary or an experiment may do to one environment, and the channels the
//! adversary sees (command offset, gravity offset, foot forces) with their bounds from `[env.adversary]`.

use trainer::{PerturbationChannel, SignedPermutation};

use crate::config::AdversaryBounds;

/// Applied on top of the env's own command and physics until changed. All zero = no perturbation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Perturbation {
    /// Added to the commanded (v_x, v_y, w_z) the policy observes and is rewarded on.
    pub command_offset: [f64; 3],
    /// Added to the gravity direction in the observation (renormalised afterwards): a tilted IMU.
    pub gravity_offset: [f64; 3],
    /// External force on each foot (left, right), world frame, N.
    pub foot_force: [[f64; 3]; 2],
    /// Constant force on the torso in the torso's own frame, N (the paper's push experiment).
    pub torso_force_local: [f64; 3],
}

impl Perturbation {
    /// Flat layout used by the adversary: command offset (3), gravity offset (3), left foot force (3), right
    /// foot force (3).
    pub const ADVERSARY_DIM: usize = 12;

    pub fn from_adversary(v: &[f32]) -> Perturbation {
        assert_eq!(v.len(), Self::ADVERSARY_DIM, "adversary perturbation has {} values", Self::ADVERSARY_DIM);
        let f = |i: usize| [v[i] as f64, v[i + 1] as f64, v[i + 2] as f64];
        Perturbation {
            command_offset: f(0),
            gravity_offset: f(3),
            foot_force: [f(6), f(9)],
            torso_force_local: [0.0; 3],
        }
    }
}

/// TopA's adversary channels, in the layout of `Perturbation::from_adversary`. Each command offset has its own
/// bound; each gravity component is bounded by sin(max tilt)/√3, so the offset's norm stays below sin(max tilt)
/// and the observed gravity tilts by at most the max tilt; each force component by max force/√3, so each foot's
/// force stays below the max force.
pub fn channels(b: &AdversaryBounds) -> Vec<PerturbationChannel> {
    let g = (b.max_gravity_tilt.sin() / 3f64.sqrt()) as f32;
    let f = (b.max_foot_force / 3f64.sqrt()) as f32;
    vec![
        PerturbationChannel::new("command", b.max_command_offset.map(|x| x as f32).to_vec(), 3),
        PerturbationChannel::new("gravity", vec![g; 3], 3),
        PerturbationChannel::new("foot_force", vec![f; 6], 3),
    ]
}

/// The mirror of the adversary's perturbation through the world's xz-plane, the mirror `symmetry` applies to the
/// robot's state: command (v_x, −v_y, −w_z), observed gravity (g_x, −g_y, g_z), each foot's world-frame force
/// (f_x, −f_y, f_z) given to the other foot.
pub fn mirror() -> SignedPermutation {
    let flip_y = [1.0, -1.0, 1.0];
    SignedPermutation {
        perm: vec![0, 1, 2, 3, 4, 5, 9, 10, 11, 6, 7, 8],
        sign: [[1.0, -1.0, -1.0], flip_y, flip_y, flip_y].concat(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn perturbations_never_exceed_their_limits() {
        let b = AdversaryBounds::default();
        let ch = channels(&b);
        let bounds = trainer::adversary::bounds(&ch);
        assert_eq!(bounds.len(), Perturbation::ADVERSARY_DIM);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        for _ in 0..2000 {
            // Raw outputs of any size, including absurd ones.
            let scale: f32 = 10f32.powi(rng.random_range(-2..6));
            let raw: Vec<f32> = (0..12).map(|_| rng.random_range(-1.0..1.0) * scale).collect();
            let mut p = vec![0.0; 12];
            trainer::adversary::squash(&raw, &bounds, &mut p);
            for i in 0..3 {
                assert!(p[i].abs() <= b.max_command_offset[i] as f32);
            }
            let g = (p[3] as f64).hypot(p[4] as f64).hypot(p[5] as f64);
            assert!(g <= b.max_gravity_tilt.sin() + 1e-6);
            // The observed gravity (0,0,−1) + offset, renormalised, tilts by at most the max tilt.
            let tilted = [p[3] as f64, p[4] as f64, p[5] as f64 - 1.0];
            let n = (tilted[0].powi(2) + tilted[1].powi(2) + tilted[2].powi(2)).sqrt();
            assert!((-tilted[2] / n).acos() <= b.max_gravity_tilt + 1e-6);
            for foot in [&p[6..9], &p[9..12]] {
                let f = foot.iter().map(|x| (*x as f64).powi(2)).sum::<f64>().sqrt();
                assert!(f <= b.max_foot_force + 1e-4, "{f}");
            }
        }
    }
}
