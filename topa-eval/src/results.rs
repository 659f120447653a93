//! The evaluation's data model: the paper's groups, what the experiments produce for one policy (tracking rows,
//! push grids, noise rows), as written to `ablation.json`. The experiments fill it; the report, the groups'
//! statistics and the claims read it.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::gait::GaitStats;
use crate::error::{ensure, Error, Result};

/// The paper's three policies: O (trained on the serial approximation), C (on the closed chain), C+A (C with the
/// adversary). Written as "O", "C", "CA" in files and on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Group {
    O,
    C,
    CA,
}

impl Group {
    /// In the order every report lists them.
    pub const ALL: [Group; 3] = [Group::O, Group::C, Group::CA];

    /// The name in files and flags.
    pub fn key(self) -> &'static str {
        match self {
            Group::O => "O",
            Group::C => "C",
            Group::CA => "CA",
        }
    }

    /// The paper's name.
    pub fn label(self) -> &'static str {
        match self {
            Group::CA => "C+A",
            g => g.key(),
        }
    }

    pub fn from_key(key: &str) -> Option<Group> {
        Group::ALL.into_iter().find(|g| g.key() == key)
    }
}

impl std::fmt::Display for Group {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.label())
    }
}

/// Everything the experiments measured for one policy.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolicyResults {
    /// The group it is a seed of.
    pub name: Group,
    pub policy: PathBuf,
    /// CRC-32 of the weights measured (the sidecar's `weights_crc32`): ties the numbers to one file's contents
    /// (absent in reports written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weights_crc32: Option<u32>,
    pub trained_on: String,
    pub tracking: Vec<TrackingRow>,
    /// The paper's push test: standing (command 0).
    pub push: PushGrid,
    /// The same grid while walking at `Extent::walking_push_command`.
    pub push_walking: Option<PushGrid>,
    pub noise: Vec<NoiseRow>,
}

/// The push experiment's result: a square grid of constant torso forces (F_x, F_y) and the time to fall in each
/// cell.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
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

/// The paper's six commands: (key in paper_tables.toml, title, (v_x, v_y, w_z)).
pub const COMMANDS: [(&str, &str, [f64; 3]); 6] = [
    ("walk_forward", "Walk forward: v_x = 0.5 m/s", [0.5, 0.0, 0.0]),
    ("walk_backward", "Walk backwards: v_x = −0.35 m/s", [-0.35, 0.0, 0.0]),
    ("walk_right", "Walk right: v_y = 0.5 m/s", [0.0, 0.5, 0.0]),
    ("walk_left", "Walk left: v_y = −0.5 m/s", [0.0, -0.5, 0.0]),
    ("rotate_ccw", "Rotate counterclockwise: w_z = 1.0 rad/s", [0.0, 0.0, 1.0]),
    ("rotate_cw", "Rotate clockwise: w_z = −1.0 rad/s", [0.0, 0.0, -1.0]),
];

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TrackingRow {
    pub key: String,
    pub command: [f64; 3],
    /// Ours: mean of the three component errors, after the transient, up to a fall.
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub mae: f64,
    /// Ours, per component (v_x, v_y, w_z).
    #[serde(deserialize_with = "super::nan_json::f64x3")]
    pub mae_components: [f64; 3],
    /// Paper-comparable, per component: the whole window from the command's start, continuing after a fall.
    #[serde(deserialize_with = "super::nan_json::f64x3")]
    pub mae_whole: [f64; 3],
    /// Paper-comparable "v_x,y, w_z MAE": the sum of `mae_whole`.
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub mae_paper: f64,
    /// Whole-window means (as `mae_whole`).
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub mean_torque: f64,
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub mean_roll: f64,
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub mean_pitch: f64,
    /// Whether any start fell.
    pub fell: bool,
    /// Seconds into the window of the earliest fall.
    pub fell_at: Option<f64>,
    /// The gait after the transient, up to a fall, pooled over the starts.
    pub gait: GaitStats,
    /// Initial states the command ran from (1 in reports written before starts were counted).
    #[serde(default = "one")]
    pub starts: usize,
    /// Starts that fell (None in older reports: see `fell`).
    #[serde(default)]
    pub falls: Option<usize>,
    /// Starts that stood still: the mean velocity along the command, after the transient and up to a fall, below
    /// `STAND_STILL_SHARE` of the command (None in older reports).
    #[serde(default)]
    pub stood_still: Option<usize>,
}

/// Serde default of counts absent from older reports (one start each).
pub(crate) fn one() -> usize {
    1
}

impl TrackingRow {
    /// Starts that fell, also for reports that only say whether one did.
    pub fn fall_count(&self) -> usize {
        self.falls.unwrap_or(usize::from(self.fell))
    }
}

/// Falls and stand-stills over a set of tracking rows (one command's, a policy's, a group's), counted in runs:
/// each command from each start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunCounts {
    pub runs: usize,
    pub falls: usize,
    /// None when a report among the rows did not count them.
    pub stood_still: Option<usize>,
}

impl RunCounts {
    pub fn of<'a>(rows: impl IntoIterator<Item = &'a TrackingRow>) -> Self {
        let mut c = RunCounts { runs: 0, falls: 0, stood_still: Some(0) };
        for t in rows {
            c.runs += t.starts;
            c.falls += t.fall_count();
            c.stood_still = c.stood_still.zip(t.stood_still).map(|(a, b)| a + b);
        }
        c
    }
    /// "falls/runs".
    pub fn falls_cell(&self) -> String {
        format!("{}/{}", self.falls, self.runs)
    }
    /// "stand-stills/runs", or "–" where they were not counted.
    pub fn still_cell(&self) -> String {
        self.stood_still.map_or("–".into(), |n| format!("{n}/{}", self.runs))
    }
}

/// One command-noise level's outcome.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NoiseRow {
    pub sigma_v: f64,
    pub sigma_wz: f64,
    pub runs: usize,
    pub successes: usize,
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub success_pct: f64,
}

/// Policy files of one group (`group`, the flag that gave them): files as given, folders expanded to their `*.json` policies in name order.
pub fn policy_files(group: &str, paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(Error::io("reading", p))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| f.extension().is_some_and(|x| x == "json"))
                .collect();
            found.sort();
            ensure!(!found.is_empty(), "--{group} {}: no *.json policy in this folder", p.display());
            out.extend(found);
        } else {
            ensure!(p.is_file(), "--{group} {}: no such policy file", p.display());
            out.push(p.clone());
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn policy_folders_expand_to_their_json_files_and_missing_ones_are_named() {
        let dir = std::env::temp_dir().join(format!("topa-policy-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for f in ["seed2.json", "seed1.json", "seed1.safetensors", "README.md"] {
            std::fs::write(dir.join(f), "").unwrap();
        }
        let files = policy_files("c", std::slice::from_ref(&dir)).unwrap();
        assert_eq!(files, vec![dir.join("seed1.json"), dir.join("seed2.json")]);
        let err = policy_files("ca", &[dir.join("nope.json")]).unwrap_err().to_string();
        assert!(err.contains("--ca") && err.contains("nope.json"), "{err}");
        let empty = dir.join("empty");
        std::fs::create_dir_all(&empty).unwrap();
        assert!(policy_files("o", &[empty]).unwrap_err().to_string().contains("no *.json"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn groups_read_and_write_as_their_keys() {
        for g in Group::ALL {
            assert_eq!(Group::from_key(g.key()), Some(g));
            assert_eq!(serde_json::to_string(&g).unwrap(), format!("\"{}\"", g.key()));
        }
        assert_eq!(Group::CA.label(), "C+A");
        assert_eq!(Group::from_key("C+A"), None);
    }
}
