//! A robot in a world of our making (a course, terrain): the robot's own MJCF with the world's geoms spliced into
//! its `<worldbody>`, compiled in memory with includes resolved beside the robot's file — no hand-edited copy of
//! the robot. The robot's own floor is hidden; it either stays the ground (a flat world whose friction varies from
//! place to place: `FrictionMap`) or is switched off (the world brings its own ground, e.g. terrain).

use std::sync::Arc;

use mujoco::{Model, ObjType};

use crate::error::{EnvError, Result};
use crate::spec::RobotSpec;

/// MJCF fragments a world adds: `<asset>` children (materials, heightfields) and `<worldbody>` children.
#[derive(Debug, Clone, Default)]
pub struct WorldXml {
    pub assets: String,
    pub worldbody: String,
    /// Top-level elements after the robot's own, e.g. a `<size>` that raises the contact capacity for terrain.
    pub top: String,
    /// Keep the robot's floor as the (hidden) ground instead of switching its contacts off.
    pub keep_floor: bool,
}

/// The friction of a flat ground by place: axis-aligned patches over a default. Contact friction in MuJoCo is per
/// geom, not per place, so an env with a map gives each foot the friction of the patch under it before every step
/// and keeps the floor's own below any patch's (MuJoCo takes the larger of the two geoms').
#[derive(Debug, Clone, PartialEq)]
pub struct FrictionMap {
    /// (min corner, max corner, sliding friction); the last patch containing a point wins.
    pub patches: Vec<([f64; 2], [f64; 2], f64)>,
    /// Where no patch is.
    pub default: f64,
}

impl FrictionMap {
    pub fn at(&self, p: [f64; 2]) -> f64 {
        self.patches
            .iter()
            .rev()
            .find(|(lo, hi, _)| (lo[0]..=hi[0]).contains(&p[0]) && (lo[1]..=hi[1]).contains(&p[1]))
            .map_or(self.default, |(_, _, mu)| *mu)
    }
}

/// The floor's own sliding friction under a friction map: below every patch, so that the feet's value rules.
pub const MAPPED_FLOOR_FRICTION: f64 = 0.01;

/// The robot's MJCF text with `world` spliced in (for inspection or a file a user opens in MuJoCo's viewer).
pub fn mjcf_text(spec: &RobotSpec, world: &WorldXml) -> Result<String> {
    let text = std::fs::read_to_string(&spec.mjcf)
        .map_err(|e| EnvError::Config(format!("robot MJCF {}: {e}", spec.mjcf.display())))?;
    let Some(at) = text.rfind("</worldbody>") else {
        return Err(EnvError::Config(format!(
            "robot MJCF {} has no </worldbody> to add a world to (the robot's bodies must be in the main file)",
            spec.mjcf.display()
        )));
    };
    let end = at + "</worldbody>".len();
    Ok(format!(
        "{}<!-- world -->\n{}\n{}\n<asset>\n{}\n</asset>\n{}{}",
        &text[..at],
        world.worldbody,
        &text[at..end],
        world.assets,
        world.top,
        &text[end..]
    ))
}

/// Compiles the robot in `world`, its own floor switched off.
pub fn compile(spec: &RobotSpec, world: &WorldXml) -> Result<Arc<Model>> {
    let xml = mjcf_text(spec, world)?;
    let dir = spec.mjcf.parent().unwrap_or(std::path::Path::new("."));
    let mut model = Model::from_xml_string(&xml, dir)?;
    let floor = model.id(ObjType::Geom, &spec.floor_geom)?;
    if !world.keep_floor {
        model.geom_contype_mut()[floor] = 0;
        model.geom_conaffinity_mut()[floor] = 0;
    }
    model.geom_rgba_mut()[floor][3] = 0.0;
    Ok(Arc::new(model))
}

/// Whether geom `g` is part of the ground: anything fixed to the world (the floor, terrain, a course's thresholds,
/// and its walls, which sit in static bodies of their own).
pub fn is_ground(model: &Model, g: usize) -> bool {
    model.body_weldid()[model.geom_bodyid()[g] as usize] == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> RobotSpec {
        RobotSpec::load(&crate::assets::resolve_path("assets/robots/topa_closed.toml")).unwrap().0
    }

    #[test]
    fn a_world_replaces_the_robots_floor_and_keeps_the_robot() {
        let spec = spec();
        let world = WorldXml {
            assets: r#"<material name="w_mat" rgba="0.5 0.5 0.5 1"/>"#.into(),
            worldbody: r#"<geom name="w_floor" type="box" size="2 2 0.05" pos="0 0 -0.05" material="w_mat"
                 contype="0" conaffinity="1" priority="1" friction="0.4 0.005 0.0001"/>"#
                .into(),
            top: String::new(),
            keep_floor: false,
        };
        let m = compile(&spec, &world).unwrap();
        let (_, plain) = RobotSpec::load(&spec.path).unwrap();
        assert_eq!(m.nq(), plain.nq());
        assert_eq!(m.ngeom(), plain.ngeom() + 1);
        let floor = m.id(ObjType::Geom, &spec.floor_geom).unwrap();
        assert_eq!(m.geom_conaffinity()[floor], 0);
        let box_ = m.id(ObjType::Geom, "w_floor").unwrap();
        assert!(is_ground(&m, box_) && is_ground(&m, floor));
        assert_eq!(m.geom_friction()[box_][0], 0.4);
        let kept = compile(&spec, &WorldXml { keep_floor: true, ..world }).unwrap();
        assert_eq!(kept.geom_conaffinity()[floor], 1);
        assert_eq!(kept.geom_rgba()[floor][3], 0.0);
    }

    #[test]
    fn a_friction_map_gives_the_last_patch_under_a_point_or_its_default() {
        let map =
            FrictionMap { patches: vec![([0.0, 0.0], [2.0, 2.0], 0.4), ([1.0, 1.0], [3.0, 3.0], 0.7)], default: 1.0 };
        assert_eq!(map.at([0.5, 0.5]), 0.4);
        assert_eq!(map.at([1.5, 1.5]), 0.7);
        assert_eq!(map.at([5.0, 5.0]), 1.0);
    }

    #[test]
    fn a_broken_world_is_named_as_a_compile_error() {
        let world = WorldXml { worldbody: r#"<geom type="box" size="1 1"#.into(), ..Default::default() };
        let err = compile(&spec(), &world).err().unwrap().to_string();
        assert!(err.contains("could not load"), "{err}");
    }
}
