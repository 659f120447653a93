//! Perturbation hooks: what an adversary or an experiment may do to one environment.

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
