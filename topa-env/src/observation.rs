//! The paper's observation `[v, ω, g, q − q_nominal, q̇, a_prev, c]` for a robot with n motors, and optionally a
//! height scan after it: one layout that the env writes, the mirror maps permute and the ONNX export documents.
//! Beyond the paper (the velocity-free observation of its future work): `v` may be left out, earlier frames of
//! proprioception may follow, and privileged values for the critic may close the row (the actor reads the row
//! up to them).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// The observation's options beyond the paper (`[env.observation]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ObservationConfig {
    /// What the policy knows of the base's linear velocity, which no robot measures: "observed" (the paper: the
    /// simulator's, or the Kalman filter's in realistic sim2sim), "estimated" (a concurrent estimator learns it
    /// from the actor's other inputs and the actor reads its estimate) or "none". Without "observed" the critic
    /// reads the true velocity at the row's end (asymmetric actor–critic).
    pub base_velocity: BaseVelocity,
    /// Earlier frames of proprioception (ω, g, q − q_nominal, q̇, a_prev) after the current observation, newest
    /// first.
    pub history: usize,
}

impl Default for ObservationConfig {
    fn default() -> Self {
        ObservationConfig { base_velocity: BaseVelocity::Observed, history: 0 }
    }
}

/// What the policy knows of the base's linear velocity (`[env.observation] base_velocity`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum BaseVelocity {
    /// In the observation (the paper).
    #[default]
    Observed,
    /// Estimated by a network trained beside the policy, from the actor's other inputs.
    Estimated,
    /// Not at all.
    None,
}

impl ObservationConfig {
    /// `layout` with these options.
    pub fn layout(&self, layout: ObsLayout) -> ObsLayout {
        let observed = self.base_velocity == BaseVelocity::Observed;
        layout.with_proprioception(observed, self.history, !observed)
    }

    /// What the actor reads of a row of `layout` (this config's): the row up to the privileged block, and with an
    /// estimated velocity the estimate of that block.
    pub fn actor_view(&self, layout: &ObsLayout) -> trainer::actor_view::ActorView {
        let at = layout.offset(Block::PrivilegedLinVel);
        let estimate = (self.base_velocity == BaseVelocity::Estimated).then(|| at..at + 3);
        trainer::actor_view::ActorView { obs_dim: layout.dim(), inputs: layout.actor_dim(), estimate }
    }
}

/// The blocks of the observation, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Block {
    /// Base linear velocity in the torso frame (3).
    LinVel,
    /// Base angular velocity in the torso frame (3).
    AngVel,
    /// Gravity direction in the torso frame (3).
    Gravity,
    /// Motor positions minus their nominal values (n).
    MotorPos,
    /// Motor velocities (n).
    MotorVel,
    /// The previous action (n).
    LastAction,
    /// The command (v_x, v_y, w_z) (3).
    Command,
    /// Ground heights around the robot (`[env.height_scan]`; none by default: the paper's policy is blind).
    HeightScan,
    /// Earlier frames of proprioception, newest first, each `[ω, g, q − q_nominal, q̇, a_prev]` (none by default).
    History,
    /// The base's true linear velocity, for the critic only (asymmetric actor–critic; none by default).
    PrivilegedLinVel,
}

/// What the earlier frames become when an observation is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HistoryUpdate {
    /// A new start: every earlier frame is the current one.
    Fill,
    /// A step: the frame observed last becomes the newest earlier frame.
    Shift,
}

/// How the XZ-plane mirror acts on a block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mirror {
    /// A robot-frame vector: y flips.
    Vector,
    /// A pseudo-vector (angular velocity): x and z flip.
    PseudoVector,
    /// Motor-indexed: the robot's left↔right map.
    Motors,
    /// The command: v_y and w_z flip.
    Command,
    /// A scan grid: points swap with their mirror images across the robot's XZ plane.
    Scan,
    /// Frames of proprioception, each mirrored as its blocks are.
    History,
}

impl Block {
    pub const ALL: [Block; 10] = [
        Block::LinVel,
        Block::AngVel,
        Block::Gravity,
        Block::MotorPos,
        Block::MotorVel,
        Block::LastAction,
        Block::Command,
        Block::HeightScan,
        Block::History,
        Block::PrivilegedLinVel,
    ];

    /// The blocks of one frame of proprioception (what `History` repeats), in order.
    pub const PROPRIOCEPTION: [Block; 5] =
        [Block::AngVel, Block::Gravity, Block::MotorPos, Block::MotorVel, Block::LastAction];

    /// The name the ONNX metadata gives the block.
    pub fn name(self) -> &'static str {
        match self {
            Block::LinVel => "base_linear_velocity",
            Block::AngVel => "base_angular_velocity",
            Block::Gravity => "projected_gravity",
            Block::MotorPos => "motor_position_minus_nominal",
            Block::MotorVel => "motor_velocity",
            Block::LastAction => "previous_action",
            Block::Command => "command_vx_vy_wz",
            Block::HeightScan => "height_scan",
            Block::History => "proprioception_history",
            Block::PrivilegedLinVel => "privileged_base_linear_velocity",
        }
    }

    pub fn mirror(self) -> Mirror {
        match self {
            Block::LinVel | Block::Gravity | Block::PrivilegedLinVel => Mirror::Vector,
            Block::AngVel => Mirror::PseudoVector,
            Block::MotorPos | Block::MotorVel | Block::LastAction => Mirror::Motors,
            Block::Command => Mirror::Command,
            Block::HeightScan => Mirror::Scan,
            Block::History => Mirror::History,
        }
    }
}

/// Offsets and sizes of the blocks for a robot with `n_motors` motors and a height scan of `scan` = (points along
/// x, points along y), x-major (0 × 0: no scan); with or without the base velocity, with `history` earlier frames
/// and the privileged block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ObsLayout {
    pub n_motors: usize,
    pub scan: (usize, usize),
    /// The policy reads the base's linear velocity (the paper's observation; false: velocity-free).
    pub base_velocity: bool,
    /// Earlier frames of proprioception after the current observation.
    pub history: usize,
    /// The critic's privileged block closes the row.
    pub privileged: bool,
}

impl ObsLayout {
    /// The paper's observation.
    pub const fn new(n_motors: usize) -> Self {
        ObsLayout { n_motors, scan: (0, 0), base_velocity: true, history: 0, privileged: false }
    }

    /// The same with a height scan of `nx` × `ny` points after the paper's blocks.
    pub const fn with_scan(self, (nx, ny): (usize, usize)) -> Self {
        ObsLayout { scan: (nx, ny), ..self }
    }

    /// The same with (or without) the base velocity, `history` earlier frames and the privileged block.
    pub const fn with_proprioception(self, base_velocity: bool, history: usize, privileged: bool) -> Self {
        ObsLayout { base_velocity, history, privileged, ..self }
    }

    /// Values in one frame of proprioception.
    pub const fn frame(&self) -> usize {
        6 + 3 * self.n_motors
    }

    pub const fn size(&self, b: Block) -> usize {
        match b {
            Block::LinVel if !self.base_velocity => 0,
            Block::PrivilegedLinVel if !self.privileged => 0,
            Block::MotorPos | Block::MotorVel | Block::LastAction => self.n_motors,
            Block::HeightScan => self.scan.0 * self.scan.1,
            Block::History => self.history * self.frame(),
            _ => 3,
        }
    }

    /// The scan's mirror: point (i, j) takes the value of point (i, ny − 1 − j) (the y values are symmetric).
    pub fn scan_mirror(&self) -> Vec<usize> {
        let (nx, ny) = self.scan;
        (0..nx).flat_map(|i| (0..ny).map(move |j| i * ny + (ny - 1 - j))).collect()
    }

    /// Where block `b` starts: the sizes of the blocks before it in `Block::ALL`.
    pub const fn offset(&self, b: Block) -> usize {
        let mut at = 0;
        let mut k = 0;
        while k < Block::ALL.len() {
            if Block::ALL[k] as usize == b as usize {
                return at;
            }
            at += self.size(Block::ALL[k]);
            k += 1;
        }
        at
    }

    /// The whole row (the critic's input).
    pub const fn dim(&self) -> usize {
        self.offset(Block::PrivilegedLinVel) + self.size(Block::PrivilegedLinVel)
    }

    /// The actor's part of the row: everything before the privileged block.
    pub const fn actor_dim(&self) -> usize {
        self.offset(Block::PrivilegedLinVel)
    }

    /// (block, offset within a frame, size) of each block of one history frame.
    pub fn frame_blocks(&self) -> Vec<(Block, usize, usize)> {
        let mut at = 0;
        Block::PROPRIOCEPTION
            .iter()
            .map(|&b| {
                let r = (b, at, self.size(b));
                at += r.2;
                r
            })
            .collect()
    }

    /// (block, offset, size) of every block the observation has, in order.
    pub fn blocks(&self) -> Vec<(Block, usize, usize)> {
        Block::ALL.iter().map(|&b| (b, self.offset(b), self.size(b))).filter(|b| b.2 > 0).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_tile_the_observation() {
        for (n, scan) in [(1, (0, 0)), (10, (0, 0)), (12, (0, 0)), (10, (7, 5))] {
            let l = ObsLayout::new(n).with_scan(scan);
            let mut next = 0;
            for (_, offset, size) in l.blocks() {
                assert_eq!(offset, next);
                next += size;
            }
            assert_eq!(next, l.dim());
        }
    }

    #[test]
    fn the_paper_layout_is_unchanged_and_the_velocity_free_layout_tiles_with_history_and_privileged() {
        let paper = ObsLayout::new(10);
        assert_eq!((paper.dim(), paper.actor_dim(), paper.offset(Block::Command)), (42, 42, 39));
        assert_eq!(paper.offset(Block::HeightScan), 42);
        let free = ObsLayout::new(10).with_proprioception(false, 4, true);
        assert_eq!(free.offset(Block::AngVel), 0, "no velocity block");
        assert_eq!(free.frame(), 36);
        assert_eq!(free.offset(Block::History), 39);
        assert_eq!(free.actor_dim(), 39 + 4 * 36);
        assert_eq!(free.dim(), free.actor_dim() + 3);
        let mut next = 0;
        for (_, offset, size) in free.with_scan((3, 3)).blocks() {
            assert_eq!(offset, next);
            next += size;
        }
        assert_eq!(next, free.with_scan((3, 3)).dim());
        let frame: usize = free.frame_blocks().iter().map(|b| b.2).sum();
        assert_eq!(frame, free.frame());
    }

    #[test]
    fn the_scans_mirror_swaps_left_and_right_points_and_is_its_own_inverse() {
        let l = ObsLayout::new(10).with_scan((3, 5));
        let m = l.scan_mirror();
        assert_eq!(&m[..5], &[4, 3, 2, 1, 0]);
        assert_eq!(m[7], 7, "the centre line stays");
        assert!((0..m.len()).all(|k| m[m[k]] == k));
    }
}
