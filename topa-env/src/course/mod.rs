//! A course as data (`assets/courses/*.toml`): a path from start to goal, floor patches of different materials,
//! walls (given one by one, or as corridors that follow the path), door frames and thresholds. `Course::load`
//! validates it — the path on the floor, walls clear of the path and of each other — and `world()` turns it into
//! the MJCF geoms a robot walks it in (see `world.rs`).

mod mjcf;
pub mod path;

use std::collections::BTreeMap;
use std::path::Path as FsPath;

use serde::Deserialize;

use crate::error::{EnvError, Result};

use path::{dist, point_segment_distance, segment_distance, segments_cross};
pub use path::{Path, PathPoint};

/// A floor material: the friction of a rubber sole on it, and its colour.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    pub friction: f64,
    #[serde(default = "grey")]
    pub rgba: [f32; 4],
    /// Where the friction value comes from.
    #[serde(default)]
    pub source: String,
}

fn grey() -> [f32; 4] {
    [0.7, 0.7, 0.7, 1.0]
}

/// An axis-aligned floor patch, top surface at z = 0.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloorPatch {
    pub material: String,
    pub min: [f64; 2],
    pub max: [f64; 2],
}

/// A straight wall from `from` to `to` (its centre line).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wall {
    pub from: [f64; 2],
    pub to: [f64; 2],
    #[serde(default = "wall_thickness")]
    pub thickness: f64,
    #[serde(default = "wall_height")]
    pub height: f64,
}

fn wall_thickness() -> f64 {
    0.08
}
fn wall_height() -> f64 {
    1.0
}

/// Walls either side of the path between two arc lengths, `half_width` from it.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Corridor {
    pub from_m: f64,
    pub to_m: f64,
    pub half_width: f64,
}

/// A low bar across the path at arc length `at_m`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Threshold {
    pub at_m: f64,
    pub height: f64,
    #[serde(default = "threshold_depth")]
    pub depth: f64,
    #[serde(default = "threshold_width")]
    pub width: f64,
}

fn threshold_depth() -> f64 {
    0.04
}
fn threshold_width() -> f64 {
    1.2
}

/// A door frame across the path at `at_m`: two posts `clear_width` apart, optionally with a threshold.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Door {
    pub at_m: f64,
    pub clear_width: f64,
    #[serde(default = "post")]
    pub post: f64,
    #[serde(default)]
    pub threshold: f64,
}

fn post() -> f64 {
    0.1
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Raw {
    name: String,
    #[serde(default)]
    description: String,
    path: Vec<[f64; 2]>,
    #[serde(default = "goal_radius")]
    goal_radius: f64,
    materials: BTreeMap<String, Material>,
    floor: Vec<FloorPatch>,
    #[serde(default)]
    wall: Vec<Wall>,
    #[serde(default)]
    corridor: Vec<Corridor>,
    #[serde(default)]
    threshold: Vec<Threshold>,
    #[serde(default)]
    door: Vec<Door>,
}

fn goal_radius() -> f64 {
    0.5
}

/// A validated course.
#[derive(Debug, Clone)]
pub struct Course {
    pub name: String,
    pub description: String,
    pub path: Path,
    /// The goal is reached within this distance of the path's end, m.
    pub goal_radius: f64,
    pub materials: BTreeMap<String, Material>,
    pub floor: Vec<FloorPatch>,
    /// Every wall: the ones given, the corridors' and the door posts (in that order).
    pub walls: Vec<Wall>,
    pub thresholds: Vec<Threshold>,
    pub doors: Vec<Door>,
}

/// Name prefix of the geoms a wall contact is counted on (walls and door posts).
pub const WALL_PREFIX: &str = "course_wall";

/// Walls must leave this much room between their face and the path, m (half a robot's width).
pub const PATH_CLEARANCE: f64 = 0.15;

impl Course {
    /// Reads and validates a course file; every error names the file and the item.
    pub fn load(file: &FsPath) -> Result<Course> {
        let at = |m: &dyn std::fmt::Display| EnvError::Course(format!("course {}: {m}", file.display()));
        let text = std::fs::read_to_string(file).map_err(|e| at(&format!("{e} (courses live in assets/courses/)")))?;
        Course::parse(&text).map_err(|e| at(&e))
    }

    /// Parses and validates a course from TOML text.
    pub fn parse(text: &str) -> Result<Course> {
        let raw: Raw = toml::from_str(text).map_err(|e| EnvError::Course(e.to_string().trim_end().to_string()))?;
        let path = Path::new(raw.path.clone()).map_err(|e| EnvError::Course(format!("path: {e}")))?;
        let len = path.length();
        let within = |what: &str, s: f64| {
            if (0.0..=len).contains(&s) {
                Ok(())
            } else {
                Err(EnvError::Course(format!("{what}: at {s} m, but the path is {len:.1} m long")))
            }
        };
        for (name, m) in &raw.materials {
            if !(m.friction > 0.0 && m.friction <= 2.0) {
                return Err(EnvError::Course(format!("materials.{name}: friction {} is outside (0, 2]", m.friction)));
            }
        }
        for (i, f) in raw.floor.iter().enumerate() {
            if !raw.materials.contains_key(&f.material) {
                return Err(EnvError::Course(format!("floor {i}: no material '{}' in [materials]", f.material)));
            }
            if !(f.min[0] < f.max[0] && f.min[1] < f.max[1]) {
                return Err(EnvError::Course(format!(
                    "floor {i}: min {:?} must be below max {:?} in x and y",
                    f.min, f.max
                )));
            }
        }
        let mut walls = raw.wall.clone();
        for (i, c) in raw.corridor.iter().enumerate() {
            within(&format!("corridor {i} from_m"), c.from_m)?;
            within(&format!("corridor {i} to_m"), c.to_m)?;
            if c.to_m <= c.from_m || c.half_width < PATH_CLEARANCE + 0.05 {
                return Err(EnvError::Course(format!(
                    "corridor {i}: needs from_m < to_m and half_width ≥ {} m (got {}–{} m, {} m)",
                    PATH_CLEARANCE + 0.05,
                    c.from_m,
                    c.to_m,
                    c.half_width
                )));
            }
            walls.extend(corridor_walls(&path.slice(c.from_m, c.to_m), c.half_width));
        }
        for (i, t) in raw.threshold.iter().enumerate() {
            within(&format!("threshold {i}"), t.at_m)?;
            if !(t.height > 0.0 && t.height <= 0.05) {
                return Err(EnvError::Course(format!(
                    "threshold {i}: height {} m is not a threshold (0 < h ≤ 0.05 m)",
                    t.height
                )));
            }
        }
        for (i, d) in raw.door.iter().enumerate() {
            within(&format!("door {i}"), d.at_m)?;
            if d.clear_width < 2.0 * PATH_CLEARANCE || d.post <= 0.0 || !(0.0..=0.05).contains(&d.threshold) {
                return Err(EnvError::Course(format!(
                    "door {i}: needs clear_width ≥ {} m, post > 0 and threshold in [0, 0.05] m",
                    2.0 * PATH_CLEARANCE
                )));
            }
            let p = path.at(d.at_m);
            let (t, n) = ([p.heading.cos(), p.heading.sin()], [-p.heading.sin(), p.heading.cos()]);
            for side in [-1.0, 1.0] {
                let off = side * (d.clear_width + d.post) / 2.0;
                let c = [p.xy[0] + n[0] * off, p.xy[1] + n[1] * off];
                let h = d.post / 2.0;
                walls.push(Wall {
                    from: [c[0] - t[0] * h, c[1] - t[1] * h],
                    to: [c[0] + t[0] * h, c[1] + t[1] * h],
                    thickness: d.post,
                    height: 2.0,
                });
            }
        }
        let course = Course {
            name: raw.name,
            description: raw.description,
            path,
            goal_radius: raw.goal_radius,
            materials: raw.materials,
            floor: raw.floor,
            walls,
            thresholds: raw.threshold,
            doors: raw.door,
        };
        course.check_geometry()?;
        Ok(course)
    }

    /// The path on the floor, walls off the path and off each other.
    fn check_geometry(&self) -> Result<()> {
        let len = self.path.length();
        let n = (len / 0.05).ceil() as usize;
        for k in 0..=n {
            let p = self.path.at(len * k as f64 / n as f64);
            if self.material_at(p.xy).is_none() {
                return Err(EnvError::Course(format!(
                    "the path leaves its floor at {:.2} m ({:.2}, {:.2}): no [[floor]] patch covers it",
                    p.s, p.xy[0], p.xy[1]
                )));
            }
        }
        for (i, w) in self.walls.iter().enumerate() {
            if !(w.thickness > 0.0 && w.height > 0.0) || dist(w.from, w.to) < 1e-6 {
                return Err(EnvError::Course(format!(
                    "{}: needs two different end points, thickness > 0 and height > 0",
                    self.wall_name(i)
                )));
            }
            for seg in self.path.points().windows(2) {
                let d = segment_distance(w.from, w.to, seg[0], seg[1]);
                if d < w.thickness / 2.0 + PATH_CLEARANCE {
                    return Err(EnvError::Course(format!(
                        "{} is {d:.2} m from the path: a robot following it needs {:.2} m",
                        self.wall_name(i),
                        w.thickness / 2.0 + PATH_CLEARANCE
                    )));
                }
            }
        }
        for i in 0..self.walls.len() {
            for j in i + 1..self.walls.len() {
                let (a, b) = (&self.walls[i], &self.walls[j]);
                let shared = [a.from, a.to].iter().any(|p| [b.from, b.to].iter().any(|q| dist(*p, *q) < 1e-9));
                let overlap = segments_cross(a.from, a.to, b.from, b.to)
                    || (!shared && segment_distance(a.from, a.to, b.from, b.to) < (a.thickness + b.thickness) / 2.0)
                    || (shared && collinear_overlap(a, b));
                if overlap {
                    return Err(EnvError::Course(format!("{} and {} overlap", self.wall_name(i), self.wall_name(j))));
                }
            }
        }
        Ok(())
    }

    fn wall_name(&self, i: usize) -> String {
        format!("wall {i} ({:?} → {:?})", self.walls[i].from, self.walls[i].to)
    }

    /// The material of the floor at `p` (the last patch listed wins where patches overlap).
    pub fn material_at(&self, p: [f64; 2]) -> Option<&str> {
        self.floor
            .iter()
            .rev()
            .find(|f| (f.min[0]..=f.max[0]).contains(&p[0]) && (f.min[1]..=f.max[1]).contains(&p[1]))
            .map(|f| f.material.as_str())
    }

    /// The distance from `p` to the nearest wall face (negative inside a wall).
    pub fn wall_clearance(&self, p: [f64; 2]) -> f64 {
        self.walls
            .iter()
            .map(|w| point_segment_distance(p, w.from, w.to) - w.thickness / 2.0)
            .fold(f64::INFINITY, f64::min)
    }

    /// Where a robot starts: the path's first point, facing along it.
    pub fn start(&self) -> PathPoint {
        self.path.at(0.0)
    }

    /// Floor extent [min, max] over all patches.
    pub fn bounds(&self) -> ([f64; 2], [f64; 2]) {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for f in &self.floor {
            for k in 0..2 {
                lo[k] = lo[k].min(f.min[k]);
                hi[k] = hi[k].max(f.max[k]);
            }
        }
        (lo, hi)
    }
}

/// Two walls that share an end point overlap when they fold back onto each other.
fn collinear_overlap(a: &Wall, b: &Wall) -> bool {
    let (da, db) = ([a.to[0] - a.from[0], a.to[1] - a.from[1]], [b.to[0] - b.from[0], b.to[1] - b.from[1]]);
    let cross = da[0] * db[1] - da[1] * db[0];
    if cross.abs() > 1e-9 * dist(a.from, a.to) * dist(b.from, b.to) {
        return false;
    }
    // Collinear: they overlap unless they only touch at the shared point.
    let pa = [a.from, a.to];
    let pb = [b.from, b.to];
    pa.iter().any(|p| point_segment_distance(*p, b.from, b.to) < 1e-9 && pb.iter().all(|q| dist(*p, *q) > 1e-9))
        || pb.iter().any(|p| point_segment_distance(*p, a.from, a.to) < 1e-9 && pa.iter().all(|q| dist(*p, *q) > 1e-9))
}

/// Walls either side of a polyline, `hw` from it, with mitred corners (consecutive walls share their end points).
fn corridor_walls(line: &[[f64; 2]], hw: f64) -> Vec<Wall> {
    let normal = |a: [f64; 2], b: [f64; 2]| {
        let l = dist(a, b);
        [-(b[1] - a[1]) / l, (b[0] - a[0]) / l]
    };
    let n = line.len();
    let mut walls = Vec::new();
    for side in [1.0, -1.0] {
        let offset: Vec<[f64; 2]> = (0..n)
            .map(|i| {
                let m = if i == 0 {
                    normal(line[0], line[1])
                } else if i == n - 1 {
                    normal(line[n - 2], line[n - 1])
                } else {
                    let (a, b) = (normal(line[i - 1], line[i]), normal(line[i], line[i + 1]));
                    let s = [a[0] + b[0], a[1] + b[1]];
                    let k = (s[0] * a[0] + s[1] * a[1]).max(1e-6);
                    [s[0] / k, s[1] / k]
                };
                [line[i][0] + side * hw * m[0], line[i][1] + side * hw * m[1]]
            })
            .collect();
        walls.extend(offset.windows(2).map(|w| Wall {
            from: w[0],
            to: w[1],
            thickness: wall_thickness(),
            height: wall_height(),
        }));
    }
    walls
}

#[cfg(test)]
mod tests;
