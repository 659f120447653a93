//! PD gains for actuators that have none (a published model's torque motors): kp from the load, so that the motor
//! reaches its torque limit at `saturation` rad of error, and kd from the joint's inertia (armature, the reflected
//! rotor inertia, included), for a damping ratio `zeta` at the stand pose. Actuators that already are PD loops keep
//! their gains.

use mujoco::{Data, Model};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    pub kp: f64,
    pub kd: f64,
    /// Whether the model already had them.
    pub kept: bool,
}

/// How the gains of torque motors are suggested.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GainRule {
    /// Error at which the PD loop reaches the torque limit, rad.
    pub saturation: f64,
    /// Damping ratio on the joint's own inertia at the stand pose.
    pub zeta: f64,
}

impl Default for GainRule {
    fn default() -> Self {
        // Kestrel's and TopA's hand-set gains reach their limits at 0.4–0.9 rad of error.
        GainRule { saturation: 1.0, zeta: 0.5 }
    }
}

/// Gains of each actuator of `data`'s model at its current pose (its forward dynamics computed), with
/// `torque_limit` per actuator.
pub fn suggest(data: &Data, torque_limit: &[f64], rule: GainRule) -> Vec<Gains> {
    let m: &Model = data.model();
    let nv = m.nv();
    let mass = data.full_mass_matrix();
    (0..m.nu())
        .map(|a| {
            let (kp, bias) = (m.actuator_gainprm()[a][0], m.actuator_biasprm()[a]);
            if kp > 0.0 && (bias[1] + kp).abs() <= 1e-12 * kp {
                return Gains { kp, kd: -bias[2], kept: true };
            }
            let dof = m.jnt_dofadr_of(m.actuator_trnid()[a][0] as usize);
            let inertia = mass[dof * nv + dof];
            let kp = torque_limit[a] / rule.saturation;
            Gains { kp, kd: 2.0 * rule.zeta * (kp * inertia).sqrt(), kept: false }
        })
        .collect()
}
