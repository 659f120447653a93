//! MCAP recordings that Foxglove opens: every body's pose (`foxglove.FrameTransform` on `/tf`), a 3-D scene of
//! the robot's geoms locked to those frames (`foxglove.SceneUpdate` on `/scene`), and plottable JSON channels —
//! joint and motor positions/velocities/torques, base state, commands, foot contact forces, reward terms.
//! Written to a temporary file and renamed when finished, so a recording is either complete or absent.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use mujoco::{Data, GeomType, Model, ObjType};
use serde_json::{json, Value};

/// JSON schemas of the Foxglove message types we write (the fields we use).
const FRAME_TRANSFORM_SCHEMA: &str = r#"{"title":"foxglove.FrameTransform","type":"object","properties":{
"timestamp":{"type":"object","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},
"parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},
"translation":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}},
"rotation":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}}}}}"#;

const SCENE_UPDATE_SCHEMA: &str = r#"{"title":"foxglove.SceneUpdate","type":"object","properties":{
"deletions":{"type":"array","items":{"type":"object"}},
"entities":{"type":"array","items":{"type":"object","properties":{
"timestamp":{"type":"object"},"frame_id":{"type":"string"},"id":{"type":"string"},
"lifetime":{"type":"object"},"frame_locked":{"type":"boolean"},
"cubes":{"type":"array","items":{"type":"object"}},"spheres":{"type":"array","items":{"type":"object"}},
"cylinders":{"type":"array","items":{"type":"object"}}}}}}}"#;

const PLOT_SCHEMA: &str = r#"{"type":"object","additionalProperties":true}"#;

/// Plottable channels and their schema names.
pub const PLOT_CHANNELS: [(&str, &str); 6] = [
    ("/joints", "topa.JointState"),
    ("/motors", "topa.MotorState"),
    ("/base", "topa.BaseState"),
    ("/command", "topa.Command"),
    ("/contacts", "topa.FootContacts"),
    ("/rewards", "topa.RewardTerms"),
];

pub struct Recorder {
    writer: Option<mcap::Writer<BufWriter<File>>>,
    tmp: PathBuf,
    path: PathBuf,
    tf: u16,
    scene: u16,
    plots: BTreeMap<&'static str, u16>,
    sequence: u32,
    body_names: Vec<String>,
}

fn stamp(t: f64) -> Value {
    let ns = (t.max(0.0) * 1e9).round() as u64;
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

fn pose(pos: [f64; 3], quat: [f64; 4]) -> Value {
    json!({"position": {"x": pos[0], "y": pos[1], "z": pos[2]},
           "orientation": {"x": quat[1], "y": quat[2], "z": quat[3], "w": quat[0]}})
}

fn color(rgba: [f32; 4]) -> Value {
    json!({"r": rgba[0], "g": rgba[1], "b": rgba[2], "a": rgba[3].max(0.05)})
}

impl Recorder {
    pub fn create(path: &Path, model: &Model) -> Result<Recorder> {
        let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir).map_err(Error::io("creating", dir))?;
        let name = path.file_name().ok_or_else(|| Error::Invalid(format!("{} names no file", path.display())))?;
        let tmp = dir.join(format!(".{}.tmp-{}", name.to_string_lossy(), std::process::id()));
        let file = File::create(&tmp).map_err(Error::io("creating", &tmp))?;
        let mut w = mcap::Writer::new(BufWriter::new(file))?;
        let none = BTreeMap::new();
        let tf_schema = w.add_schema("foxglove.FrameTransform", "jsonschema", FRAME_TRANSFORM_SCHEMA.as_bytes())?;
        let tf = w.add_channel(tf_schema, "/tf", "json", &none)?;
        let scene_schema = w.add_schema("foxglove.SceneUpdate", "jsonschema", SCENE_UPDATE_SCHEMA.as_bytes())?;
        let scene = w.add_channel(scene_schema, "/scene", "json", &none)?;
        let mut plots = BTreeMap::new();
        for (topic, schema) in PLOT_CHANNELS {
            let s = w.add_schema(schema, "jsonschema", PLOT_SCHEMA.as_bytes())?;
            plots.insert(topic, w.add_channel(s, topic, "json", &none)?);
        }
        let body_names = (0..model.nbody())
            .map(|b| model.name_of(ObjType::Body, b).map_or(format!("body{b}"), str::to_string))
            .collect();
        let mut body_names: Vec<String> = body_names;
        body_names[0] = "world".into();
        Ok(Recorder { writer: Some(w), tmp, path: path.to_path_buf(), tf, scene, plots, sequence: 0, body_names })
    }

    fn write(&mut self, channel: u16, t: f64, value: &Value) -> Result<()> {
        let ns = (t.max(0.0) * 1e9).round() as u64;
        self.sequence += 1;
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: self.sequence,
            log_time: ns,
            publish_time: ns,
        };
        self.writer
            .as_mut()
            .ok_or_else(|| Error::Invalid("recording already finished".into()))?
            .write_to_known_channel(&header, &serde_json::to_vec(value)?)?;
        Ok(())
    }

    /// The robot's geoms as frame-locked scene entities, one per body (call once, at the start).
    pub fn write_scene(&mut self, model: &Model, t: f64) -> Result<()> {
        let mut entities = Vec::new();
        for b in 0..model.nbody() {
            let (mut cubes, mut spheres, mut cylinders) = (vec![], vec![], vec![]);
            let first = model.body_geomadr()[b].max(0) as usize;
            for g in first..first + model.body_geomnum()[b] as usize {
                let (p, q, s, c) =
                    (model.geom_pos()[g], model.geom_quat()[g], model.geom_size()[g], color(model.geom_rgba()[g]));
                match model.geom_type(g) {
                    GeomType::Plane => cubes.push(json!({"pose": pose(p, q), "size": {"x": 10.0, "y": 10.0, "z": 0.001}, "color": {"r": 0.6, "g": 0.6, "b": 0.65, "a": 1.0}})),
                    GeomType::Box => cubes.push(json!({"pose": pose(p, q), "size": {"x": 2.0 * s[0], "y": 2.0 * s[1], "z": 2.0 * s[2]}, "color": c})),
                    GeomType::Sphere => spheres.push(json!({"pose": pose(p, q), "size": {"x": 2.0 * s[0], "y": 2.0 * s[0], "z": 2.0 * s[0]}, "color": c})),
                    GeomType::Cylinder | GeomType::Capsule => {
                        cylinders.push(json!({"pose": pose(p, q), "size": {"x": 2.0 * s[0], "y": 2.0 * s[0], "z": 2.0 * s[1]}, "bottom_scale": 1.0, "top_scale": 1.0, "color": c}));
                        if model.geom_type(g) == GeomType::Capsule {
                            // Capsule caps: spheres at ± half-length along the geom's z axis.
                            let rot = topa_env::state::quat_of(&q);
                            for sign in [-1.0, 1.0] {
                                let end = rot.transform_vector(&nalgebra::Vector3::new(0.0, 0.0, sign * s[1]));
                                let pe = [p[0] + end.x, p[1] + end.y, p[2] + end.z];
                                spheres.push(json!({"pose": pose(pe, q), "size": {"x": 2.0 * s[0], "y": 2.0 * s[0], "z": 2.0 * s[0]}, "color": c}));
                            }
                        }
                    }
                    _ => spheres.push(json!({"pose": pose(p, q), "size": {"x": 2.0 * s[0], "y": 2.0 * s[1].max(s[0]), "z": 2.0 * s[2].max(s[0])}, "color": c})),
                }
            }
            if cubes.is_empty() && spheres.is_empty() && cylinders.is_empty() {
                continue;
            }
            entities.push(json!({"timestamp": stamp(t), "frame_id": self.body_names[b], "id": self.body_names[b],
                "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": true,
                "cubes": cubes, "spheres": spheres, "cylinders": cylinders}));
        }
        let ch = self.scene;
        self.write(ch, t, &json!({"deletions": [], "entities": entities}))
    }

    /// Every body's world pose as a transform from "world".
    pub fn write_transforms(&mut self, d: &Data, t: f64) -> Result<()> {
        let (xpos, xquat) = (d.xpos().to_vec(), d.xquat().to_vec());
        for b in 1..xpos.len() {
            let (p, q) = (xpos[b], xquat[b]);
            let msg = json!({"timestamp": stamp(t), "parent_frame_id": "world", "child_frame_id": self.body_names[b],
                "translation": {"x": p[0], "y": p[1], "z": p[2]}, "rotation": {"x": q[1], "y": q[2], "z": q[3], "w": q[0]}});
            let ch = self.tf;
            self.write(ch, t, &msg)?;
        }
        Ok(())
    }

    /// A plottable message on one of `PLOT_CHANNELS`.
    pub fn write_plot(&mut self, topic: &str, t: f64, value: Value) -> Result<()> {
        let ch = *self.plots.get(topic).ok_or_else(|| Error::Invalid(format!("unknown recording channel {topic}")))?;
        self.write(ch, t, &value)
    }

    /// Writes the summary and footer and moves the file into place. Safe to call twice.
    pub fn finish(&mut self) -> Result<PathBuf> {
        if let Some(mut w) = self.writer.take() {
            w.finish()?;
            drop(w);
            std::fs::rename(&self.tmp, &self.path).map_err(Error::io("moving the recording to", &self.path))?;
        }
        Ok(self.path.clone())
    }
}

impl Drop for Recorder {
    /// A recording interrupted by an error is still finished (valid MCAP with what was written).
    fn drop(&mut self) {
        let _ = self.finish();
    }
}
