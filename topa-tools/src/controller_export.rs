//! `topa export --controller DIR`: the controller file a robot's driver loads with `topa_control` — the policy's
//! weights beside `controller.json`, which holds what the robot side needs of the robot spec, the MJCF (the PD
//! gains the policy was trained with), the training config (command ranges) and the observation layout.

use std::path::Path;

use topa_control::spec::{BaseVelocity, ControllerSpec, MotorSpec, ObservationSpec, SafetySpec, FORMAT, VERSION};
use topa_env::indices::RobotIndices;
use topa_env::observation::{self as obs};
use topa_env::policy_runner::PolicyRunner;
use topa_env::spec::RobotSpec;
use trainer::policy_file;

use crate::error::{bad_file, Error, Result};

/// The controller file of the policy at `policy_path` for the robot it runs on.
pub fn spec(policy_path: &Path) -> Result<ControllerSpec> {
    spec_of(&PolicyRunner::load(policy_path, "controller")?, policy_path)
}

/// The controller file of `runner`'s policy, loaded from `policy_path`.
fn spec_of(runner: &PolicyRunner, policy_path: &Path) -> Result<ControllerSpec> {
    let m = &runner.policy.meta;
    let layout = runner.layout();
    if layout.scan != (0, 0) {
        bad_file!("{}: the controller runs blind policies; this one reads a height scan", policy_path.display());
    }
    let robot = runner.robot();
    let (_, model) = RobotSpec::load(&robot.path)?;
    let idx = RobotIndices::resolve(&model, &std::sync::Arc::new(robot.clone()))?;
    let n = robot.n_motors();
    let motors = (0..n)
        .map(|i| {
            let a = idx.actuators[i];
            MotorSpec {
                name: robot.motors[i].actuator.clone(),
                range: idx.motor_range[i],
                nominal: runner.nominal_motors()[i],
                action_zero: runner.action_zero()[i],
                kp: model.actuator_gainprm()[a][0],
                kd: -model.actuator_biasprm()[a][2],
            }
        })
        .collect();
    let training = runner.training_config();
    let base_velocity = match training.observation.base_velocity {
        obs::BaseVelocity::Observed => BaseVelocity::Observed,
        obs::BaseVelocity::Estimated => BaseVelocity::Estimated,
        obs::BaseVelocity::None => BaseVelocity::None,
    };
    let flat = |d: &nalgebra::DMatrix<f64>| (0..n).flat_map(|r| (0..n).map(move |c| d[(r, c)])).collect::<Vec<_>>();
    let c = &training.commands;
    let spec = ControllerSpec {
        format: FORMAT.into(),
        version: VERSION,
        robot: robot.name.clone(),
        policy: policy_path.display().to_string(),
        motors,
        action_scale: m.action_scale,
        action_clip: m.action_clip,
        control_period_s: m.policy_dt,
        observation: ObservationSpec {
            base_velocity,
            history: layout.history,
            inputs: runner.policy.view().inputs,
            row: layout.dim(),
        },
        joint_map: runner.joint_map().map(|(j, inv)| [flat(j), flat(inv)]),
        hidden: m.hidden.clone(),
        estimator_hidden: m.estimator_hidden.clone(),
        command_ranges: [c.lin_vel_x, c.lin_vel_y, c.ang_vel_z],
        safety: SafetySpec::default(),
        weights: "policy.safetensors".into(),
        weights_crc32: m.weights_crc32,
    };
    spec.validate().map_err(|e| Error::Invalid(format!("the controller file of {}: {e}", policy_path.display())))?;
    Ok(spec)
}

/// Writes `dir/controller.json` and `dir/policy.safetensors` (atomically); returns the spec.
pub fn export(policy_path: &Path, dir: &Path) -> Result<ControllerSpec> {
    let runner = PolicyRunner::load(policy_path, "controller")?;
    let spec = spec_of(&runner, policy_path)?;
    std::fs::create_dir_all(dir).map_err(Error::io("creating", dir))?;
    let weights = policy_file::weights_path(&policy_file::sidecar_path(policy_path), &runner.policy.meta);
    let bytes = std::fs::read(&weights).map_err(Error::io("cannot read", &weights))?;
    trainer::tensorfile::write_atomic(&dir.join(&spec.weights), &bytes)?;
    let text = serde_json::to_string_pretty(&spec)?;
    trainer::tensorfile::write_atomic(&dir.join("controller.json"), text.as_bytes())?;
    Ok(spec)
}
