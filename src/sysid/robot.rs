//! A robot hung in the air as a bench: its own MJCF with the floating base removed (the torso fixed where the
//! file puts it) and contacts off, every motor at once, the closed loops included. A window starts with the
//! logged motor positions and the loops closed around them (the robot's own loop-closure solver).

use std::path::Path;
use std::sync::Mutex;

use anyhow::{Context, Result};
use mujoco_sys::{Model, ObjType};
use topa_env::linkage::Linkage;
use topa_env::spec::RobotSpec;

use super::bench::{Bench, StartPose};
use super::log::MotorLog;

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
    let text = std::fs::read_to_string(&flat).context("reading the flattened robot MJCF back")?;
    let _ = std::fs::remove_file(&flat);
    let fixed_text = without_floating_base(&text)
        .with_context(|| format!("{}: no floating base (a freejoint) to fix", mjcf.display()))?;
    let dir = mjcf.parent().unwrap_or(Path::new("."));
    let mut model = Model::from_xml_string(&fixed_text, dir)?;
    model.set_contacts_enabled(false);
    // Nothing here reads a sensor; the accelerometer alone costs a second Newton–Euler pass every step.
    model.set_sensors_enabled(false);
    let step = log.step();
    model.set_timestep(step / (step / MAX_TIMESTEP).ceil())?;
    model.set_integrator(mujoco_sys::Integrator::Euler);
    let motors = Bench::motors_of(&model, spec_path, log)?;

    // The fixed model's joints in the free model's qpos (same names; the free model has the base in front).
    let mut map = Vec::new();
    for j in 0..model.njnt() {
        let name = model.name_of(ObjType::Joint, j).context("every joint of the robot needs a name")?;
        let k = free_model.id(ObjType::Joint, name)?;
        map.push((model.jnt_qposadr_of(j), free_model.jnt_qposadr_of(k)));
    }
    // Log order → the spec's motor order.
    let order: Vec<usize> = spec
        .motors
        .iter()
        .map(|m| {
            log.motors.iter().position(|l| l.name == m.actuator).with_context(|| {
                format!("motor {} of {} has no columns in the log: log all of them", m.actuator, spec_path.display())
            })
        })
        .collect::<Result<_>>()?;
    let linkage = Mutex::new(Linkage::new(&spec, &free_model)?);
    let nq = model.nq();
    let start_pose: StartPose = Box::new(move |logged: &[f64]| {
        let motors: Vec<f64> = order.iter().map(|&i| logged[i]).collect();
        let free = linkage.lock().map_err(|_| anyhow::anyhow!("loop-closure solver poisoned"))?.closed_qpos(&motors)?;
        let mut q = vec![0.0; nq];
        for &(fixed, f) in &map {
            q[fixed] = free[f];
        }
        Ok(q)
    });
    Bench::from_model(model, spec_path, motors, log, Some(start_pose))
}

/// The MJCF without its `<freejoint …/>` (or `<joint … type="free" …/>`) and without keyframes (their qpos has the
/// base's seven numbers); None when it has no floating base.
fn without_floating_base(xml: &str) -> Option<String> {
    let mut out = xml.to_string();
    let start = out.find("<freejoint").or_else(|| {
        out.match_indices("<joint")
            .map(|(i, _)| i)
            .find(|&i| out[i..].split("/>").next().is_some_and(|t| t.contains("type=\"free\"")))
    })?;
    let end = start + out[start..].find("/>")? + 2;
    out.replace_range(start..end, "");
    while let Some(k) = out.find("<keyframe>") {
        let e = k + out[k..].find("</keyframe>")? + "</keyframe>".len();
        out.replace_range(k..e, "");
    }
    // A second floating base (two robots in one file) is not a robot on a stand.
    (!out.contains("<freejoint") && !out.contains("type=\"free\"")).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_floating_base_and_keyframes_leave_the_document() {
        let xml = "<mujoco><worldbody><body name=\"t\"><freejoint name=\"base\"/><joint name=\"k\"/></body>\
                   </worldbody><keyframe><key qpos=\"0 0 0 1 0 0 0 0\"/></keyframe></mujoco>";
        let out = without_floating_base(xml).unwrap();
        assert_eq!(out, "<mujoco><worldbody><body name=\"t\"><joint name=\"k\"/></body></worldbody></mujoco>");
        let typed = xml.replace("<freejoint name=\"base\"/>", "<joint name=\"base\" type=\"free\"/>");
        assert_eq!(without_floating_base(&typed).unwrap(), out);
        assert!(without_floating_base(&out).is_none());
    }
}
