//! The derived MJCF: the published file's tree with what training needs and the file may lack. Assets whose files
//! are absent (visual meshes left out of a repository) go with the geoms that show them; unnamed equality
//! constraints, floating bases, actuators and accelerometers get names; torque motors become PD loops at gear 1
//! (the joint's range as the target range, the gear's torque as the force range); a floor, an IMU accelerometer,
//! sole sites, `<size>` and the `stand` keyframe are added. Nothing else changes: bodies, joints, inertias, springs,
//! contacts and options are the published ones.

use std::path::Path;

use xmltree::{Element, XMLNode};

use crate::draft::Draft;
use crate::error::{Error, Result};
use crate::gains::Gains;
use crate::xml::{all, element, find_mut, for_each_mut, numbers, remove_where, section};

/// Names the derived model adds.
pub const FLOOR: &str = "floor";
pub const STAND: &str = "stand";
const IMU_SITE: &str = "imu";
const IMU_ACCELEROMETER: &str = "imu-accelerometer";

/// Drops `<mesh>` and `<texture>` assets whose files are not beside the model, the geoms that show such a mesh and
/// the materials' references to such a texture; returns the files dropped.
pub fn drop_absent_assets(root: &mut Element, dir: &Path) -> Vec<String> {
    let compiler = root.get_child("compiler");
    let attr = |k: &str| compiler.and_then(|c| c.attributes.get(k)).cloned();
    let asset_dir = attr("assetdir").unwrap_or_default();
    let mesh_dir = attr("meshdir").unwrap_or_else(|| asset_dir.clone());
    let texture_dir = attr("texturedir").unwrap_or_else(|| asset_dir.clone());
    let absent = |sub: &str, e: &Element| {
        e.attributes.get("file").is_some_and(|f| !dir.join(sub).join(f).exists() && !Path::new(f).exists())
    };
    let mut gone_meshes = Vec::new();
    let mut gone_textures = Vec::new();
    let mut dropped = Vec::new();
    let mut meshes = Vec::new();
    all(root, "mesh", &mut meshes);
    for m in meshes.iter().filter(|m| absent(&mesh_dir, m)) {
        gone_meshes.push(m.attributes.get("name").or(m.attributes.get("file")).cloned().unwrap_or_default());
        dropped.push(m.attributes["file"].clone());
    }
    dropped.dedup();
    let mut textures = Vec::new();
    all(root, "texture", &mut textures);
    for t in textures.iter().filter(|t| absent(&texture_dir, t)) {
        gone_textures.push(t.attributes.get("name").cloned().unwrap_or_default());
        dropped.push(t.attributes["file"].clone());
    }
    dropped.sort();
    dropped.dedup();
    remove_where(root, &|e| {
        (e.name == "mesh" || e.name == "texture") && absent(if e.name == "mesh" { &mesh_dir } else { &texture_dir }, e)
    });
    remove_where(root, &|e| e.name == "geom" && e.attributes.get("mesh").is_some_and(|m| gone_meshes.contains(m)));
    for_each_mut(root, &mut |e| {
        if e.name == "material" && e.attributes.get("texture").is_some_and(|t| gone_textures.contains(t)) {
            e.attributes.shift_remove("texture");
        }
    });
    dropped
}

/// Refuses what the import cannot follow: `<include>`d files (the derived copy would not see inside them).
pub fn check_supported(root: &Element, path: &Path) -> Result<()> {
    let mut includes = Vec::new();
    all(root, "include", &mut includes);
    if let Some(i) = includes.first() {
        return Err(Error::model(
            path,
            format!(
                "<include file=\"{}\">: import the robot's own file (the one with its bodies and actuators), not a \
                 scene that includes it",
                i.attributes.get("file").map_or("", String::as_str)
            ),
        ));
    }
    Ok(())
}

/// Names what a spec refers to and the published file may leave unnamed: equality constraints (after their first
/// body), the floating base, actuators (after their joint) and accelerometers.
pub fn name_unnamed(root: &mut Element) {
    let mut taken: Vec<String> = Vec::new();
    for_each_mut(root, &mut |e| {
        if let Some(n) = e.attributes.get("name") {
            taken.push(n.clone());
        }
    });
    let mut fresh = |base: String| {
        let mut n = base.clone();
        let mut k = 2;
        while taken.contains(&n) {
            n = format!("{base}-{k}");
            k += 1;
        }
        taken.push(n.clone());
        n
    };
    let mut in_actuator = false;
    name_below(root, &mut in_actuator, &mut fresh);
}

fn name_below(e: &mut Element, in_actuator: &mut bool, fresh: &mut dyn FnMut(String) -> String) {
    for c in e.children.iter_mut() {
        let XMLNode::Element(x) = c else { continue };
        if !x.attributes.contains_key("name") {
            let name = match x.name.as_str() {
                "connect" | "weld" if e.name == "equality" => {
                    Some(format!("{}-loop", x.attributes.get("body1").map_or("equality", String::as_str)))
                }
                "freejoint" => Some("floating-base".to_string()),
                "joint" if x.attributes.get("type").is_some_and(|t| t == "free") => Some("floating-base".to_string()),
                "accelerometer" => Some(IMU_ACCELEROMETER.to_string()),
                _ if *in_actuator => x.attributes.get("joint").map(|j| format!("{j}-motor")),
                _ => None,
            };
            if let Some(n) = name {
                x.attributes.insert("name".into(), fresh(n));
            }
        }
        let was = *in_actuator;
        *in_actuator = x.name == "actuator";
        name_below(x, in_actuator, fresh);
        *in_actuator = was;
    }
}

/// The IMU: an accelerometer's site, and its name (`None`: the model has none, `add_imu` makes one).
pub fn find_imu(root: &Element) -> Option<(String, String)> {
    let mut acc = Vec::new();
    all(root, "accelerometer", &mut acc);
    let a = acc.first()?;
    Some((a.attributes.get("site")?.clone(), a.attributes.get("name")?.clone()))
}

/// Everything training needs that the published file lacks (see the module's text).
pub struct Additions<'a> {
    pub draft: &'a Draft,
    pub gains: &'a [Gains],
    /// The floor's collision bits: it touches every robot geom that collides with anything.
    pub floor_bits: (i32, i32),
    pub has_floor: Option<String>,
    pub imu: Option<(String, String)>,
    pub size: (usize, usize),
    pub source: String,
}

/// The derived tree of `root` (already stripped and named): see `Additions`. Returns the floor's, the IMU site's
/// and the accelerometer's names.
pub fn derive(root: &mut Element, add: &Additions) -> (String, String, String) {
    let d = add.draft;
    let header = format!(
        " Derived by `topa robot import` from {}, which stays as published beside it: make it again rather than \
         edit it. Added: PD actuators, floor, IMU, sole sites, <size>, keyframe '{STAND}'. ",
        add.source
    );
    root.children.insert(0, XMLNode::Comment(header));
    // PD actuators, in the published order and names.
    let act = section(root, "actuator");
    let mut k = 0;
    for c in act.children.iter_mut() {
        let XMLNode::Element(x) = c else { continue };
        let (mo, g) = (&d.motors[k], add.gains[k]);
        k += 1;
        let keep_class = x.attributes.get("class").cloned();
        let mut attrs = vec![("name", mo.actuator.clone()), ("joint", mo.joint.clone())];
        if let Some(cl) = keep_class {
            attrs.push(("class", cl));
        }
        attrs.extend([
            ("gear", "1".to_string()),
            ("dyntype", "none".to_string()),
            ("gaintype", "fixed".to_string()),
            ("biastype", "affine".to_string()),
            ("ctrllimited", "true".to_string()),
            ("ctrlrange", numbers(&mo.range)),
            ("forcelimited", "true".to_string()),
            ("forcerange", numbers(&[-mo.torque_limit, mo.torque_limit])),
            ("gainprm", numbers(&[g.kp])),
            ("biasprm", numbers(&[0.0, -g.kp, -g.kd])),
        ]);
        *x = element("general", &attrs);
    }
    // The floor, first in the world.
    let floor = add.has_floor.clone().unwrap_or_else(|| FLOOR.to_string());
    let world = section(root, "worldbody");
    if add.has_floor.is_none() {
        let (contype, conaffinity) = add.floor_bits;
        let g = element(
            "geom",
            &[
                ("name", FLOOR.to_string()),
                ("type", "plane".to_string()),
                ("size", "0 0 0.05".to_string()),
                ("contype", contype.to_string()),
                ("conaffinity", conaffinity.to_string()),
                ("condim", "3".to_string()),
                ("friction", "1 0.005 0.0001".to_string()),
            ],
        );
        world.children.insert(0, XMLNode::Element(g));
    }
    // Sole sites (and names for unnamed sole geoms).
    for f in &d.feet {
        if let Some(body) = find_mut(root, &|e| e.name == "body" && e.attributes.get("name") == Some(&f.body)) {
            if !f.geom_named {
                let geom = body
                    .children
                    .iter_mut()
                    .filter_map(XMLNode::as_mut_element)
                    .filter(|e| e.name == "geom")
                    .nth(f.geom_in_body);
                if let Some(g) = geom {
                    g.attributes.insert("name".into(), f.geom.clone());
                }
            }
            let site = element(
                "site",
                &[("name", f.site.clone()), ("pos", numbers(&f.site_pos)), ("size", "0.01".to_string())],
            );
            body.children.push(XMLNode::Element(site));
        }
    }
    // The IMU: the model's accelerometer, or a site at the base's origin with one.
    let (imu_site, imu_acc) = add.imu.clone().unwrap_or_else(|| {
        if let Some(base) = find_mut(root, &|e| e.name == "body" && e.attributes.get("name") == Some(&d.base_body)) {
            base.children.push(XMLNode::Element(element(
                "site",
                &[("name", IMU_SITE.to_string()), ("size", "0.01".to_string())],
            )));
        }
        let s = section(root, "sensor");
        s.children.push(XMLNode::Element(element(
            "accelerometer",
            &[("name", IMU_ACCELEROMETER.to_string()), ("site", IMU_SITE.to_string())],
        )));
        (IMU_SITE.to_string(), IMU_ACCELEROMETER.to_string())
    });
    // Sizes: MuJoCo 2.2 allocates contacts and constraint rows up front.
    let size = section(root, "size");
    size.attributes.insert("nconmax".into(), add.size.0.to_string());
    size.attributes.insert("njmax".into(), add.size.1.to_string());
    // The stand keyframe (replacing one of that name).
    set_keyframe(root, &d.stand_qpos);
    (floor, imu_site, imu_acc)
}

/// Whether the document itself (not a file it includes) has a keyframe `name`.
pub fn has_keyframe(root: &Element, name: &str) -> bool {
    let mut keys = Vec::new();
    all(root, "key", &mut keys);
    keys.iter().any(|k| k.attributes.get("name").is_some_and(|n| n == name))
}

/// Whether the document includes other files.
pub fn has_includes(root: &Element) -> bool {
    let mut includes = Vec::new();
    all(root, "include", &mut includes);
    !includes.is_empty()
}

/// Sets (or adds) the keyframe `stand` to `qpos`.
pub fn set_keyframe(root: &mut Element, qpos: &[f64]) {
    set_keyframe_named(root, STAND, qpos);
}

/// Sets the keyframe `name` to `qpos` (its other attributes kept), or adds it.
pub fn set_keyframe_named(root: &mut Element, name: &str, qpos: &[f64]) {
    let keys = section(root, "keyframe");
    let existing = keys
        .children
        .iter_mut()
        .filter_map(XMLNode::as_mut_element)
        .find(|e| e.name == "key" && e.attributes.get("name").is_some_and(|n| n == name));
    match existing {
        Some(k) => {
            k.attributes.insert("qpos".into(), numbers(qpos));
        }
        None => {
            keys.children.push(XMLNode::Element(element("key", &[("name", name.to_string()), ("qpos", numbers(qpos))])))
        }
    }
}
