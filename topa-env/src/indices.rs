//! The TopA spec resolved against a loaded MJCF: every id and address the environment needs, found once at
//! start-up, with the model checked against the spec (names, actuator order, limits, nominal pose).

use mujoco_sys::{ffi, Model, ObjType};

use crate::error::{EnvError, Result};
use crate::robot::{self, ModelKind, N_MOTORS};

/// Tolerance for limits read back from the compiled model (MJCF numbers are parsed as doubles).
const LIMIT_TOL: f64 = 1e-9;

#[derive(Debug, Clone)]
pub struct RobotIndices {
    pub kind: ModelKind,
    pub torso_body: usize,
    pub base_qpos: usize,
    pub base_dof: usize,
    pub actuators: [usize; N_MOTORS],
    /// qpos/dof addresses of the joints the actuators drive (motor joints on the closed model).
    pub actuated_qpos: [usize; N_MOTORS],
    pub actuated_dof: [usize; N_MOTORS],
    /// qpos/dof addresses of the kinematic joints (hip roll … ankle pitch), both models.
    pub joint_qpos: [usize; N_MOTORS],
    pub joint_dof: [usize; N_MOTORS],
    pub foot_bodies: [usize; 2],
    pub foot_geoms: [usize; 2],
    /// Sites at the centre of each sole (`l_foot_site`, `r_foot_site`).
    pub foot_sites: [usize; 2],
    /// The IMU site and the address of its accelerometer (`imu_acc`) in `sensordata`.
    pub imu_site: usize,
    pub imu_accel: usize,
    pub floor_geom: usize,
    /// Bodies whose contact with the floor ends an episode (everything but the feet).
    pub fall_bodies: Vec<usize>,
    /// The closed model's loop-closure constraints (empty on the open model).
    pub loops: Vec<usize>,
    pub stand_key: usize,
    pub torque_limit: [f64; N_MOTORS],
}

impl RobotIndices {
    /// Resolves and checks. Every mismatch is an error naming the object and the expected value.
    pub fn resolve(model: &Model, kind: ModelKind) -> Result<Self> {
        let spec_err = |problem: String| EnvError::Spec { model: model.name().to_string(), kind: kind.name(), problem };
        let id = |t: ObjType, name: &str| model.id(t, name).map_err(|e| spec_err(e.to_string()));
        // Catch the common mix-up first, with the fix: each model has joints the other lacks.
        let has_linkage = model.id(ObjType::Joint, "l_ankle_motor").is_ok();
        match (kind, has_linkage) {
            (ModelKind::Closed, false) => return Err(spec_err(
                "it has no linkage joint 'l_ankle_motor', so it looks like the open (serial) model: use --model open"
                    .into(),
            )),
            (ModelKind::Open, true) => {
                return Err(spec_err(
                    "it has the linkage joint 'l_ankle_motor', so it looks like the closed model: use --model closed"
                        .into(),
                ))
            }
            _ => {}
        }
        if model.nu() != N_MOTORS {
            return Err(spec_err(format!("expected {N_MOTORS} actuators, found {}", model.nu())));
        }
        let torso_body = id(ObjType::Body, "torso")?;
        let base_joint = id(ObjType::Joint, "floating_base")?;
        if model.jnt_type()[base_joint] != ffi::mjJNT_FREE as i32 {
            return Err(spec_err("joint 'floating_base' must be a free joint".into()));
        }
        let act_names = robot::actuator_names(kind);
        let actuated = robot::actuated_joint_names(kind);
        let joints = robot::joint_names();
        let mut actuators = [0; N_MOTORS];
        let mut actuated_jnt = [0; N_MOTORS];
        let mut joint_jnt = [0; N_MOTORS];
        for i in 0..N_MOTORS {
            actuators[i] = id(ObjType::Actuator, &act_names[i])?;
            if actuators[i] != i {
                return Err(spec_err(format!(
                    "actuator '{}' is #{} but the spec's order puts it at #{i} (left leg roll, yaw, pitch, knee, \
                     ankle, then the right leg)",
                    act_names[i], actuators[i]
                )));
            }
            actuated_jnt[i] = id(ObjType::Joint, &actuated[i])?;
            joint_jnt[i] = id(ObjType::Joint, &joints[i])?;
            let driven = model.actuator_trnid()[i][0];
            if model.actuator_trntype()[i] != ffi::mjTRN_JOINT as i32 || driven != actuated_jnt[i] as i32 {
                let got = model.name_of(ObjType::Joint, driven.max(0) as usize).unwrap_or("?");
                return Err(spec_err(format!(
                    "actuator '{}' must drive joint '{}', it drives '{got}'",
                    act_names[i], actuated[i]
                )));
            }
        }
        check_limits(model, kind, &act_names, &actuated, &joints, &actuated_jnt, &joint_jnt).map_err(spec_err)?;

        let foot = |leg: usize| -> Result<(usize, usize)> {
            let name = robot::side_name(leg, "foot");
            Ok((id(ObjType::Body, &name)?, id(ObjType::Geom, &name)?))
        };
        let (lf, rf) = (foot(0)?, foot(1)?);
        let floor_geom = id(ObjType::Geom, "floor")?;
        let foot_bodies = [lf.0, rf.0];
        let fall_bodies = (1..model.nbody()).filter(|b| !foot_bodies.contains(b)).collect();
        let loops = match kind {
            ModelKind::Closed => {
                (0..2).map(|leg| id(ObjType::Equality, &robot::side_name(leg, "ankle_loop"))).collect::<Result<_>>()?
            }
            ModelKind::Open => Vec::new(),
        };
        let stand_key = id(ObjType::Key, robot::STAND_KEY)?;
        // The keyframe's joint angles must be the spec's nominal pose (its ctrl may add gravity compensation).
        let key_qpos = model.key_qpos(stand_key);
        for (i, n) in robot::nominal_joints().iter().enumerate() {
            let q = key_qpos[model.jnt_qposadr_of(joint_jnt[i])];
            if (q - n).abs() > 1e-6 {
                return Err(spec_err(format!(
                    "keyframe 'stand' puts joint '{}' at {q}, the spec's nominal pose is {n}",
                    joints[i]
                )));
            }
        }
        Ok(RobotIndices {
            kind,
            torso_body,
            base_qpos: model.jnt_qposadr_of(base_joint),
            base_dof: model.jnt_dofadr_of(base_joint),
            actuators,
            actuated_qpos: actuated_jnt.map(|j| model.jnt_qposadr_of(j)),
            actuated_dof: actuated_jnt.map(|j| model.jnt_dofadr_of(j)),
            joint_qpos: joint_jnt.map(|j| model.jnt_qposadr_of(j)),
            joint_dof: joint_jnt.map(|j| model.jnt_dofadr_of(j)),
            foot_bodies,
            foot_geoms: [lf.1, rf.1],
            foot_sites: [id(ObjType::Site, "l_foot_site")?, id(ObjType::Site, "r_foot_site")?],
            imu_site: id(ObjType::Site, "imu")?,
            imu_accel: model.sensor_adr()[id(ObjType::Sensor, "imu_acc")?] as usize,
            floor_geom,
            fall_bodies,
            loops,
            stand_key,
            torque_limit: robot::per_motor(|m| m.torque_limit),
        })
    }
}

fn close(a: [f64; 2], b: [f64; 2]) -> bool {
    (a[0] - b[0]).abs() < LIMIT_TOL && (a[1] - b[1]).abs() < LIMIT_TOL
}

fn check_limits(
    model: &Model,
    kind: ModelKind,
    act_names: &[String],
    actuated: &[String],
    joints: &[String],
    actuated_jnt: &[usize; N_MOTORS],
    joint_jnt: &[usize; N_MOTORS],
) -> std::result::Result<(), String> {
    let ctrl = robot::actuated_range(kind);
    let motor_ranges = robot::per_motor(|m| m.motor_range);
    let joint_ranges = robot::per_motor(|m| m.joint_range);
    for i in 0..N_MOTORS {
        let limit = robot::LEG[i % robot::N_LEG].torque_limit;
        if model.actuator_ctrllimited()[i] == 0 || !close(model.actuator_ctrlrange()[i], ctrl[i]) {
            return Err(format!(
                "actuator '{}' ctrlrange is {:?}, the spec says {:?}",
                act_names[i],
                model.actuator_ctrlrange()[i],
                ctrl[i]
            ));
        }
        if model.actuator_forcelimited()[i] == 0 || !close(model.actuator_forcerange()[i], [-limit, limit]) {
            return Err(format!(
                "actuator '{}' forcerange is {:?}, the spec's torque limit is ±{limit} N·m",
                act_names[i],
                model.actuator_forcerange()[i]
            ));
        }
        let expect_actuated = if kind == ModelKind::Closed { motor_ranges[i] } else { joint_ranges[i] };
        for (name, j, want) in
            [(&actuated[i], actuated_jnt[i], expect_actuated), (&joints[i], joint_jnt[i], joint_ranges[i])]
        {
            if model.jnt_limited()[j] == 0 || !close(model.jnt_range()[j], want) {
                return Err(format!("joint '{name}' range is {:?}, the spec says {want:?}", model.jnt_range()[j]));
            }
        }
    }
    Ok(())
}
