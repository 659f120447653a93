//! The robot's own leg kinematics, as its computer evaluates them from encoder readings: each foot's position
//! and velocity relative to the IMU, in the torso frame. Computed by MuJoCo on a private `Data` of the robot's
//! model with the base fixed at the origin, so every robot and linkage the MJCF describes is handled alike.

use std::sync::Arc;

use mujoco::{Data, Model, ObjType};
use nalgebra::Vector3;

use crate::error::Result;
use crate::indices::RobotIndices;

/// One foot relative to the IMU, in the torso frame.
#[derive(Debug, Clone, Copy, Default)]
pub struct FootKinematics {
    pub position: Vector3<f64>,
    pub velocity: Vector3<f64>,
    pub angular_velocity: Vector3<f64>,
}

pub struct LegKinematics {
    data: Data,
    joint_qpos: Vec<usize>,
    joint_dof: Vec<usize>,
    foot_sites: [usize; 2],
    imu_site: usize,
    base_qpos: usize,
    last: Vec<FootKinematics>,
}

impl LegKinematics {
    pub fn new(model: Arc<Model>, idx: &RobotIndices) -> Result<Self> {
        let mut data = Data::new(model)?;
        data.reset_keyframe(idx.stand_key)?;
        Ok(LegKinematics {
            data,
            joint_qpos: idx.joint_qpos.clone(),
            joint_dof: idx.joint_dof.clone(),
            foot_sites: idx.foot_sites,
            imu_site: idx.imu_site,
            base_qpos: idx.base_qpos,
            last: vec![FootKinematics::default(); 2],
        })
    }

    /// For kinematic-joint angles and velocities (one per degree of freedom): each foot relative to the IMU.
    pub fn feet(&mut self, joints: &[f64], joint_vel: &[f64]) -> &[FootKinematics] {
        let b = self.base_qpos;
        {
            let q = self.data.qpos_mut();
            q[b..b + 7].copy_from_slice(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
            for (&a, &j) in self.joint_qpos.iter().zip(joints) {
                q[a] = j;
            }
        }
        self.data.qvel_mut().iter_mut().for_each(|v| *v = 0.0);
        for (&a, &v) in self.joint_dof.iter().zip(joint_vel) {
            self.data.qvel_mut()[a] = v;
        }
        if self.data.kinematics().is_err() {
            // Non-finite encoder values: keep the last feet; the filter refuses non-finite input anyway.
            return &self.last;
        }
        let imu = Vector3::from(self.data.site_xpos()[self.imu_site]);
        for (f, &site) in self.foot_sites.iter().enumerate() {
            let p = Vector3::from(self.data.site_xpos()[site]) - imu;
            let v = self.data.object_velocity(ObjType::Site, site, false);
            self.last[f] = FootKinematics {
                position: p,
                velocity: Vector3::new(v[3], v[4], v[5]),
                angular_velocity: Vector3::new(v[0], v[1], v[2]),
            };
        }
        &self.last
    }
}
