//! The paper's S_o and S_a: mirror maps of observations and actions in the XZ plane, as signed permutations
//! (`out[i] = sign[i] · in[perm[i]]`), derived from the robot spec.

pub use trainer::symmetry::{SignedPermutation, Symmetry};

use crate::observation::{Mirror, ObsLayout};

/// Mirror of a robot-frame vector (x forward, y left, z up) in the XZ plane: y flips.
const VEC_SIGN: [f32; 3] = [1.0, -1.0, 1.0];
/// Mirror of an angular velocity (a pseudo-vector): x and z flip.
const PSEUDO_SIGN: [f32; 3] = [-1.0, 1.0, -1.0];
/// Mirror of the command (v_x, v_y, w_z): v_y and w_z flip.
const CMD_SIGN: [f32; 3] = [1.0, -1.0, -1.0];

/// S_o and S_a for an observation layout, given the robot's motor mirror (`out[i] = sign[i] · in[perm[i]]`).
pub fn for_layout(layout: &ObsLayout, motor_perm: &[usize], motor_sign: &[f32]) -> Symmetry {
    let id3 = [0, 1, 2];
    let mut obs = SignedPermutation::identity(layout.dim());
    let put = |obs: &mut SignedPermutation, mirror: Mirror, offset: usize| match mirror {
        Mirror::Vector => obs.set_block(offset, &id3, &VEC_SIGN),
        Mirror::PseudoVector => obs.set_block(offset, &id3, &PSEUDO_SIGN),
        Mirror::Command => obs.set_block(offset, &id3, &CMD_SIGN),
        Mirror::Motors => obs.set_block(offset, motor_perm, motor_sign),
        Mirror::Scan => {
            let perm = layout.scan_mirror();
            obs.set_block(offset, &perm, &vec![1.0; perm.len()]);
        }
        Mirror::History => unreachable!("a history frame holds proprioception blocks only"),
    };
    for (block, offset, _) in layout.blocks() {
        if block.mirror() != Mirror::History {
            put(&mut obs, block.mirror(), offset);
            continue;
        }
        // Each earlier frame is mirrored as the current frame's blocks are.
        for f in 0..layout.history {
            for (b, at, _) in layout.frame_blocks() {
                put(&mut obs, b.mirror(), offset + f * layout.frame() + at);
            }
        }
    }
    let mut act = SignedPermutation::identity(layout.n_motors);
    act.set_block(0, motor_perm, motor_sign);
    Symmetry { obs, act }
}

/// The XZ-plane mirror of a whole MuJoCo state (for equivariance checks and data augmentation), derived from the
/// model's geometry rather than joint names: at `qpos0` a joint's mirror partner is the joint of the same type
/// whose world anchor is its anchor reflected (y → −y) and whose axis is its axis reflected — a hinge axis is a
/// pseudo-vector (reflects to (−x, y, −z)), a slide axis a vector ((x, −y, z)); the coordinate keeps its sign
/// when the partner's axis is that reflection and flips when it is the opposite. Joints on the plane are their
/// own partners (a roll joint there flips). Every joint is covered, the linkages' passive ones included.
pub struct StateMirror {
    /// qpos[i] of the mirror = qpos_sign[i] · qpos[qpos_perm[i]]; likewise for qvel.
    qpos_perm: Vec<usize>,
    qpos_sign: Vec<f64>,
    qvel_perm: Vec<usize>,
    qvel_sign: Vec<f64>,
}

/// Anchors and axes closer than this are the same (metres; unit-vector components).
const MIRROR_TOL: f64 = 1e-6;

impl StateMirror {
    pub fn new(model: &std::sync::Arc<mujoco::Model>) -> crate::error::Result<Self> {
        use mujoco::{JointType, ObjType};
        let mut d = mujoco::Data::new(model.clone())?;
        d.kinematics()?;
        let (nq, nv) = (model.nq(), model.nv());
        let mut m = StateMirror {
            qpos_perm: (0..nq).collect(),
            qpos_sign: vec![1.0; nq],
            qvel_perm: (0..nv).collect(),
            qvel_sign: vec![1.0; nv],
        };
        let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|i| (a[i] - b[i]).abs() < MIRROR_TOL);
        for j in 0..model.njnt() {
            let (qa, da) = (model.jnt_qposadr_of(j), model.jnt_dofadr_of(j));
            let t = model.jnt_type(j);
            if t == JointType::Free {
                // Position: y flips. Quaternion (w, x, y, z) of S R S with S = diag(1, −1, 1): x and z flip.
                // World linear velocity: y flips; body angular velocity (a pseudo-vector): x and z flip.
                for k in [1, 4, 6] {
                    m.qpos_sign[qa + k] = -1.0;
                }
                for k in [1, 3, 5] {
                    m.qvel_sign[da + k] = -1.0;
                }
                continue;
            }
            let name = || model.name_of(ObjType::Joint, j).unwrap_or("?").to_string();
            if t == JointType::Ball {
                return Err(crate::error::EnvError::Config(format!(
                    "joint '{}' is a ball joint: the state mirror handles hinge, slide and free joints",
                    name()
                )));
            }
            let [x, y, z] = d.xanchor()[j];
            let anchor = [x, -y, z];
            let [ax, ay, az] = d.xaxis()[j];
            let axis = if t == JointType::Hinge { [-ax, ay, -az] } else { [ax, -ay, az] };
            let partner = (0..model.njnt()).find_map(|k| {
                if model.jnt_type(k) != t || !close(d.xanchor()[k], anchor) {
                    return None;
                }
                let b = d.xaxis()[k];
                if close(b, axis) {
                    Some((k, 1.0))
                } else if close(b, [-axis[0], -axis[1], -axis[2]]) {
                    Some((k, -1.0))
                } else {
                    None
                }
            });
            let Some((k, sign)) = partner else {
                return Err(crate::error::EnvError::Config(format!(
                    "joint '{}' has no mirror image (no joint at ({x:.4}, {:.4}, {z:.4}) with the reflected axis at \
                     qpos0): the model is not left-right symmetric",
                    name(),
                    -y
                )));
            };
            m.qpos_perm[qa] = model.jnt_qposadr_of(k);
            m.qpos_sign[qa] = sign;
            m.qvel_perm[da] = model.jnt_dofadr_of(k);
            m.qvel_sign[da] = sign;
        }
        Ok(m)
    }

    /// The mirrored (qpos, qvel).
    pub fn apply(&self, qpos: &[f64], qvel: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let p = self.qpos_perm.iter().zip(&self.qpos_sign).map(|(&i, s)| s * qpos[i]).collect();
        let v = self.qvel_perm.iter().zip(&self.qvel_sign).map(|(&i, s)| s * qvel[i]).collect();
        (p, v)
    }
}

/// Mirrors a full MuJoCo state in the XZ plane (see `StateMirror`; builds the map each call).
pub fn mirror_mj_state(
    model: &std::sync::Arc<mujoco::Model>,
    qpos: &[f64],
    qvel: &[f64],
) -> crate::error::Result<(Vec<f64>, Vec<f64>)> {
    Ok(StateMirror::new(model)?.apply(qpos, qvel))
}
