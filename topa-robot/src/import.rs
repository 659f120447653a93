//! `topa robot import`: a published MJCF made a robot of this stack, untouched. The derived MJCF is written beside
//! it (`NAME.topa.xml`, so relative asset paths and the licence stay with it), the spec into the robots folder;
//! then the stand keyframe and feed-forward are solved (`stand`) and the result loaded as every command loads it.

use std::path::{Component, Path, PathBuf};

use mujoco::{Data, Model};
use topa_env::linkage::JointMap;
use topa_env::spec::RobotSpec;

use crate::derive::{self, Additions};
use crate::draft::{self, Draft, CHOOSE};
use crate::error::{Error, Result};
use crate::gains::{self, GainRule, Gains};
use crate::stand::{stand, StandReport};

#[derive(Debug, Clone)]
pub struct ImportOptions {
    /// The published MJCF.
    pub model: PathBuf,
    /// The robot's name: the spec is `robots_dir/NAME.toml`, the derived MJCF `NAME.topa.xml` beside the model.
    pub name: String,
    pub robots_dir: PathBuf,
    pub gains: GainRule,
}

#[derive(Debug, Clone)]
pub struct ImportReport {
    pub spec: PathBuf,
    pub mjcf: PathBuf,
    /// Asset files the model names that are not beside it (dropped with what shows them).
    pub dropped_assets: Vec<String>,
    /// Per actuator: name, gains.
    pub gains: Vec<(String, Gains)>,
    /// The spec's lines left to choose (each a `CHOOSE` value the loader refuses); empty when it loads.
    pub to_choose: Vec<String>,
    /// The stand solve (absent while a line is left to choose).
    pub stand: Option<StandReport>,
}

pub fn import(opts: &ImportOptions) -> Result<ImportReport> {
    let path = &opts.model;
    if opts.name.is_empty() || !opts.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
        return Err(Error::model(path, format!("--name '{}': use letters, digits, '-' and '_'", opts.name)));
    }
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf();
    let mut root = crate::xml::parse(path)?;
    derive::check_supported(&root, path)?;
    let dropped_assets = derive::drop_absent_assets(&mut root, &dir);
    derive::name_unnamed(&mut root);
    let model = Model::from_xml_string(&crate::xml::write(&root), &dir)?;
    let draft = draft::draft(&model, path)?;

    let torque: Vec<f64> = draft.motors.iter().map(|m| m.torque_limit).collect();
    let mut data = Data::new(std::sync::Arc::new(model.try_clone()?))?;
    data.qpos_mut().copy_from_slice(&draft.stand_qpos);
    data.forward()?;
    let gains = gains::suggest(&data, &torque, opts.gains);

    let floor_bits = (1..model.ngeom())
        .filter(|&g| model.geom_bodyid()[g] != 0)
        .fold((0, 0), |(t, a), g| (t | model.geom_conaffinity()[g], a | model.geom_contype()[g]));
    let has_floor = (0..model.ngeom())
        .find(|&g| model.geom_bodyid()[g] == 0 && model.geom_type(g) == mujoco::GeomType::Plane)
        .map(|g| model.name_of(mujoco::ObjType::Geom, g).map(str::to_string))
        .map(|n| n.ok_or_else(|| Error::model(path, "the floor plane has no name: name it")))
        .transpose()?;
    let colliding =
        (0..model.ngeom()).filter(|&g| (model.geom_contype()[g] | model.geom_conaffinity()[g]) != 0).count();
    // Contacts: a few per colliding geom; rows: four per contact (pyramidal, condim 3), the loops' and limits'.
    let nconmax = (4 * colliding).max(100).max(model.nconmax());
    let njmax = (4 * nconmax + 6 * model.neq() + 2 * model.njnt()).max(model.njmax());
    let imu = derive::find_imu(&root);
    let stem = path.file_name().map_or(String::new(), |f| f.to_string_lossy().into_owned());
    let (floor, imu_site, imu_acc) = derive::derive(
        &mut root,
        &Additions { draft: &draft, gains: &gains, floor_bits, has_floor, imu, size: (nconmax, njmax), source: stem },
    );
    let mjcf = dir.join(format!("{}.topa.xml", opts.name));
    trainer::tensorfile::write_atomic(&mjcf, crate::xml::write(&root).as_bytes())?;
    let spec_path = opts.robots_dir.join(format!("{}.toml", opts.name));
    let text =
        render(&model, &opts.name, &draft, &relative(&mjcf, &opts.robots_dir), &floor, &imu_site, &imu_acc, path)?;
    trainer::tensorfile::write_atomic(&spec_path, text.as_bytes())?;
    let to_choose: Vec<String> =
        text.lines().filter(|l| l.contains(CHOOSE) && !l.trim_start().starts_with('#')).map(str::to_string).collect();
    let stand = if to_choose.is_empty() {
        let report = stand(&spec_path)?;
        let (spec, model) = RobotSpec::load(&spec_path)?;
        JointMap::new(&spec, &model)?;
        Some(report)
    } else {
        None
    };
    Ok(ImportReport {
        spec: spec_path,
        mjcf,
        dropped_assets,
        gains: draft.motors.iter().map(|m| m.actuator.clone()).zip(gains).collect(),
        to_choose,
        stand,
    })
}

/// `to` relative to the folder `from` (both made absolute from the working folder), with `/` separators.
fn relative(to: &Path, from: &Path) -> String {
    let abs = |p: &Path| {
        let p = if p.is_absolute() { p.to_path_buf() } else { std::env::current_dir().unwrap_or_default().join(p) };
        let mut out: Vec<Component> = Vec::new();
        for c in p.components() {
            match c {
                Component::CurDir => {}
                Component::ParentDir if matches!(out.last(), Some(Component::Normal(_))) => {
                    out.pop();
                }
                c => out.push(c),
            }
        }
        out.iter().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect::<Vec<_>>()
    };
    let (t, f) = (abs(to), abs(from));
    let common = t.iter().zip(&f).take_while(|(a, b)| a == b).count();
    let mut parts: Vec<String> = vec!["..".to_string(); f.len() - common];
    parts.extend(t[common..].iter().cloned());
    parts.join("/")
}

fn quote(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

fn list(v: &[String]) -> String {
    format!("[{}]", v.iter().map(|s| quote(s)).collect::<Vec<_>>().join(", "))
}

/// The spec's text: every value the model decided, and a `CHOOSE` value where it could not.
#[allow(clippy::too_many_arguments)]
fn render(
    model: &Model,
    name: &str,
    d: &Draft,
    mjcf: &str,
    floor: &str,
    imu_site: &str,
    imu_acc: &str,
    source: &Path,
) -> Result<String> {
    use std::fmt::Write;
    let mut t = String::new();
    let base_z = d.stand_qpos[2];
    let source = source.file_name().map_or(String::new(), |f| f.to_string_lossy().into_owned());
    let w = &mut t;
    let _ =
        writeln!(w, "# {name}: drafted by `topa robot import` from {source}. The loader checks every name and number");
    let _ = writeln!(w, "# against the MJCF; a value starting with {CHOOSE} is one the model could not decide.");
    let _ = writeln!(w, "name = {}", quote(name));
    let _ = writeln!(w, "mjcf = {}", quote(mjcf));
    let _ = writeln!(w, "base_body = {}", quote(&d.base_body));
    let _ = writeln!(w, "base_joint = {}", quote(&d.base_joint));
    let _ = writeln!(w, "floor_geom = {}", quote(floor));
    let _ = writeln!(w, "imu_site = {}", quote(imu_site));
    let _ = writeln!(w, "imu_accelerometer = {}", quote(imu_acc));
    let _ = writeln!(w, "stand_keyframe = {}", quote(derive::STAND));
    let _ = writeln!(w, "base_height_target = {base_z}    # the base's height in the stand keyframe");
    for (i, f) in d.feet.iter().enumerate() {
        let _ = writeln!(w, "\n[[feet]]    # {}: the lowest collision geom on this side", ["left", "right"][i]);
        let _ = writeln!(w, "body = {}\ngeom = {}\nsite = {}", quote(&f.body), quote(&f.geom), quote(&f.site));
    }
    for m in &d.motors {
        let _ = writeln!(w, "\n[[motors]]");
        let _ = writeln!(w, "actuator = {}", quote(&m.actuator));
        let _ = writeln!(w, "drives = {}", quote(&m.joint));
        let _ = writeln!(w, "joint = {}", quote(m.kinematic.as_deref().unwrap_or(&m.joint)));
        let j = model.id(mujoco::ObjType::Joint, &m.joint)?;
        let _ = writeln!(w, "nominal = {}", d.stand_qpos[model.jnt_qposadr_of(j)]);
        let _ = writeln!(w, "motor_range = [{}, {}]", m.range[0], m.range[1]);
        let _ = writeln!(w, "joint_range = [{}, {}]", m.range[0], m.range[1]);
        let _ = writeln!(w, "torque_limit = {}", m.torque_limit);
        match &m.mirror {
            draft::Mirror::Found { motor, sign } => {
                let _ = writeln!(w, "mirror = {}\nmirror_sign = {sign}", quote(&d.motors[*motor].joint));
            }
            draft::Mirror::Choose(choose) => {
                let _ = writeln!(w, "mirror = {}\nmirror_sign = 1", quote(choose));
            }
        }
    }
    if !d.groups.is_empty() {
        let _ = writeln!(w, "\n# Joint-deviation reward groups, by joint axis in the base frame.\n[groups]");
        for (g, idx) in &d.groups {
            let names: Vec<String> = idx.iter().map(|&i| d.motors[i].joint.clone()).collect();
            let _ = writeln!(w, "{g} = {}", list(&names));
        }
    }
    for l in &d.loops {
        let _ = writeln!(w, "\n[[loops]]");
        let _ = writeln!(w, "name = {}", quote(&l.name));
        let _ = writeln!(w, "equality = {}", list(&l.equality));
        let _ = writeln!(w, "passive = {}", list(&l.passive));
        if !l.springs.is_empty() {
            let _ = writeln!(w, "springs = {}", list(&l.springs));
        }
    }
    Ok(t)
}
