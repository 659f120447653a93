//! What the robot is doing right now, read off a `Data` in the robot's terms: base velocities in the torso
//! frame, gravity direction, roll/pitch, motor and joint positions, velocities and motor torques, foot contacts.

use mujoco::Data;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use crate::indices::RobotIndices;

/// Minimum normal force for a foot to count as in contact, N (filters grazing contacts).
pub const CONTACT_FORCE_THRESHOLD: f64 = 1.0;

#[derive(Debug, Clone, Default)]
pub struct RobotState {
    pub base_pos: [f64; 3],
    /// Torso orientation (w, x, y, z).
    pub base_quat: [f64; 4],
    /// Base linear and angular velocity in the torso frame.
    pub lin_vel: [f64; 3],
    pub ang_vel: [f64; 3],
    /// Unit gravity direction in the torso frame.
    pub gravity: [f64; 3],
    pub roll: f64,
    pub pitch: f64,
    pub yaw: f64,
    /// Positions, velocities and torques of the joints the actuators drive: the motors (on a serial model the
    /// kinematic joints are the motors).
    pub motor_pos: Vec<f64>,
    pub motor_vel: Vec<f64>,
    pub motor_torque: Vec<f64>,
    /// Kinematic joint angles and velocities, one per degree of freedom.
    pub joint_pos: Vec<f64>,
    pub joint_vel: Vec<f64>,
    /// Normal contact force on each foot from the floor, N.
    pub foot_force: [f64; 2],
    /// Horizontal speed of each foot, m/s.
    pub foot_speed: [f64; 2],
    /// A robot body other than a foot touches the floor.
    pub body_contact: bool,
}

impl RobotState {
    pub fn foot_contact(&self) -> [bool; 2] {
        self.foot_force.map(|f| f > CONTACT_FORCE_THRESHOLD)
    }
}

pub fn quat_of(q: &[f64]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// Reads the state; `d` must be after `forward`/`step` (contacts and velocities valid).
pub fn read(d: &Data, idx: &RobotIndices) -> RobotState {
    let mut s = RobotState::default();
    read_into(d, idx, &mut s);
    s
}

/// As `read`, into `s`'s buffers (no allocation once they have their size).
pub fn read_into(d: &Data, idx: &RobotIndices, s: &mut RobotState) {
    let qpos = d.qpos();
    let qvel = d.qvel();
    let b = idx.base_qpos;
    let q = quat_of(&qpos[b + 3..b + 7]);
    let world_lin = Vector3::new(qvel[idx.base_dof], qvel[idx.base_dof + 1], qvel[idx.base_dof + 2]);
    // MuJoCo: a free joint's linear velocity is in the world frame, its angular velocity in the body frame.
    let lin = q.inverse_transform_vector(&world_lin);
    let g = q.inverse_transform_vector(&Vector3::new(0.0, 0.0, -1.0));
    let (roll, pitch, yaw) = q.euler_angles();
    s.base_pos = [qpos[b], qpos[b + 1], qpos[b + 2]];
    s.base_quat = [qpos[b + 3], qpos[b + 4], qpos[b + 5], qpos[b + 6]];
    s.lin_vel = [lin.x, lin.y, lin.z];
    s.ang_vel = [qvel[idx.base_dof + 3], qvel[idx.base_dof + 4], qvel[idx.base_dof + 5]];
    s.gravity = [g.x, g.y, g.z];
    (s.roll, s.pitch, s.yaw) = (roll, pitch, yaw);
    let force = d.actuator_force();
    let gather = |out: &mut Vec<f64>, src: &[f64], at: &[usize]| {
        out.clear();
        out.extend(at.iter().map(|&i| src[i]));
    };
    gather(&mut s.motor_pos, qpos, &idx.actuated_qpos);
    gather(&mut s.motor_vel, qvel, &idx.actuated_dof);
    gather(&mut s.motor_torque, force, &idx.actuators);
    gather(&mut s.joint_pos, qpos, &idx.joint_qpos);
    gather(&mut s.joint_vel, qvel, &idx.joint_dof);
    (s.foot_force, s.body_contact) = contact_forces(d, idx);
    for f in 0..2 {
        let v = d.body_velocity(idx.foot_bodies[f], false);
        s.foot_speed[f] = v[3].hypot(v[4]);
    }
}

/// Normal force of the ground (anything fixed to the world: the floor, a course's walls) on each foot (N), and
/// whether any other robot body touches the ground.
pub fn contact_forces(d: &Data, idx: &RobotIndices) -> ([f64; 2], bool) {
    let (mut force, mut body_contact) = ([0.0; 2], false);
    let m = d.model();
    for (i, con) in d.contacts().iter().enumerate() {
        let (g1, g2) = (con.geom1 as usize, con.geom2 as usize);
        let other = if crate::world::is_ground(m, g1) {
            g2
        } else if crate::world::is_ground(m, g2) {
            g1
        } else {
            continue;
        };
        if let Some(f) = idx.foot_geoms.iter().position(|&fg| fg == other) {
            force[f] += d.contact_force(i).map(|w| w[0]).unwrap_or(0.0);
        } else if idx.fall_bodies.contains(&(d.model().geom_bodyid()[other] as usize)) {
            body_contact = true;
        }
    }
    (force, body_contact)
}

/// The base's linear velocity in the torso frame, straight from the simulator.
pub fn read_base_velocity(d: &Data, idx: &RobotIndices) -> [f64; 3] {
    let b = idx.base_qpos;
    let q = quat_of(&d.qpos()[b + 3..b + 7]);
    let dof = idx.base_dof;
    let v = q.inverse_transform_vector(&Vector3::new(d.qvel()[dof], d.qvel()[dof + 1], d.qvel()[dof + 2]));
    [v.x, v.y, v.z]
}
