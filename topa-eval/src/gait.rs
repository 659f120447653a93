//! The gait report: what a locomotion researcher looks at first — steps per second per foot, air time per step,
//! foot clearance, foot slip, the share of double support, and the base height — measured on one run at the
//! policy rate.
//!
//! Definitions: a foot is in contact when its normal force exceeds `state::CONTACT_FORCE_THRESHOLD`; a step is a
//! touchdown after at least one policy step in the air; its air time is that swing's duration and its clearance
//! the highest point of the sole's centre site during the swing (above the ground plane, z = 0); slip is the
//! horizontal distance the sole's centre travels while the foot is in contact, reported per stance phase.

use serde::Serialize;
use topa_env::RobotEnv;

/// The gait of one run.
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GaitStats {
    /// Observed time, s (summed over the initial states of a tracking command).
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub seconds: f64,
    /// Touchdowns per second, per foot (mean of both feet).
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub steps_per_s: f64,
    /// Mean air time of a step, s.
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub air_time_s: f64,
    /// Mean of each step's highest sole point during its swing, m.
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub clearance_m: f64,
    /// Horizontal sliding of the sole while in contact, per stance phase, m.
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub slip_per_stance_m: f64,
    /// Share of the time with both feet in contact.
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub double_support: f64,
    /// Mean torso height, m.
    #[serde(deserialize_with = "super::nan_json::f64")]
    pub base_height_m: f64,
}

/// Accumulates `GaitStats` step by step.
#[derive(Debug, Clone, Default)]
pub struct GaitAccumulator {
    seconds: f64,
    steps: usize,
    air_sum: f64,
    clearance_sum: f64,
    slip_sum: f64,
    stances: usize,
    double: f64,
    height_sum: f64,
    samples: usize,
    /// Per foot: in contact at the last sample, air time and top height of the current swing.
    contact: [Option<bool>; 2],
    swing_time: [f64; 2],
    swing_top: [f64; 2],
}

impl GaitAccumulator {
    /// One policy step of `dt` seconds, read off the env after the step.
    pub fn add(&mut self, task: &RobotEnv, dt: f64) {
        let s = task.robot_state();
        let idx = task.indices();
        let d = task.data();
        let contact = s.foot_contact();
        self.seconds += dt;
        self.samples += 1;
        self.height_sum += s.base_pos[2];
        if contact[0] && contact[1] {
            self.double += dt;
        }
        for f in 0..2 {
            let site = idx.foot_sites[f];
            let height = d.site_xpos()[site][2];
            if contact[f] {
                let v = d.object_velocity(mujoco::ObjType::Site, site, false);
                self.slip_sum += v[3].hypot(v[4]) * dt;
                match self.contact[f] {
                    Some(false) => {
                        self.steps += 1;
                        self.air_sum += self.swing_time[f];
                        self.clearance_sum += self.swing_top[f];
                        self.stances += 1;
                    }
                    None => self.stances += 1,
                    Some(true) => {}
                }
            } else {
                if self.contact[f] != Some(false) {
                    self.swing_time[f] = 0.0;
                    self.swing_top[f] = height;
                }
                self.swing_time[f] += dt;
                self.swing_top[f] = self.swing_top[f].max(height);
            }
            self.contact[f] = Some(contact[f]);
        }
    }

    /// Adds the totals of another run (the same command from another initial state): the pooled statistics weigh
    /// every step and every second alike. The other run's swing in progress is dropped, as at the end of a window.
    pub fn absorb(&mut self, o: &GaitAccumulator) {
        self.seconds += o.seconds;
        self.steps += o.steps;
        self.air_sum += o.air_sum;
        self.clearance_sum += o.clearance_sum;
        self.slip_sum += o.slip_sum;
        self.stances += o.stances;
        self.double += o.double;
        self.height_sum += o.height_sum;
        self.samples += o.samples;
    }

    pub fn finish(&self) -> GaitStats {
        let per_step = |x: f64| if self.steps > 0 { x / self.steps as f64 } else { f64::NAN };
        let t = self.seconds.max(1e-12);
        GaitStats {
            seconds: self.seconds,
            steps_per_s: self.steps as f64 / 2.0 / t,
            air_time_s: per_step(self.air_sum),
            clearance_m: per_step(self.clearance_sum),
            slip_per_stance_m: if self.stances > 0 { self.slip_sum / self.stances as f64 } else { f64::NAN },
            double_support: self.double / t,
            base_height_m: if self.samples > 0 { self.height_sum / self.samples as f64 } else { f64::NAN },
        }
    }
}
