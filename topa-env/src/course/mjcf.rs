//! A course as MJCF geoms: the robot's own (hidden, flat) floor stays the ground and the floor patches are drawn
//! on it, their friction given to the feet by a `FrictionMap` (a foot on a box floor costs MuJoCo twice a foot on
//! a plane); walls, door posts and thresholds are boxes; the path and the goal are drawn without contacts.
//!
//! MuJoCo 2.2 tests every geom of the world body against every geom of every other body at each collision pass
//! (four per RK4 step), whereas a static body of its own goes through sweep-and-prune and is skipped unless the
//! robot is near it: so each wall gets a body, and the drawn-only geoms share one that cannot collide (a course run
//! costs ~13 % less). Thresholds, which the feet stand on, stay in the world body beside the floor: moving them
//! would reorder the feet's contacts and with them the solver's rounding, and so every course result.

use std::fmt::Write;

use std::sync::Arc;

use mujoco::{Model, ObjType};

use super::path::dist;
use super::{Course, WALL_PREFIX};
use crate::error::Result;
use crate::spec::RobotSpec;
use crate::world::{FrictionMap, WorldXml, MAPPED_FLOOR_FRICTION};

fn quat_z(yaw: f64) -> String {
    format!("{:.6} 0 0 {:.6}", (yaw / 2.0).cos(), (yaw / 2.0).sin())
}

impl Course {
    /// The course's geoms and materials.
    pub fn world(&self) -> WorldXml {
        let mut assets = String::new();
        for (name, m) in &self.materials {
            let [r, g, b, a] = m.rgba;
            writeln!(assets, r#"  <material name="course_{name}" rgba="{r} {g} {b} {a}"/>"#).unwrap();
        }
        assets.push_str(r#"  <material name="course_wall_mat" rgba="0.85 0.9 0.95 0.35"/>"#);
        assets.push_str("\n  <material name=\"course_bar_mat\" rgba=\"0.4 0.3 0.2 1\"/>\n");
        let (mut body, mut marks) = (String::new(), String::new());
        let solid = r#"contype="0" conaffinity="1" condim="3""#;
        for (i, f) in self.floor.iter().enumerate() {
            let (cx, cy) = ((f.min[0] + f.max[0]) / 2.0, (f.min[1] + f.max[1]) / 2.0);
            let (hx, hy) = ((f.max[0] - f.min[0]) / 2.0, (f.max[1] - f.min[1]) / 2.0);
            // Later patches a little higher, so that overlaps draw the way `material_at` reads them.
            let z = -0.002 + 1e-5 * i as f64;
            writeln!(
                marks,
                r#"    <geom name="course_floor{i}" type="box" pos="{cx} {cy} {z}" size="{hx} {hy} 0.001" contype="0" conaffinity="0" material="course_{}"/>"#,
                f.material
            )
            .unwrap();
        }
        for (i, w) in self.walls.iter().enumerate() {
            let yaw = (w.to[1] - w.from[1]).atan2(w.to[0] - w.from[0]);
            let c = [(w.from[0] + w.to[0]) / 2.0, (w.from[1] + w.to[1]) / 2.0];
            // Extended by half a thickness at each end, so mitred corridor walls close their corners.
            let hl = dist(w.from, w.to) / 2.0 + w.thickness / 2.0;
            writeln!(
                body,
                r#"  <body><geom name="{WALL_PREFIX}{i}" type="box" pos="{} {} {}" quat="{}" size="{hl} {} {}" {solid} material="course_wall_mat"/></body>"#,
                c[0],
                c[1],
                w.height / 2.0,
                quat_z(yaw),
                w.thickness / 2.0,
                w.height / 2.0
            )
            .unwrap();
        }
        let bars =
            self.thresholds.iter().map(|t| (t.at_m, t.height, t.depth, t.width)).chain(
                self.doors.iter().filter(|d| d.threshold > 0.0).map(|d| (d.at_m, d.threshold, 0.04, d.clear_width)),
            );
        for (i, (s, h, depth, width)) in bars.enumerate() {
            let p = self.path.at(s);
            writeln!(
                body,
                r#"  <geom name="course_bar{i}" type="box" pos="{} {} {}" quat="{}" size="{} {} {}" {solid} material="course_bar_mat"/>"#,
                p.xy[0],
                p.xy[1],
                h / 2.0,
                quat_z(p.heading),
                depth / 2.0,
                width / 2.0,
                h / 2.0
            )
            .unwrap();
        }
        // The path and the goal, drawn only.
        for (i, w) in self.path.points().windows(2).enumerate() {
            let (a, b) = (w[0], w[1]);
            writeln!(
                marks,
                r#"    <geom name="course_line{i}" type="box" pos="{} {} 0.0005" quat="{}" size="{} 0.01 0.0005" contype="0" conaffinity="0" rgba="0.9 0.8 0.1 1"/>"#,
                (a[0] + b[0]) / 2.0,
                (a[1] + b[1]) / 2.0,
                quat_z((b[1] - a[1]).atan2(b[0] - a[0])),
                dist(a, b) / 2.0
            )
            .unwrap();
        }
        let g = self.path.at(self.path.length()).xy;
        writeln!(
            marks,
            r#"    <geom name="course_goal" type="cylinder" pos="{} {} 0.001" size="{} 0.001" contype="0" conaffinity="0" rgba="0.1 0.8 0.2 0.6"/>"#,
            g[0], g[1], self.goal_radius
        )
        .unwrap();
        write!(body, "  <body name=\"course_marks\">\n{marks}  </body>\n").unwrap();
        WorldXml { assets, worldbody: body, top: String::new(), keep_floor: true }
    }

    /// The robot on this course, and the friction under its feet.
    pub fn compile(&self, spec: &RobotSpec) -> Result<(Arc<Model>, FrictionMap)> {
        let mut model = crate::world::compile(spec, &self.world())?;
        let floor = model.id(ObjType::Geom, &spec.floor_geom)?;
        Arc::make_mut(&mut model).geom_friction_mut()[floor][0] = MAPPED_FLOOR_FRICTION;
        let patches = self.floor.iter().map(|f| (f.min, f.max, self.materials[&f.material].friction)).collect();
        // Off every patch the robot is off the course; the first material stands in until it is put back.
        let default = self.floor.first().map_or(1.0, |f| self.materials[&f.material].friction);
        Ok((model, FrictionMap { patches, default }))
    }
}
