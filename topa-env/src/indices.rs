//! A robot spec resolved against its compiled MJCF: every id and address the environment needs, found once at
//! start-up (the spec loader has already checked names, order, limits and the stand pose), plus the per-motor
//! tables the env uses every step.

use std::sync::Arc;

use mujoco::{Model, ObjType};

use crate::error::Result;
use crate::observation::ObsLayout;
use crate::spec::RobotSpec;

#[derive(Debug, Clone)]
pub struct RobotIndices {
    /// The robot's spec.
    pub spec: Arc<RobotSpec>,
    pub n_motors: usize,
    pub torso_body: usize,
    pub base_qpos: usize,
    pub base_dof: usize,
    pub actuators: Vec<usize>,
    /// qpos/dof addresses of the joints the actuators drive (motor joints inside a linkage).
    pub actuated_qpos: Vec<usize>,
    pub actuated_dof: Vec<usize>,
    /// qpos/dof addresses of the kinematic joint of each degree of freedom.
    pub joint_qpos: Vec<usize>,
    pub joint_dof: Vec<usize>,
    pub foot_bodies: [usize; 2],
    pub foot_geoms: [usize; 2],
    /// Sites at the centre of each sole.
    pub foot_sites: [usize; 2],
    /// The IMU site and the address of its accelerometer in `sensordata`.
    pub imu_site: usize,
    pub imu_accel: usize,
    pub floor_geom: usize,
    /// Bodies whose contact with the floor ends an episode (everything but the feet).
    pub fall_bodies: Vec<usize>,
    /// The equality constraints that close the robot's loops (empty for a serial robot).
    pub loops: Vec<usize>,
    pub stand_key: usize,
    /// Per motor: peak torque, N·m; the driven joint's range and the kinematic joint's range, rad.
    pub torque_limit: Vec<f64>,
    pub motor_range: Vec<[f64; 2]>,
    pub joint_range: Vec<[f64; 2]>,
    /// Per motor: the driven joint's and the kinematic joint's position in the stand keyframe.
    pub nominal_actuated: Vec<f64>,
    pub nominal_joints: Vec<f64>,
    /// Per motor: the PD target of a zero action, the driven joint's nominal position plus the spec's
    /// feed-forward torque over the actuator's kp (= the nominal position where there is none).
    pub action_zero: Vec<f64>,
    /// The left↔right mirror of motor-indexed vectors (`out[i] = sign[i] · in[perm[i]]`).
    pub mirror_perm: Vec<usize>,
    pub mirror_sign: Vec<f32>,
    /// Motor indices of the joint-deviation reward groups: hip roll, hip yaw, ankle pitch.
    pub deviation_groups: [Vec<usize>; 3],
}

/// The spec's reward groups the joint-deviation terms read, in term order.
pub const DEVIATION_GROUPS: [&str; 3] = ["hip_roll", "hip_yaw", "ankle_pitch"];

impl RobotIndices {
    /// Resolves a loaded spec on its model (`RobotSpec::load` checked the one against the other).
    pub fn resolve(model: &Model, spec: &Arc<RobotSpec>) -> Result<Self> {
        let id = |t: ObjType, name: &str| -> Result<usize> { Ok(model.id(t, name)?) };
        let base_joint = id(ObjType::Joint, &spec.base_joint)?;
        let mut idx = RobotIndices {
            spec: spec.clone(),
            n_motors: spec.n_motors(),
            torso_body: id(ObjType::Body, &spec.base_body)?,
            base_qpos: model.jnt_qposadr_of(base_joint),
            base_dof: model.jnt_dofadr_of(base_joint),
            actuators: Vec::new(),
            actuated_qpos: Vec::new(),
            actuated_dof: Vec::new(),
            joint_qpos: Vec::new(),
            joint_dof: Vec::new(),
            foot_bodies: [0; 2],
            foot_geoms: [0; 2],
            foot_sites: [0; 2],
            imu_site: id(ObjType::Site, &spec.imu_site)?,
            imu_accel: model.sensor_adr()[id(ObjType::Sensor, &spec.imu_accelerometer)?] as usize,
            floor_geom: id(ObjType::Geom, &spec.floor_geom)?,
            fall_bodies: Vec::new(),
            loops: Vec::new(),
            stand_key: id(ObjType::Key, &spec.stand_keyframe)?,
            torque_limit: spec.motors.iter().map(|m| m.torque_limit).collect(),
            motor_range: spec.motors.iter().map(|m| m.motor_range).collect(),
            joint_range: spec.motors.iter().map(|m| m.joint_range).collect(),
            nominal_actuated: Vec::new(),
            nominal_joints: spec.nominal_joints(),
            action_zero: Vec::new(),
            mirror_perm: Vec::new(),
            mirror_sign: Vec::new(),
            deviation_groups: DEVIATION_GROUPS.map(|g| spec.group(g).to_vec()),
        };
        for m in &spec.motors {
            idx.actuators.push(id(ObjType::Actuator, &m.actuator)?);
            let (drv, jnt) = (id(ObjType::Joint, &m.drives)?, id(ObjType::Joint, &m.joint)?);
            idx.actuated_qpos.push(model.jnt_qposadr_of(drv));
            idx.actuated_dof.push(model.jnt_dofadr_of(drv));
            idx.joint_qpos.push(model.jnt_qposadr_of(jnt));
            idx.joint_dof.push(model.jnt_dofadr_of(jnt));
        }
        for (f, foot) in spec.feet.iter().enumerate() {
            idx.foot_bodies[f] = id(ObjType::Body, &foot.body)?;
            idx.foot_geoms[f] = id(ObjType::Geom, &foot.geom)?;
            idx.foot_sites[f] = id(ObjType::Site, &foot.site)?;
        }
        idx.fall_bodies = (1..model.nbody()).filter(|b| !idx.foot_bodies.contains(b)).collect();
        for l in &spec.loops {
            for e in &l.equality {
                idx.loops.push(id(ObjType::Equality, e)?);
            }
        }
        let key_qpos = model.key_qpos(idx.stand_key);
        idx.nominal_actuated = idx.actuated_qpos.iter().map(|&a| key_qpos[a]).collect();
        idx.action_zero = (0..idx.n_motors)
            .map(|i| {
                let ff = spec.motors[i].feedforward;
                let q = idx.nominal_actuated[i];
                if ff == 0.0 {
                    q
                } else {
                    q + ff / model.actuator_gainprm()[idx.actuators[i]][0]
                }
            })
            .collect();
        (idx.mirror_perm, idx.mirror_sign) = spec.mirror_map();
        Ok(idx)
    }

    /// The observation layout of this robot.
    pub fn obs_layout(&self) -> ObsLayout {
        ObsLayout::new(self.n_motors)
    }
}
