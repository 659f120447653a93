//! The optional height scan: ground heights on a grid around the robot, in its heading frame, as extra observation
//! values after the paper's 42 (legged_gym's `measured_heights`), for a robot with a depth sensor or a map. Off by
//! default: the paper's policy is blind.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::{EnvError, Result};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct HeightScanConfig {
    /// Off (default): the paper's 42-value observation.
    pub enabled: bool,
    /// Points ahead (+) of and behind (−) the base along its heading, m.
    pub x: Vec<f64>,
    /// Points to its left (+) and right (−), m; symmetric about 0 (the mirror maps swap left and right points).
    pub y: Vec<f64>,
    /// Each value is the base's height over the ground at the point minus its stand height, clipped to ±clip m.
    pub clip: f64,
    /// Uniform noise on each value while `[env.noise]` is on, ±m (a depth sensor's error).
    pub noise: f64,
}

impl Default for HeightScanConfig {
    fn default() -> Self {
        // A 7 × 5 grid, 15 cm apart, from 0.3 m behind to 0.6 m ahead: the next two steps of TopA's feet
        // (legged_gym's 17 × 11 at 10 cm spans ANYmal's ±0.8 m).
        HeightScanConfig {
            enabled: false,
            x: vec![-0.3, -0.15, 0.0, 0.15, 0.3, 0.45, 0.6],
            y: vec![-0.3, -0.15, 0.0, 0.15, 0.3],
            clip: 1.0,
            noise: 0.02,
        }
    }
}

impl HeightScanConfig {
    pub fn validate(&self) -> Result<()> {
        if !self.enabled {
            return Ok(());
        }
        let bad = |what: &str| Err(EnvError::Config(format!("[env.height_scan] {what}")));
        if self.x.is_empty() || self.y.is_empty() || self.x.len() * self.y.len() > 1000 {
            return bad("needs 1 to 1000 points: give x and y lists");
        }
        let n = self.y.len();
        let sorted = self.y.windows(2).all(|w| w[0] < w[1]);
        if !sorted || (0..n).any(|i| (self.y[i] + self.y[n - 1 - i]).abs() > 1e-9) {
            return bad("y must be ascending and symmetric about 0 (e.g. [-0.3, 0, 0.3]): the mirror swaps its points");
        }
        if self.x.iter().chain(&self.y).any(|v| !v.is_finite())
            || self.clip.is_nan()
            || self.clip <= 0.0
            || self.noise.is_nan()
            || self.noise < 0.0
        {
            return bad("x, y must be finite, clip positive and noise ≥ 0");
        }
        Ok(())
    }

    /// (points along x, along y), or (0, 0) when off.
    pub fn grid(&self) -> (usize, usize) {
        if self.enabled {
            (self.x.len(), self.y.len())
        } else {
            (0, 0)
        }
    }
}
