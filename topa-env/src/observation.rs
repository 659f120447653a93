//! The paper's observation `[v, ω, g, q − q_nominal, q̇, a_prev, c]` for a robot with n motors, and optionally a
//! height scan after it: one layout that the env writes, the mirror maps permute and the ONNX export documents.

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
}

impl Block {
    pub const ALL: [Block; 8] = [
        Block::LinVel,
        Block::AngVel,
        Block::Gravity,
        Block::MotorPos,
        Block::MotorVel,
        Block::LastAction,
        Block::Command,
        Block::HeightScan,
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
            Block::HeightScan => "height_scan",
        }
    }

    pub fn mirror(self) -> Mirror {
        match self {
            Block::LinVel | Block::Gravity => Mirror::Vector,
            Block::AngVel => Mirror::PseudoVector,
            Block::MotorPos | Block::MotorVel | Block::LastAction => Mirror::Motors,
            Block::Command => Mirror::Command,
            Block::HeightScan => Mirror::Scan,
        }
    }
}

/// Offsets and sizes of the blocks for a robot with `n_motors` motors and a height scan of `scan` = (points along
/// x, points along y), x-major (0 × 0: no scan).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ObsLayout {
    pub n_motors: usize,
    pub scan: (usize, usize),
}

impl ObsLayout {
    pub const fn new(n_motors: usize) -> Self {
        ObsLayout { n_motors, scan: (0, 0) }
    }

    /// The same with a height scan of `nx` × `ny` points after the paper's blocks.
    pub const fn with_scan(self, (nx, ny): (usize, usize)) -> Self {
        ObsLayout { n_motors: self.n_motors, scan: (nx, ny) }
    }

    pub const fn size(&self, b: Block) -> usize {
        match b {
            Block::MotorPos | Block::MotorVel | Block::LastAction => self.n_motors,
            Block::HeightScan => self.scan.0 * self.scan.1,
            _ => 3,
        }
    }

    /// The scan's mirror: point (i, j) takes the value of point (i, ny − 1 − j) (the y values are symmetric).
    pub fn scan_mirror(&self) -> Vec<usize> {
        let (nx, ny) = self.scan;
        (0..nx).flat_map(|i| (0..ny).map(move |j| i * ny + (ny - 1 - j))).collect()
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
            Block::HeightScan => 12 + 3 * n,
        }
    }

    pub const fn dim(&self) -> usize {
        12 + 3 * self.n_motors + self.scan.0 * self.scan.1
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
    fn the_scans_mirror_swaps_left_and_right_points_and_is_its_own_inverse() {
        let l = ObsLayout::new(10).with_scan((3, 5));
        let m = l.scan_mirror();
        assert_eq!(&m[..5], &[4, 3, 2, 1, 0]);
        assert_eq!(m[7], 7, "the centre line stays");
        assert!((0..m.len()).all(|k| m[m[k]] == k));
    }
}
