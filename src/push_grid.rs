//! The push experiment's result: a square grid of constant torso forces (F_x, F_y) and the time to fall in each
//! cell. Its own module so that the evaluation that fills it and the plots that draw it do not import each other.

use serde::Serialize;

#[derive(Debug, Clone, Serialize, serde::Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PushGrid {
    /// Force values along each axis, N (ascending).
    pub axis: Vec<f64>,
    /// Time to fall per cell, s, indexed `[iy * axis.len() + ix]` for force (axis[ix], axis[iy]).
    pub t_fall: Vec<f64>,
    pub window_s: f64,
    /// The command held during the push.
    pub command: [f64; 3],
}

impl PushGrid {
    pub fn mean_t_fall(&self) -> f64 {
        self.t_fall.iter().sum::<f64>() / self.t_fall.len() as f64
    }
    pub fn force(&self, cell: usize) -> [f64; 2] {
        let n = self.axis.len();
        [self.axis[cell % n], self.axis[cell / n]]
    }
    pub fn cells(&self) -> usize {
        self.t_fall.len()
    }
}
