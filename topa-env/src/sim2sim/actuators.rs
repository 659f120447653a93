//! The motors as they are rather than as the MJCF's datasheet numbers say: armature, damping, dry friction and
//! torque constant per motor — identified values (`topa sysid fit` writes them), or a hidden "real robot" to measure
//! how much of the sim2sim gap identification closes.

use std::sync::Arc;

use mujoco::{Data, Model};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::indices::RobotIndices;

/// Per motor, in the robot spec's motor order; an empty list keeps the MJCF's values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema, Default)]
#[serde(deny_unknown_fields, default)]
pub struct ActuatorConfig {
    /// Put these values on the evaluation model.
    pub enabled: bool,
    /// Reflected rotor inertia, kg·m².
    pub armature: Vec<f64>,
    /// Viscous friction, N·m·s/rad.
    pub damping: Vec<f64>,
    /// Dry friction, N·m.
    pub frictionloss: Vec<f64>,
    /// Torque per unit of the drive's command (scales the PD gains).
    pub torque_constant: Vec<f64>,
}

impl ActuatorConfig {
    fn lists(&self) -> [(&'static str, &Vec<f64>); 4] {
        [
            ("armature", &self.armature),
            ("damping", &self.damping),
            ("frictionloss", &self.frictionloss),
            ("torque_constant", &self.torque_constant),
        ]
    }

    pub fn validate(&self, n_motors: usize) -> crate::error::Result<()> {
        if !self.enabled {
            return Ok(());
        }
        for (name, v) in self.lists() {
            if !v.is_empty() && v.len() != n_motors {
                return Err(crate::error::EnvError::Config(format!(
                    "sim2sim.actuators.{name} has {} values; the robot has {n_motors} motors (one each, or none)",
                    v.len()
                )));
            }
            if v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) || (name == "torque_constant" && v.contains(&0.0)) {
                return Err(crate::error::EnvError::Config(format!(
                    "sim2sim.actuators.{name}: values must be finite and positive (≥ 0 for friction)"
                )));
            }
        }
        Ok(())
    }

    /// Writes the values onto `m` in place, motor i being `motors[i]` = (its joint's dof, its actuator): the joint's
    /// armature, damping and frictionloss, and the torque constant as a factor on the actuator's PD gains (gainprm =
    /// kp, biasprm = 0 −kp −kd). Without `Data::set_const` afterwards a changed armature has no effect.
    pub fn put(&self, m: &mut Model, motors: &[(usize, usize)]) {
        for (i, &(dof, a)) in motors.iter().enumerate() {
            if let Some(&v) = self.armature.get(i) {
                m.dof_armature_mut()[dof] = v;
            }
            if let Some(&v) = self.damping.get(i) {
                m.dof_damping_mut()[dof] = v;
            }
            if let Some(&v) = self.frictionloss.get(i) {
                m.dof_frictionloss_mut()[dof] = v;
            }
            if let Some(&k) = self.torque_constant.get(i) {
                m.actuator_gainprm_mut()[a][0] *= k;
                m.actuator_biasprm_mut()[a][1] *= k;
                m.actuator_biasprm_mut()[a][2] *= k;
            }
        }
    }

    /// Puts the values on `model` (a copy when they differ) and recomputes what depends on them.
    pub fn apply(&self, model: &mut Arc<Model>, idx: &RobotIndices) -> Result<()> {
        if !self.enabled {
            return Ok(());
        }
        self.validate(idx.n_motors)?;
        let motors: Vec<(usize, usize)> = idx.actuated_dof.iter().copied().zip(idx.actuators.iter().copied()).collect();
        self.put(Arc::make_mut(model), &motors);
        Ok(Data::set_const_of(model)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::RobotSpec;

    #[test]
    fn values_land_on_the_motors_and_bad_lists_are_refused() {
        let (spec, model) = RobotSpec::load(&crate::assets::resolve_path("assets/robots/topa_closed.toml")).unwrap();
        let mut model = Arc::new(model);
        let idx = RobotIndices::resolve(&model, &Arc::new(spec)).unwrap();
        let n = idx.n_motors;
        let before = model.clone();
        let cfg = ActuatorConfig {
            enabled: true,
            armature: vec![0.05; n],
            torque_constant: (0..n).map(|i| 0.5 + 0.1 * i as f64).collect(),
            ..Default::default()
        };
        cfg.apply(&mut model, &idx).unwrap();
        for i in 0..n {
            let (dof, a) = (idx.actuated_dof[i], idx.actuators[i]);
            assert_eq!(model.dof_armature()[dof], 0.05);
            assert_eq!(model.dof_damping()[dof], before.dof_damping()[dof], "an empty list keeps the MJCF's");
            let k = 0.5 + 0.1 * i as f64;
            assert!((model.actuator_gainprm()[a][0] - k * before.actuator_gainprm()[a][0]).abs() < 1e-12);
            assert!((model.actuator_biasprm()[a][2] - k * before.actuator_biasprm()[a][2]).abs() < 1e-12);
        }
        // The shared model the caller still holds is untouched.
        assert_ne!(before.dof_armature()[idx.actuated_dof[0]], 0.05);
        let short = ActuatorConfig { enabled: true, damping: vec![0.1; 3], ..Default::default() };
        assert!(short.validate(n).unwrap_err().to_string().contains("damping has 3 values; the robot has 10 motors"));
        let negative = ActuatorConfig { enabled: true, frictionloss: vec![-0.1; n], ..Default::default() };
        assert!(negative.validate(n).is_err());
        let off = ActuatorConfig { enabled: false, damping: vec![0.1; 3], ..Default::default() };
        assert!(off.validate(n).is_ok());
    }
}
