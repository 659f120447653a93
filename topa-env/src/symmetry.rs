//! The paper's S_o and S_a: mirror maps of observations and actions in the XZ plane, as signed permutations
//! (`out[i] = sign[i] · in[perm[i]]`), derived from the robot spec.

pub use trainer::symmetry::{SignedPermutation, Symmetry};

use crate::observation::{Mirror, ObsLayout};
use crate::robot;

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
    for (block, offset, _) in layout.blocks() {
        match block.mirror() {
            Mirror::Vector => obs.set_block(offset, &id3, &VEC_SIGN),
            Mirror::PseudoVector => obs.set_block(offset, &id3, &PSEUDO_SIGN),
            Mirror::Command => obs.set_block(offset, &id3, &CMD_SIGN),
            Mirror::Motors => obs.set_block(offset, motor_perm, motor_sign),
        }
    }
    let mut act = SignedPermutation::identity(layout.n_motors);
    act.set_block(0, motor_perm, motor_sign);
    Symmetry { obs, act }
}

/// S_o and S_a for the TopA observation `[v, ω, g, q, q̇, a_prev, c]` (3+3+3+10+10+10+3) and action (10).
pub fn topa() -> Symmetry {
    let (leg_perm, leg_sign) = robot::mirror_legs_map();
    for_layout(&crate::observation::TOPA, &leg_perm, &leg_sign)
}

/// Mirrors a full MuJoCo state of a TopA model in the XZ plane (for equivariance checks and data augmentation):
/// the free base's y, its orientation and velocities, and every `l_*`/`r_*` hinge pair (roll and yaw joints flip
/// sign). Derived from the joint names, so the closed model's passive linkage joints are included.
pub fn mirror_mj_state(
    model: &mujoco_sys::Model,
    qpos: &[f64],
    qvel: &[f64],
) -> crate::error::Result<(Vec<f64>, Vec<f64>)> {
    use mujoco_sys::{ffi, ObjType};
    let (mut p, mut v) = (qpos.to_vec(), qvel.to_vec());
    for j in 0..model.njnt() {
        let (qa, da) = (model.jnt_qposadr_of(j), model.jnt_dofadr_of(j));
        if model.jnt_type()[j] == ffi::mjJNT_FREE as i32 {
            p[qa + 1] = -qpos[qa + 1];
            // Quaternion (w, x, y, z) of S R S with S = diag(1, −1, 1): x and z flip.
            p[qa + 4] = -qpos[qa + 4];
            p[qa + 6] = -qpos[qa + 6];
            v[da + 1] = -qvel[da + 1]; // world linear velocity: y flips
            v[da + 3] = -qvel[da + 3]; // body angular velocity (pseudo-vector): x and z flip
            v[da + 5] = -qvel[da + 5];
            continue;
        }
        let name = model.name_of(ObjType::Joint, j).unwrap_or("");
        let partner = match name.split_once('_') {
            Some(("l", rest)) => format!("r_{rest}"),
            Some(("r", rest)) => format!("l_{rest}"),
            _ => continue,
        };
        let k = model.id(ObjType::Joint, &partner)?;
        let sign = if name.contains("roll") || name.contains("yaw") { -1.0 } else { 1.0 };
        p[qa] = sign * qpos[model.jnt_qposadr_of(k)];
        v[da] = sign * qvel[model.jnt_dofadr_of(k)];
    }
    Ok((p, v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topa_maps_are_involutions_with_the_right_signs() {
        let s = topa();
        assert!(s.obs.is_involution() && s.act.is_involution());
        assert_eq!(s.obs.len(), 42);
        let x: Vec<f32> = (0..42).map(|i| i as f32 + 1.0).collect();
        let mut m = vec![0.0; 42];
        s.obs.apply(&x, &mut m);
        let mut mm = vec![0.0; 42];
        s.obs.apply(&m, &mut mm);
        assert_eq!(mm, x);
        assert_eq!(&m[0..3], &[1.0, -2.0, 3.0]); // v: y flips
        assert_eq!(&m[3..6], &[-4.0, 5.0, -6.0]); // ω: roll and yaw rates flip
        assert_eq!(&m[6..9], &[7.0, -8.0, 9.0]); // g: y flips
        assert_eq!(m[9], -x[14]); // left hip roll ← −right hip roll
        assert_eq!(m[12], x[17]); // left knee ← right knee
        assert_eq!(&m[39..42], &[40.0, -41.0, -42.0]); // command: v_y and w_z flip
    }
}
