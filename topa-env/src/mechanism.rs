//! The closed loops of a model, found from the model alone: each equality constraint between two bodies closes a
//! loop through the kinematic tree, and the joints on the tree path between the two bodies are the loop's. Those no
//! actuator drives are its passive joints — what a robot spec's `[[loops]]` lists, and what an import drafts.

use mujoco::{EqualityType, JointType, Model, ObjType, Transmission};

/// A loop closed by one equality constraint.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedLoop {
    /// The equality constraint's id, and its name where it has one.
    pub equality: usize,
    pub name: Option<String>,
    /// The joints on the tree path between the constraint's two bodies (floating bases left out), from the first
    /// body up to the common ancestor, then from the second.
    pub joints: Vec<usize>,
    /// Those an actuator drives, and the others (hinges, slides, balls; springs included).
    pub driven: Vec<usize>,
    pub passive: Vec<usize>,
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
        let (driven, passive) = joints.iter().partition(|j| driven_joints.contains(j));
        let name = model.name_of(ObjType::Equality, e).map(str::to_string);
        out.push(ClosedLoop { equality: e, name, joints, driven, passive });
    }
    out
}

/// `body` and its ancestors up to the world (body 0), nearest first.
fn ancestors(model: &Model, body: usize) -> Vec<usize> {
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
