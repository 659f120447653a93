//! The policy's observation from sensor frames, as the training env writes it: `[v?, ω, g, q − q_nominal, q̇,
//! a_prev, c]`, then H earlier frames `[ω, g, q − q_nominal, q̇, a_prev]` newest first. Everything in the torso
//! frame; motor blocks in motor space (the controller maps them to joint space for a policy that acts there).
//! Buffers are sized once: writing a row allocates nothing.

use nalgebra::{UnitQuaternion, Vector3};

use serde::{Deserialize, Serialize};

/// What the policy reads of the base velocity, and how many earlier frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BaseVelocity {
    /// The row starts with v: the driver must supply it (its own estimator, motion capture).
    Observed,
    /// The policy's own estimator infers it.
    Estimated,
    /// The policy reads none.
    None,
}

/// Offsets of the blocks in the row for `n` motors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    pub n: usize,
    pub base_velocity: BaseVelocity,
    pub history: usize,
}

impl Layout {
    pub fn new(n: usize, base_velocity: BaseVelocity, history: usize) -> Self {
        Layout { n, base_velocity, history }
    }

    /// Values in one frame of proprioception.
    pub fn frame(&self) -> usize {
        6 + 3 * self.n
    }

    /// Where the current frame (ω) starts: after v when the row has it.
    pub fn current(&self) -> usize {
        if self.base_velocity == BaseVelocity::Observed {
            3
        } else {
            0
        }
    }

    pub fn command(&self) -> usize {
        self.current() + self.frame()
    }

    pub fn history_at(&self) -> usize {
        self.command() + 3
    }

    /// What the actor reads.
    pub fn inputs(&self) -> usize {
        self.history_at() + self.history * self.frame()
    }

    /// The normaliser's row: the inputs and, without an observed velocity, the critic's true one.
    pub fn row(&self) -> usize {
        self.inputs() + if self.base_velocity == BaseVelocity::Observed { 0 } else { 3 }
    }

    /// Offsets of the motor blocks (q, q̇, a_prev) of the current frame and of every earlier one.
    pub fn motor_blocks(&self) -> impl Iterator<Item = usize> + '_ {
        let frames =
            std::iter::once(self.current()).chain((0..self.history).map(|k| self.history_at() + k * self.frame()));
        frames.flat_map(move |at| (0..3).map(move |b| at + 6 + b * self.n))
    }
}

/// The readings of one control period that the observation needs.
pub struct Proprioception<'a> {
    /// World ← torso orientation.
    pub orientation: &'a UnitQuaternion<f64>,
    /// Angular velocity in the torso frame, rad/s.
    pub gyro: [f64; 3],
    /// Motor positions minus their stand pose (mapped as a whole where the policy acts in joint space).
    pub motor_dev: &'a [f64],
    pub motor_vel: &'a [f64],
    /// The previous action (clipped), motor space.
    pub last_action: &'a [f64],
    pub command: [f64; 3],
    /// The base velocity in the torso frame, where the policy reads it.
    pub base_velocity: [f64; 3],
}

/// Writes rows and keeps the earlier frames.
pub struct ObservationWriter {
    pub layout: Layout,
    /// The earlier frames, newest first (history × frame).
    frames: Vec<f32>,
    current: Vec<f32>,
}

impl ObservationWriter {
    pub fn new(layout: Layout) -> Self {
        let f = layout.frame();
        ObservationWriter { layout, frames: vec![0.0; layout.history * f], current: vec![0.0; f] }
    }

    /// Writes the actor's row into `row` (`layout.inputs()` values). `restart`: a new start, every earlier frame
    /// is this one (as at an episode's reset); else the last row's frame becomes the newest earlier one.
    pub fn write(&mut self, p: &Proprioception, restart: bool, row: &mut [f32]) {
        let l = self.layout;
        let n = l.n;
        let g = p.orientation.inverse_transform_vector(&Vector3::new(0.0, 0.0, -1.0));
        let c = &mut self.current;
        for i in 0..3 {
            c[i] = p.gyro[i] as f32;
            c[3 + i] = g[i] as f32;
        }
        for i in 0..n {
            c[6 + i] = p.motor_dev[i] as f32;
            c[6 + n + i] = p.motor_vel[i] as f32;
            c[6 + 2 * n + i] = p.last_action[i] as f32;
        }
        if l.base_velocity == BaseVelocity::Observed {
            for (r, v) in row.iter_mut().zip(p.base_velocity) {
                *r = v as f32;
            }
        }
        let f = l.frame();
        row[l.current()..l.current() + f].copy_from_slice(&self.current);
        for i in 0..3 {
            row[l.command() + i] = p.command[i] as f32;
        }
        if l.history == 0 {
            return;
        }
        if restart {
            for k in 0..l.history {
                self.frames[k * f..(k + 1) * f].copy_from_slice(&self.current);
            }
        }
        row[l.history_at()..l.inputs()].copy_from_slice(&self.frames);
        // This frame becomes the newest earlier one for the next row.
        self.frames.copy_within(0..(l.history - 1) * f, f);
        self.frames[..f].copy_from_slice(&self.current);
    }
}

/// The torso's tilt from upright, rad (the angle between its z axis and the world's).
pub fn tilt(orientation: &UnitQuaternion<f64>) -> f64 {
    let up = orientation.transform_vector(&Vector3::z());
    up.z.clamp(-1.0, 1.0).acos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_layout_is_the_envs() {
        // TopA (10 motors): the paper's 42; velocity-free with 4 frames: 39 + 4 · 36 inputs, 3 privileged after.
        assert_eq!(Layout::new(10, BaseVelocity::Observed, 0).inputs(), 42);
        let l = Layout::new(10, BaseVelocity::Estimated, 4);
        assert_eq!((l.inputs(), l.row()), (39 + 4 * 36, 39 + 4 * 36 + 3));
        assert_eq!(l.motor_blocks().count(), 3 * 5);
    }

    #[test]
    fn earlier_frames_follow_newest_first() {
        let l = Layout::new(1, BaseVelocity::None, 2);
        let mut w = ObservationWriter::new(l);
        let q = UnitQuaternion::identity();
        let mut row = vec![0.0f32; l.inputs()];
        let mut rows = Vec::new();
        for (k, pos) in [0.1, 0.2, 0.3].into_iter().enumerate() {
            let p = Proprioception {
                orientation: &q,
                gyro: [0.0; 3],
                motor_dev: &[pos],
                motor_vel: &[0.0],
                last_action: &[0.0],
                command: [0.0; 3],
                base_velocity: [0.0; 3],
            };
            w.write(&p, k == 0, &mut row);
            rows.push(row.clone());
        }
        let q_at = |r: &[f32], frame: usize| r[l.history_at() + frame * l.frame() + 6];
        assert_eq!((q_at(&rows[0], 0), q_at(&rows[0], 1)), (0.1, 0.1), "a restart fills every frame");
        assert_eq!((q_at(&rows[2], 0), q_at(&rows[2], 1)), (0.2, 0.1), "then the last rows' frames, newest first");
        assert!((tilt(&UnitQuaternion::from_euler_angles(0.3, 0.0, 1.0)) - 0.3).abs() < 1e-12);
    }
}
