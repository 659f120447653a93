//! The observation the env writes: the paper's blocks from the simulator's state (or, with realistic sim2sim, from
//! what the robot's computer sensed), with observation noise, and the optional height scan after them.

use nalgebra::Vector3;
use rand::RngExt;

use super::RobotEnv;
use crate::observation::{Block, HistoryUpdate};
use crate::sim2sim::Sensed;

impl RobotEnv {
    /// The observation: the simulator's state, or with realistic sim2sim what the robot's computer `sensed`.
    pub(super) fn write_obs(&mut self, obs: &mut [f32], sensed: Option<&Sensed>, history: HistoryUpdate) {
        let s = &self.robot_state;
        let (lin_vel, ang_vel, gravity, pos, vel) = match sensed {
            Some(x) => (x.lin_vel, x.ang_vel, x.gravity, &x.motor_pos, &x.motor_vel),
            None => (s.lin_vel, s.ang_vel, s.gravity, &s.motor_pos, &s.motor_vel),
        };
        let n = &self.cfg.noise;
        let on = n.enabled;
        let rng = &mut self.rng;
        let mut noise = |scale: f64| if on && scale > 0.0 { rng.random_range(-scale..=scale) } else { 0.0 };
        let l = self.layout;
        let (lv, av, gr) = (l.offset(Block::LinVel), l.offset(Block::AngVel), l.offset(Block::Gravity));
        for i in 0..3 {
            if l.base_velocity {
                obs[lv + i] = (lin_vel[i] + noise(n.lin_vel)) as f32;
            }
            obs[av + i] = (ang_vel[i] + noise(n.ang_vel)) as f32;
        }
        let off = self.perturbation.gravity_offset;
        let mut g = Vector3::from_fn(|i, _| gravity[i] + off[i] + noise(n.gravity));
        if g.norm() > 1e-9 {
            g.normalize_mut();
        }
        for i in 0..3 {
            obs[gr + i] = g[i] as f32;
        }
        let (q, qd, la) = (l.offset(Block::MotorPos), l.offset(Block::MotorVel), l.offset(Block::LastAction));
        let nominal = &self.idx.nominal_actuated;
        for i in 0..l.n_motors {
            obs[q + i] = (pos[i] - nominal[i] + noise(n.motor_pos)) as f32;
            obs[qd + i] = (vel[i] + noise(n.motor_vel)) as f32;
            obs[la + i] = self.last_action[i] as f32;
        }
        let c = self.command();
        let co = l.offset(Block::Command);
        for i in 0..3 {
            obs[co + i] = c[i] as f32;
        }
        self.write_height_scan(obs);
        self.write_history(obs, history);
        if l.privileged {
            // The simulator's truth, whatever the robot sensed: the critic's input only.
            let at = l.offset(Block::PrivilegedLinVel);
            for i in 0..3 {
                obs[at + i] = self.robot_state.lin_vel[i] as f32;
            }
        }
    }

    /// The earlier frames after the current observation; then the current frame joins them.
    fn write_history(&mut self, obs: &mut [f32], history: HistoryUpdate) {
        let l = self.layout;
        if l.history == 0 {
            return;
        }
        let (frame, now) = (l.frame(), l.offset(Block::AngVel));
        let current = now..now + frame;
        match history {
            HistoryUpdate::Fill => {
                for f in 0..l.history {
                    self.history[f * frame..(f + 1) * frame].copy_from_slice(&obs[current.clone()]);
                }
                let at = l.offset(Block::History);
                obs[at..at + l.history * frame].copy_from_slice(&self.history);
            }
            HistoryUpdate::Shift => {
                let at = l.offset(Block::History);
                obs[at..at + l.history * frame].copy_from_slice(&self.history);
                self.history.copy_within(0..(l.history - 1) * frame, frame);
                self.history[..frame].copy_from_slice(&obs[current]);
            }
        }
    }

    /// The height scan's values (`[env.height_scan]`), after the paper's blocks: at each point of the grid in the
    /// base's heading frame, the base's height over the ground there minus the stand height, clipped.
    pub(super) fn write_height_scan(&mut self, obs: &mut [f32]) {
        let scan = &self.cfg.height_scan;
        if !scan.enabled {
            return;
        }
        let at = self.layout.offset(crate::observation::Block::HeightScan);
        let [bx, by, bz] = self.robot_state.base_pos;
        let (sin, cos) = self.robot_state.yaw.sin_cos();
        let target = self.base_height_target();
        let noisy = self.cfg.noise.enabled && scan.noise > 0.0;
        let mut k = at;
        for &x in &scan.x {
            for &y in &scan.y {
                let (px, py) = (bx + cos * x - sin * y, by + sin * x + cos * y);
                let mut v = (bz - self.ground_height(px, py) - target).clamp(-scan.clip, scan.clip);
                if noisy {
                    v += self.rng.random_range(-scan.noise..=scan.noise);
                }
                obs[k] = v as f32;
                k += 1;
            }
        }
    }
}
