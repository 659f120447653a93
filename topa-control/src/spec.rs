//! The controller file (`controller.json`, written by `topa export --controller DIR` beside a copy of the policy's
//! weights): everything the robot side needs — the motors, their gains and ranges, the observation's layout, the
//! linkage map where the policy acts in joint space, the command ranges, the safety limits — as data, validated
//! before use.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
pub use crate::observation::BaseVelocity;

pub const FORMAT: &str = "topa-controller";
pub const VERSION: u32 = 1;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    pub format: String,
    pub version: u32,
    /// The robot's name (a file for another robot is refused by its motor names).
    pub robot: String,
    /// The policy file it was exported from (for the record).
    pub policy: String,
    pub motors: Vec<MotorSpec>,
    /// Motor target = action zero + action_scale · clip(action, ±action_clip), within the motor's range.
    pub action_scale: f64,
    pub action_clip: f64,
    pub control_period_s: f64,
    pub observation: ObservationSpec,
    /// J (motor → joint) and J⁻¹, row-major n × n, where the policy acts in joint space (a policy trained on a
    /// serial approximation of the robot); none where it acts in motor space.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_map: Option<[Vec<f64>; 2]>,
    /// The policy's network sizes.
    pub hidden: Vec<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimator_hidden: Option<Vec<usize>>,
    /// The ranges of (v_x, v_y, w_z) the policy was trained on: commands are clamped to them.
    pub command_ranges: [[f64; 2]; 3],
    pub safety: SafetySpec,
    /// The weights file (same folder) and its CRC-32.
    pub weights: String,
    pub weights_crc32: u32,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorSpec {
    pub name: String,
    /// Motor position range, rad.
    pub range: [f64; 2],
    /// The stand pose (what the observation's positions are offsets from) and a zero action's target, rad.
    pub nominal: f64,
    pub action_zero: f64,
    /// The PD gains the policy was trained with (N·m/rad, N·m·s/rad).
    pub kp: f64,
    pub kd: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObservationSpec {
    pub base_velocity: BaseVelocity,
    pub history: usize,
    /// Values the actor reads (the policy's input): the row without privileged values.
    pub inputs: usize,
    /// Values of the normaliser's row (the inputs, and the privileged velocity where the policy had one).
    pub row: usize,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafetySpec {
    /// Damping when the torso tilts further than this from upright, rad.
    pub max_tilt_rad: f64,
    /// Damping when no valid frame came for this many control periods. The controller notices at its next tick,
    /// so 2 means damping within 3 periods of the last frame. A robot should send frames faster than the control
    /// rate (drives report at their bus rate), so that a lost frame or two never looks like a silent robot.
    pub stale_periods: f64,
    /// The soft start's ramp from the measured pose to the stand pose, s.
    pub soft_start_s: f64,
    /// Damping when a motor leaves its range by more than this, rad.
    pub range_margin_rad: f64,
    /// The operator's command moves towards its target at most this fast, per second: (v_x, v_y, w_z).
    pub command_rate: [f64; 3],
    /// Damping: zero stiffness and the motor's kd times this.
    pub damping_kd_scale: f64,
}

impl Default for SafetySpec {
    fn default() -> Self {
        SafetySpec {
            max_tilt_rad: 0.8,
            stale_periods: 2.0,
            soft_start_s: 2.0,
            range_margin_rad: 0.1,
            command_rate: [1.0, 1.0, 2.0],
            damping_kd_scale: 1.0,
        }
    }
}

impl ControllerSpec {
    /// Loads and validates `path` (`controller.json`, or the folder holding it).
    pub fn load(path: &Path) -> Result<(ControllerSpec, PathBuf)> {
        let json = if path.is_dir() { path.join("controller.json") } else { path.to_path_buf() };
        let text = std::fs::read_to_string(&json).map_err(|source| Error::Io { path: json.clone(), source })?;
        let bad = |message: String| Error::File { path: json.clone(), message };
        let spec: ControllerSpec = serde_json::from_str(&text)
            .map_err(|e| bad(format!("{e}; export it again with `topa export --policy P --controller DIR`")))?;
        if spec.format != FORMAT || spec.version != VERSION {
            return Err(bad(format!(
                "format {} version {}, expected {FORMAT} version {VERSION}: export it again",
                spec.format, spec.version
            )));
        }
        spec.validate().map_err(|e| bad(e.to_string()))?;
        let weights = json.parent().unwrap_or(Path::new(".")).join(&spec.weights);
        Ok((spec, weights))
    }

    pub fn n_motors(&self) -> usize {
        self.motors.len()
    }

    /// Sizes, finite values and ranges; a message naming the key otherwise.
    pub fn validate(&self) -> Result<()> {
        let n = self.n_motors();
        if n == 0 {
            return Err(Error::Invalid("motors: none".into()));
        }
        for m in &self.motors {
            let vals = [m.range[0], m.range[1], m.nominal, m.action_zero, m.kp, m.kd];
            if vals.iter().any(|v| !v.is_finite()) || m.range[0] >= m.range[1] || m.kp < 0.0 || m.kd < 0.0 {
                return Err(Error::Invalid(format!(
                    "motor '{}': ranges, pose and gains must be finite, gains ≥ 0",
                    m.name
                )));
            }
        }
        let positive = [
            ("action_scale", self.action_scale),
            ("action_clip", self.action_clip),
            ("control_period_s", self.control_period_s),
            ("safety.max_tilt_rad", self.safety.max_tilt_rad),
            ("safety.stale_periods", self.safety.stale_periods),
            ("safety.soft_start_s", self.safety.soft_start_s),
        ];
        if let Some((k, v)) = positive.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
            return Err(Error::Invalid(format!("{k} must be positive, got {v}")));
        }
        let o = &self.observation;
        let expect = crate::observation::Layout::new(n, o.base_velocity, o.history);
        if o.inputs != expect.inputs() || o.row != expect.row() {
            return Err(Error::Invalid(format!(
                "observation: {} inputs in a row of {}, but {n} motors with this velocity and history make {} in {}",
                o.inputs,
                o.row,
                expect.inputs(),
                expect.row()
            )));
        }
        if let Some([j, inv]) = &self.joint_map {
            if j.len() != n * n || inv.len() != n * n || j.iter().chain(inv).any(|v| !v.is_finite()) {
                return Err(Error::Invalid(format!("joint_map: two finite {n} × {n} matrices")));
            }
        }
        if (o.base_velocity == BaseVelocity::Estimated) != self.estimator_hidden.is_some() {
            return Err(Error::Invalid("estimator_hidden: given exactly when the base velocity is estimated".into()));
        }
        Ok(())
    }
}
