//! The closed loops of a model, found from the model alone: each equality constraint between two bodies closes a
//! loop through the kinematic tree, and the joints on the tree path between the two bodies are the loop's. Those no
//! actuator drives are its passive joints, or its springs where they have a stiffness — what a robot spec's
//! `[[loops]]` lists, and what an import drafts. `Posed` answers the geometric questions of a pose (mirror signs).

use std::sync::Arc;

use mujoco::{Data, EqualityType, JointType, Model, MujocoError, ObjType, Transmission};

/// A loop closed by one equality constraint.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedLoop {
    /// The equality constraint's id, and its name where it has one.
    pub equality: usize,
    pub name: Option<String>,
    /// The joints on the tree path between the constraint's two bodies (floating bases left out), from the first
    /// body up to the common ancestor, then from the second.
    pub joints: Vec<usize>,
    /// Those an actuator drives, the others with no spring (hinges, slides, balls), and those with one.
    pub driven: Vec<usize>,
    pub passive: Vec<usize>,
    pub springs: Vec<usize>,
}

/// Every loop of `model`: one per active connect or weld constraint between two bodies of one tree (a constraint
/// to the world, a joint or tendon equality closes no loop through bodies).
pub fn loops(model: &Model) -> Vec<ClosedLoop> {
    let driven_joints: Vec<usize> = (0..model.nu())
        .filter(|&a| model.actuator_trntype(a) == Transmission::Joint)
        .map(|a| model.actuator_trnid()[a][0] as usize)
        .collect();
    let mut out = Vec::new();
    for e in 0..model.neq() {
        if !matches!(model.eq_type(e), EqualityType::Connect | EqualityType::Weld) {
            continue;
        }
        let (b1, b2) = (model.eq_obj1id()[e] as usize, model.eq_obj2id()[e] as usize);
        let (up1, up2) = (ancestors(model, b1), ancestors(model, b2));
        let Some(&common) = up1.iter().find(|b| up2.contains(b)) else { continue };
        if common == 0 && (b1 == 0 || b2 == 0) {
            continue; // a body held to the world
        }
        let below = |up: &[usize]| up.iter().take_while(|&&b| b != common).copied().collect::<Vec<_>>();
        let joints: Vec<usize> = below(&up1)
            .into_iter()
            .chain(below(&up2))
            .flat_map(|b| body_joints(model, b))
            .filter(|&j| model.jnt_type(j) != JointType::Free)
            .collect();
        let (driven, free): (Vec<usize>, Vec<usize>) = joints.iter().partition(|j| driven_joints.contains(j));
        let (springs, passive) = free.into_iter().partition(|&j| model.jnt_stiffness()[j] > 0.0);
        let name = model.name_of(ObjType::Equality, e).map(str::to_string);
        out.push(ClosedLoop { equality: e, name, joints, driven, passive, springs });
    }
    out
}

/// `body` and its ancestors up to the world (body 0), nearest first.
pub fn ancestors(model: &Model, body: usize) -> Vec<usize> {
    let mut chain = vec![body];
    let mut b = body;
    while b != 0 {
        b = model.body_parentid()[b] as usize;
        chain.push(b);
    }
    chain
}

fn body_joints(model: &Model, body: usize) -> std::ops::Range<usize> {
    let adr = model.body_jntadr()[body];
    let n = model.body_jntnum()[body] as usize;
    if adr < 0 {
        0..0
    } else {
        adr as usize..adr as usize + n
    }
}

/// A model posed at one configuration (a keyframe), for the geometric questions an import and the spec loader ask:
/// which way the left↔right mirror turns a joint, where a geom's lowest point is.
pub struct Posed {
    data: Data,
    /// The base's sagittal-plane normal (its y axis) and a point of the plane (its origin), world frame.
    normal: [f64; 3],
    origin: [f64; 3],
}

impl Posed {
    /// `model` at `qpos`, with the sagittal plane of `base_body`.
    pub fn new(model: &Model, qpos: &[f64], base_body: usize) -> Result<Posed, MujocoError> {
        let mut data = Data::new(Arc::new(model.try_clone()?))?;
        data.qpos_mut().copy_from_slice(qpos);
        data.kinematics()?;
        let r = data.xmat()[base_body];
        let normal = [r[1], r[4], r[7]];
        let origin = data.xpos()[base_body];
        Ok(Posed { data, normal, origin })
    }

    pub fn data(&self) -> &Data {
        &self.data
    }

    /// The sign the mirror puts on joint `b`'s position for joint `a`'s: +1 where b's axis is a's reflected
    /// through the sagittal plane, −1 where it is the reverse, `None` where neither holds within 0.1 rad (not a
    /// mirror pair, or not a hinge or slide). An axis is a pseudo-vector for a hinge (a reflection also reverses
    /// it) and a vector for a slide.
    pub fn mirror_sign(&self, a: usize, b: usize) -> Option<f64> {
        let m = self.data.model();
        let kind = m.jnt_type(a);
        if kind != m.jnt_type(b) || !matches!(kind, JointType::Hinge | JointType::Slide) {
            return None;
        }
        let (xa, xb) = (self.data.xaxis()[a], self.data.xaxis()[b]);
        let n = self.normal;
        let along = xa[0] * n[0] + xa[1] * n[1] + xa[2] * n[2];
        let pseudo = if kind == JointType::Hinge { -1.0 } else { 1.0 };
        let reflected: [f64; 3] = std::array::from_fn(|k| pseudo * (xa[k] - 2.0 * along * n[k]));
        let cos = (0..3).map(|k| reflected[k] * xb[k]).sum::<f64>();
        (cos.abs() > 0.1f64.cos()).then(|| cos.signum())
    }

    /// How far joint `b`'s anchor is from joint `a`'s reflected through the sagittal plane, m.
    pub fn anchor_asymmetry(&self, a: usize, b: usize) -> f64 {
        let (pa, pb) = (self.data.xanchor()[a], self.data.xanchor()[b]);
        let (n, o) = (self.normal, self.origin);
        let side = (0..3).map(|k| (pa[k] - o[k]) * n[k]).sum::<f64>();
        (0..3).map(|k| (pa[k] - 2.0 * side * n[k] - pb[k]).powi(2)).sum::<f64>().sqrt()
    }
}
