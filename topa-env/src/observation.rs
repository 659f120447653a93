//! The paper's observation `[v, ω, g, q − q_nominal, q̇, a_prev, c]` for a robot with n motors: one layout that the
//! env writes, the mirror maps permute and the ONNX export documents.

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
}

impl Block {
    pub const ALL: [Block; 7] = [
        Block::LinVel,
        Block::AngVel,
        Block::Gravity,
        Block::MotorPos,
        Block::MotorVel,
        Block::LastAction,
        Block::Command,
    ];

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
        }
    }

    pub fn mirror(self) -> Mirror {
        match self {
            Block::LinVel | Block::Gravity => Mirror::Vector,
            Block::AngVel => Mirror::PseudoVector,
            Block::MotorPos | Block::MotorVel | Block::LastAction => Mirror::Motors,
            Block::Command => Mirror::Command,
        }
    }
}

/// Offsets and sizes of the blocks for a robot with `n_motors` motors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ObsLayout {
    pub n_motors: usize,
}

impl ObsLayout {
    pub const fn new(n_motors: usize) -> Self {
        ObsLayout { n_motors }
    }

    pub const fn size(&self, b: Block) -> usize {
        match b {
            Block::MotorPos | Block::MotorVel | Block::LastAction => self.n_motors,
            _ => 3,
        }
    }

    pub const fn offset(&self, b: Block) -> usize {
        let n = self.n_motors;
        match b {
            Block::LinVel => 0,
            Block::AngVel => 3,
            Block::Gravity => 6,
            Block::MotorPos => 9,
            Block::MotorVel => 9 + n,
            Block::LastAction => 9 + 2 * n,
            Block::Command => 9 + 3 * n,
        }
    }

    pub const fn dim(&self) -> usize {
        12 + 3 * self.n_motors
    }

    /// (block, offset, size) of every block, in order.
    pub fn blocks(&self) -> Vec<(Block, usize, usize)> {
        Block::ALL.iter().map(|&b| (b, self.offset(b), self.size(b))).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_tile_the_observation() {
        for n in [1, 10, 12] {
            let l = ObsLayout::new(n);
            let mut next = 0;
            for (_, offset, size) in l.blocks() {
                assert_eq!(offset, next);
                next += size;
            }
            assert_eq!(next, l.dim());
        }
    }
}
