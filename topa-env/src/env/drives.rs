//! The robot under an outside controller (`topa sim-robot`): one physics step at a time with the PD targets and
//! gains the controller sent, as a real robot's motor drivers run their PD at their own rate, and the readings
//! its driver would send back.

use super::RobotEnv;
use crate::state;

/// What a robot's driver reads from it: the IMU's attitude (world ← torso, w x y z) and gyro, the base velocity
/// (the robot's estimator's, torso frame), the motors' encoders.
#[derive(Debug, Clone, Copy)]
pub struct DriverReadings<'a> {
    pub orientation: [f64; 4],
    pub gyro: [f64; 3],
    pub lin_vel: [f64; 3],
    pub motor_pos: &'a [f64],
    pub motor_vel: &'a [f64],
}

impl RobotEnv {
    /// One physics step with the drives' PD: per motor a target (rad), a stiffness kp (N·m/rad) and a damping kd
    /// (N·m·s/rad). The realistic models (action delay, torque–speed limits, the motors' identified torque
    /// constant) act on these as on the policy's targets. False when the simulation failed or diverged.
    pub fn step_drives(&mut self, target: &[f64], kp: &[f64], kd: &[f64]) -> bool {
        let n = self.idx.n_motors;
        assert!(target.len() == n && kp.len() == n && kd.len() == n, "drive commands are sized to the {n} motors");
        let constants = self.sim2sim.as_ref().map(|s| &s.config().actuators).filter(|a| a.enabled);
        let m = self.data.model_mut();
        for i in 0..n {
            let a = self.idx.actuators[i];
            // A motor weaker or stronger than its datasheet turns every gain by the same factor.
            let k = constants.and_then(|c| c.torque_constant.get(i).copied()).unwrap_or(1.0);
            m.actuator_gainprm_mut()[a][0] = kp[i] * k;
            m.actuator_biasprm_mut()[a][1] = -kp[i] * k;
            m.actuator_biasprm_mut()[a][2] = -kd[i] * k;
        }
        match &mut self.sim2sim {
            Some(s) => s.set_target(target),
            None => {
                for i in 0..n {
                    self.data.ctrl_mut()[self.idx.actuators[i]] = target[i];
                }
            }
        }
        let ok = self.physics_step() && !self.data.is_unstable();
        state::read_into(&self.data, &self.idx, &mut self.robot_state);
        ok
    }

    /// What the robot's driver reads now: with realistic sim2sim its newest sensor readings (noise, quantisation,
    /// the state estimator's velocity; the observation delay is the wire's own), else the simulator's state.
    /// Borrowed, not copied: a robot on the wire reads this every physics step.
    pub fn readings(&self) -> DriverReadings<'_> {
        match &self.sim2sim {
            Some(s) => {
                let s = s.latest();
                DriverReadings {
                    orientation: s.orientation,
                    gyro: s.ang_vel,
                    lin_vel: s.lin_vel,
                    motor_pos: &s.motor_pos,
                    motor_vel: &s.motor_vel,
                }
            }
            None => {
                let r = &self.robot_state;
                DriverReadings {
                    orientation: r.base_quat,
                    gyro: r.ang_vel,
                    lin_vel: r.lin_vel,
                    motor_pos: &r.motor_pos,
                    motor_vel: &r.motor_vel,
                }
            }
        }
    }

    /// Simulated time, s.
    pub fn time(&self) -> f64 {
        self.data.time()
    }
}
