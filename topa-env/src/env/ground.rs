//! The ground under the robot: its height (terrain; 0 on the flat floor), its friction by place (a course's
//! floors, a terrain's tiles), and, on terrain, the curriculum that picks the row each episode starts on.

use std::sync::Arc;

use nalgebra::{UnitQuaternion, Vector3};
use rand::RngExt;

use super::RobotEnv;
use crate::terrain;
use crate::world::FrictionMap;

/// Half-side of the square under the base whose mean ground height the base is measured from, m (smooths the
/// jump at a stair's edge).
const BASE_FOOTPRINT: f64 = 0.15;

/// Radius within which the highest ground lifts a robot put down on a terrain, m (its feet's reach).
const PUT_DOWN_RADIUS: f64 = 0.25;

impl RobotEnv {
    /// Friction of the ground by place (a course's floors): each foot gets the friction under it before every step.
    pub fn set_ground_friction(&mut self, map: Option<Arc<FrictionMap>>) {
        self.ground_friction = map;
    }

    /// Each foot's sliding friction to the map's value under it, times this episode's randomised friction scale
    /// (the model is copied for this env on first write).
    pub(super) fn apply_ground_friction(&mut self) {
        let Some(map) = &self.ground_friction else { return };
        for f in 0..2 {
            let p = self.data.xpos()[self.idx.foot_bodies[f]];
            let mu = map.at([p[0], p[1]]) * self.friction_scale;
            let g = self.idx.foot_geoms[f];
            if self.data.model().geom_friction()[g][0] != mu {
                self.data.model_mut().geom_friction_mut()[g][0] = mu;
            }
        }
    }

    /// Ground height at (x, y), m (0 on the flat floor).
    pub fn ground_height(&self, x: f64, y: f64) -> f64 {
        self.terrain.as_ref().map_or(0.0, |t| t.map.height_at(x, y))
    }

    /// The base's height above the ground under it (on terrain: the mean over a small square), m.
    pub fn base_height(&self) -> f64 {
        let [x, y, z] = self.robot_state.base_pos;
        let Some(t) = &self.terrain else { return z };
        let r = BASE_FOOTPRINT;
        let ground: f64 = [(-r, -r), (-r, 0.0), (-r, r), (0.0, -r), (0.0, 0.0), (0.0, r), (r, -r), (r, 0.0), (r, r)]
            .iter()
            .map(|(a, b)| t.map.height_at(x + a, y + b))
            .sum::<f64>()
            / 9.0;
        z - ground
    }

    /// Each foot's sole centre above the ground under it, m.
    pub(super) fn foot_heights(&self) -> [f64; 2] {
        self.idx.foot_sites.map(|site| {
            let p = self.data.site_xpos()[site];
            p[2] - self.ground_height(p[0], p[1])
        })
    }

    /// The terrain row this env is on, if it walks on a terrain.
    pub fn terrain_level(&self) -> Option<usize> {
        self.terrain.as_ref().map(|t| t.fixed.map_or(t.level, |f| f.0))
    }

    /// Evaluation: start every episode on tile (level, column) (`None`: back to the curriculum). An error if there
    /// is no terrain or no such tile.
    pub fn set_terrain_tile(&mut self, tile: Option<(usize, usize)>) -> crate::error::Result<()> {
        let Some(t) = &mut self.terrain else {
            return Err(crate::error::EnvError::Config(
                "this env has no terrain ([env.terrain] enabled = false)".into(),
            ));
        };
        if let Some((l, c)) = tile {
            if !t.map.has_tile(l, c) {
                return Err(crate::error::EnvError::Config(format!(
                    "terrain tile ({l}, {c}) is outside the grid of {} levels × {} types",
                    t.map.cfg.levels,
                    t.map.cfg.types.len()
                )));
            }
        }
        t.fixed = tile;
        Ok(())
    }

    /// At a reset on terrain: moves the env's row by how the episode that just ended went (not before its first
    /// episode), then picks where the next one starts (around its tile's centre, any heading).
    pub(super) fn place_on_terrain(&mut self) {
        let episode_ran = self.step_count > 0;
        let fell = self.fell;
        let [bx, by, _] = self.robot_state.base_pos;
        let Some(t) = &mut self.terrain else { return };
        let cur = &t.map.cfg.curriculum;
        if t.fixed.is_none() {
            if !cur.enabled {
                t.level = self.rng.random_range(0..=cur.start_level_max);
            } else if episode_ran {
                let walked = (bx - t.origin[0]).hypot(by - t.origin[1]);
                let commanded = t.commanded[0].hypot(t.commanded[1]);
                let change = terrain::level_change(cur, t.map.cfg.tile_size, walked, commanded, fell);
                t.level = terrain::next_level(t.level, t.map.cfg.levels, change, &mut self.rng);
            }
        }
        let (level, column) = t.fixed.unwrap_or((t.level, t.column));
        let c = t.map.tile_center(level, column);
        let s = cur.start_spread;
        let mut draw = |v: f64| if s > 0.0 { v + self.rng.random_range(-s..=s) } else { v };
        let (x, y) = (draw(c[0]), draw(c[1]));
        let yaw = self.rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        t.origin = [x, y];
        t.commanded = [0.0; 2];
        self.start_pose = Some([x, y, yaw]);
    }

    /// After the start pose is set: raises the base onto the highest ground within the feet's reach.
    pub(super) fn lift_onto_ground(&mut self) {
        let Some(t) = &self.terrain else { return };
        let b = self.idx.base_qpos;
        let (x, y) = (self.data.qpos()[b], self.data.qpos()[b + 1]);
        let lift = t.map.max_height_near(x, y, PUT_DOWN_RADIUS);
        self.data.qpos_mut()[b + 2] += lift;
    }

    /// After a step on terrain: adds the step's commanded displacement (the robot's own command, without an
    /// adversary's offset, on the robot's heading).
    pub(super) fn track_commanded(&mut self, dt: f64) {
        let c = self.command_override.unwrap_or(self.command);
        let yaw = self.robot_state.yaw;
        let Some(t) = &mut self.terrain else { return };
        let v = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw) * Vector3::new(c[0], c[1], 0.0);
        t.commanded[0] += v.x * dt;
        t.commanded[1] += v.y * dt;
    }

    /// The terrain state a checkpoint must hold (the tile is evaluation's and not saved).
    pub(super) fn save_terrain(&self, f: &mut Vec<f64>, u: &mut Vec<u64>) {
        if let Some(t) = &self.terrain {
            f.extend(t.origin.iter().chain(&t.commanded));
            u.extend([t.level as u64, t.column as u64]);
        }
    }

    /// Restores what `save_terrain` wrote; returns how many f64 and u64 values it read.
    pub(super) fn load_terrain(&mut self, f: &[f64], u: &[u64]) -> crate::error::Result<(usize, usize)> {
        let Some(t) = &mut self.terrain else { return Ok((0, 0)) };
        let (Some(f), Some(u)) = (f.get(..4), u.get(..2)) else {
            return Err(crate::error::EnvError::Shape("env snapshot too short for its terrain state".into()));
        };
        t.origin = [f[0], f[1]];
        t.commanded = [f[2], f[3]];
        (t.level, t.column) = (u[0] as usize, u[1] as usize);
        if !t.map.has_tile(t.level, t.column) {
            return Err(crate::error::EnvError::Shape(format!(
                "env snapshot puts the robot on terrain tile ({}, {}), outside this terrain's grid",
                t.level, t.column
            )));
        }
        Ok((4, 2))
    }
}
