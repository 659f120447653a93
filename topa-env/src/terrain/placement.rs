//! Where on a terrain an env's robot walks: the state the curriculum moves (the env's reset reads and writes it).

use std::sync::Arc;

use rand::RngExt;

use super::field::Terrain;

/// A robot's place on a terrain: its column (tile type, fixed), its row (level, moved by the curriculum) and
/// where this episode started.
#[derive(Debug, Clone)]
pub struct Placement {
    pub map: Arc<Terrain>,
    pub column: usize,
    pub level: usize,
    pub origin: [f64; 2],
    /// The displacement the commands asked for this episode (world frame, on the robot's heading), m.
    pub commanded: [f64; 2],
    /// Every episode on this tile (level, column), the curriculum off: evaluation.
    pub fixed: Option<(usize, usize)>,
}

impl Placement {
    /// Env `index` of a batch: its column by index (legged_gym gives each type an equal share of the robots), a
    /// starting row drawn up to the curriculum's `start_level_max`.
    pub fn new(map: Arc<Terrain>, index: u64, rng: &mut rand_chacha::ChaCha8Rng) -> Self {
        let column = index as usize % map.cfg.types.len();
        let level = rng.random_range(0..=map.cfg.curriculum.start_level_max);
        Placement { map, column, level, origin: [0.0; 2], commanded: [0.0; 2], fixed: None }
    }
}
