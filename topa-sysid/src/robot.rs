//! A robot hung in the air as a bench: its own MJCF with the floating base removed (the torso fixed where the
//! file puts it) and contacts off, every motor at once, the closed loops included. A window starts with the
//! logged motor positions and the loops closed around them (the robot's own loop-closure solver).

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use mujoco::{Model, ObjType};
use topa_env::linkage::Linkage;
use topa_env::spec::RobotSpec;
use xmltree::{Element, EmitterConfig, XMLNode};

use super::bench::{Bench, StartPose};
use super::log::MotorLog;
use crate::error::{Error, Result};

/// The longest physics step the hung robot runs at, s: semi-implicit Euler at 1 ms. Hung, it has no impacts (where
/// its MJCF's RK4 earns its cost), and Euler at 1 ms costs half of RK4 at 2 ms.
const MAX_TIMESTEP: f64 = 0.001;

/// The robot of `spec_path` with its base fixed, as a bench for `log`'s motors.
pub fn hung_bench(spec_path: &Path, log: &MotorLog) -> Result<Bench> {
    let (spec, free_model) = RobotSpec::load(spec_path)?;
    let mjcf = spec.mjcf.clone();
    // MuJoCo writes the loaded file flattened (includes inlined); the base joint and keyframes go, the rest stays.
    let flat = std::env::temp_dir().join(format!("topa-hung-{}.xml", std::process::id()));
    Model::from_xml_path(&mjcf)?.save_last_xml(&flat)?;
    let text = std::fs::read_to_string(&flat).map_err(|e| Error::bench("reading the flattened robot MJCF back", e))?;
    let _ = std::fs::remove_file(&flat);
    let fixed_text = without_floating_base(&text)?
        .ok_or_else(|| Error::bad_bench(format!("{}: not one floating base (a freejoint) to fix", mjcf.display())))?;
    let dir = mjcf.parent().unwrap_or(Path::new("."));
    let mut model = Model::from_xml_string(&fixed_text, dir)?;
    model.set_contacts_enabled(false);
    // Nothing here reads a sensor; the accelerometer alone costs a second Newton–Euler pass every step.
    model.set_sensors_enabled(false);
    let step = log.step();
    model.set_timestep(step / (step / MAX_TIMESTEP).ceil())?;
    model.set_integrator(mujoco::Integrator::Euler);
    let motors = Bench::motors_of(&model, spec_path, log)?;

    // The fixed model's joints in the free model's qpos (same names; the free model has the base in front).
    let mut map = Vec::new();
    for j in 0..model.njnt() {
        let name = model
            .name_of(ObjType::Joint, j)
            .ok_or_else(|| Error::bad_bench("every joint of the robot needs a name"))?;
        let k = free_model.id(ObjType::Joint, name)?;
        map.push((model.jnt_qposadr_of(j), free_model.jnt_qposadr_of(k)));
    }
    // Log order → the spec's motor order.
    let order: Vec<usize> = spec
        .motors
        .iter()
        .map(|m| {
            log.motors.iter().position(|l| l.name == m.actuator).ok_or_else(|| {
                Error::bad_bench(format!(
                    "motor {} of {} has no columns in the log: log all of them",
                    m.actuator,
                    spec_path.display()
                ))
            })
        })
        .collect::<Result<_>>()?;
    let linkage = Mutex::new(Linkage::new(&spec, &free_model)?);
    let nq = model.nq();
    let start_pose: StartPose = Box::new(move |logged: &[f64]| {
        let motors: Vec<f64> = order.iter().map(|&i| logged[i]).collect();
        let free = linkage.lock().map_err(|_| Error::Poisoned("loop-closure solver"))?.closed_qpos(&motors)?;
        let mut q = vec![0.0; nq];
        for &(fixed, f) in &map {
            q[fixed] = free[f];
        }
        Ok(q)
    });
    Bench::from_model(model, spec_path, motors, log, Some(start_pose))
}

/// The bench, or the robot hung in the air; and the MJCF an identified copy is made of.
pub fn bench_or_hung(bench: &Path, robot: Option<&Path>, log: &MotorLog) -> Result<(Bench, PathBuf)> {
    Ok(match robot {
        None => (Bench::load(bench, log)?, bench.to_path_buf()),
        Some(r) => {
            let spec = topa_env::assets::resolve_path(&r.to_string_lossy());
            let b = hung_bench(&spec, log)?;
            let mjcf = topa_env::spec::RobotSpec::load(&spec)?.0.mjcf;
            (b, mjcf)
        }
    })
}

/// The MJCF without its `<freejoint …/>` (or `<joint … type="free" …/>`) and without keyframes (their qpos has the
/// base's seven numbers); None when it has no floating base, or more than one (two robots are not one on a stand).
fn without_floating_base(xml: &str) -> Result<Option<String>> {
    let mut root =
        Element::parse(xml.as_bytes()).map_err(|e| Error::bench("the flattened MJCF is not well-formed XML", e))?;
    let removed = remove_floating_joints(&mut root);
    root.children.retain(|c| c.as_element().is_none_or(|e| e.name != "keyframe"));
    if removed != 1 {
        return Ok(None);
    }
    let mut out = Vec::new();
    root.write_with_config(&mut out, EmitterConfig::new().write_document_declaration(false))
        .map_err(|e| Error::bench("writing the hung robot's MJCF", e))?;
    Ok(Some(String::from_utf8(out).map_err(|e| Error::bench("the written MJCF is not UTF-8", e))?))
}

/// Removes every floating joint under `e`, returning how many there were.
fn remove_floating_joints(e: &mut Element) -> usize {
    let floating = |c: &XMLNode| {
        c.as_element().is_some_and(|j| {
            j.name == "freejoint" || (j.name == "joint" && j.attributes.get("type").is_some_and(|t| t == "free"))
        })
    };
    let before = e.children.len();
    e.children.retain(|c| !floating(c));
    let mut n = before - e.children.len();
    for c in &mut e.children {
        if let XMLNode::Element(child) = c {
            n += remove_floating_joints(child);
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The element names of a document, depth first.
    fn names(xml: &str) -> Vec<String> {
        fn walk(e: &Element, out: &mut Vec<String>) {
            out.push(e.name.clone());
            e.children.iter().filter_map(XMLNode::as_element).for_each(|c| walk(c, out));
        }
        let mut out = Vec::new();
        walk(&Element::parse(xml.as_bytes()).unwrap(), &mut out);
        out
    }

    #[test]
    fn the_floating_base_and_keyframes_leave_the_document() {
        let xml = "<mujoco><worldbody><body name=\"t\"><freejoint name=\"base\"/><joint name=\"k\"/></body>\
                   </worldbody><keyframe><key qpos=\"0 0 0 1 0 0 0 0\"/></keyframe></mujoco>";
        let out = without_floating_base(xml).unwrap().unwrap();
        assert_eq!(names(&out), ["mujoco", "worldbody", "body", "joint"]);
        assert!(out.contains("name=\"k\""), "{out}");
        let typed = xml.replace("<freejoint name=\"base\"/>", "<joint name=\"base\" type=\"free\"/>");
        assert_eq!(without_floating_base(&typed).unwrap().unwrap(), out);
        assert!(without_floating_base(&out).unwrap().is_none(), "no floating base");
        let two = xml.replace("<joint name=\"k\"/>", "<body><freejoint/></body>");
        assert!(without_floating_base(&two).unwrap().is_none(), "two floating bases");
        assert!(without_floating_base("<mujoco><worldbody>").is_err(), "malformed");
    }
}
