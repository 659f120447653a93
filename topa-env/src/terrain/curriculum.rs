//! The terrain curriculum: legged_gym's rule (up a row after walking past half a tile, down after covering less
//! than half of what the commands asked), with two changes for commands that are redrawn within an episode and
//! for falls: "what the commands asked" is the displacement the commanded velocities would have produced on the
//! robot's own heading, integrated over the episode (legged_gym multiplies the current command by the whole
//! episode's length, which over-asks after a redraw to a slow command and under-asks after a fast one), and a fall
//! moves down (in legged_gym an early fall moved down only because of that whole-episode multiplication).

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{EnvError, Result};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct CurriculumConfig {
    /// Move robots between rows by how they walked (off: every reset draws a row at random up to
    /// `start_level_max`, e.g. for evaluation on a fixed mix).
    pub enabled: bool,
    /// Robots start on a row drawn uniformly from 0 to this (legged_gym: 5 of 10).
    pub start_level_max: usize,
    /// Up a row after walking farther than this share of a tile from the start (legged_gym: 0.5).
    pub up_share: f64,
    /// Down a row after covering less than this share of the commanded displacement (legged_gym: 0.5).
    pub down_share: f64,
    /// Half-side of the square around the tile's centre where a robot starts, m (legged_gym: ±1 m on 8 m tiles;
    /// it must fit on the platform).
    pub start_spread: f64,
}

impl Default for CurriculumConfig {
    fn default() -> Self {
        CurriculumConfig { enabled: true, start_level_max: 3, up_share: 0.5, down_share: 0.5, start_spread: 0.4 }
    }
}

impl CurriculumConfig {
    pub(super) fn validate(&self, levels: usize) -> Result<()> {
        let bad = |what: String| Err(EnvError::Config(format!("[env.terrain.curriculum] {what}")));
        if self.start_level_max >= levels {
            return bad(format!("start_level_max {} must be below levels ({levels})", self.start_level_max));
        }
        if !(0.0..=1.0).contains(&self.down_share) || self.up_share <= 0.0 {
            return bad("up_share must be positive and down_share in [0, 1]".into());
        }
        if self.start_spread < 0.0 {
            return bad("start_spread must be ≥ 0 m".into());
        }
        Ok(())
    }
}

/// Where a robot goes after an episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LevelChange {
    Up,
    Stay,
    Down,
}

/// The rule: `walked` is the distance from the start (m), `commanded` the displacement the commands asked for.
pub fn level_change(cfg: &CurriculumConfig, tile_size: f64, walked: f64, commanded: f64, fell: bool) -> LevelChange {
    if !fell && walked > cfg.up_share * tile_size {
        LevelChange::Up
    } else if fell || walked < cfg.down_share * commanded {
        LevelChange::Down
    } else {
        LevelChange::Stay
    }
}

/// The next row: one up or down, never below 0; a robot that climbs past the hardest row is sent to a random row
/// (legged_gym: it keeps the whole range in use once the hardest is solved).
pub fn next_level(level: usize, levels: usize, change: LevelChange, rng: &mut ChaCha8Rng) -> usize {
    match change {
        LevelChange::Up if level + 1 >= levels => rng.random_range(0..levels),
        LevelChange::Up => level + 1,
        LevelChange::Stay => level,
        LevelChange::Down => level.saturating_sub(1),
    }
}
