//! A robot spec drafted from a compiled model alone: the floating base, each actuator's joint and limits, the
//! left↔right mirror (by name, confirmed by the geometry, or by the geometry alone), the feet (the lowest collision
//! geom on each side), reward groups by joint axis, and the loops with their passive joints and springs. What the
//! model cannot decide is left as a `CHOOSE` value the spec loader refuses, naming what to choose.

use std::path::Path;

use mujoco::{Data, JointType, Model, ObjType, Transmission};
use topa_env::mechanism::{self, ancestors, Posed};

use crate::error::{Error, Result};
use crate::geometry::{in_body_frame, lowest_point};

/// Prefix of a value the model could not decide (the loader refuses it and prints it).
pub const CHOOSE: &str = "CHOOSE";

/// Left↔right name pairs tried on a joint's name (both ways), before the geometry alone.
const SIDES: [(&str, &str); 10] = [
    ("left", "right"),
    ("Left", "Right"),
    ("LEFT", "RIGHT"),
    ("l_", "r_"),
    ("L_", "R_"),
    ("_l", "_r"),
    ("_L", "_R"),
    ("l-", "r-"),
    ("-l", "-r"),
    ("left_", "right_"),
];

/// A motor's left↔right partner, as the model decides it.
#[derive(Debug, Clone, PartialEq)]
pub enum Mirror {
    /// The partner's index among the motors and the sign the mirror puts on this motor's position.
    Found { motor: usize, sign: f64 },
    /// Not decided: the `CHOOSE` value the spec gets, naming what to choose.
    Choose(String),
}

#[derive(Debug, Clone)]
pub struct DraftMotor {
    pub actuator: String,
    pub joint: String,
    /// The joint's range (the actuator's control range), rad (m for a slide).
    pub range: [f64; 2],
    pub torque_limit: f64,
    pub mirror: Mirror,
    /// The kinematic joint where it is not the driven one, or what to choose.
    pub kinematic: Option<String>,
}

#[derive(Debug, Clone)]
pub struct DraftFoot {
    pub body: String,
    /// The geom's name, or (where it has none) the name the derived model gives it, and its index in its body.
    pub geom: String,
    pub geom_in_body: usize,
    pub geom_named: bool,
    pub site: String,
    /// The sole site's position in the foot body's frame, m.
    pub site_pos: [f64; 3],
}

#[derive(Debug, Clone)]
pub struct DraftLoop {
    pub name: String,
    pub equality: Vec<String>,
    pub passive: Vec<String>,
    pub springs: Vec<String>,
}

#[derive(Debug, Clone)]
pub struct Draft {
    pub base_body: String,
    pub base_joint: String,
    pub motors: Vec<DraftMotor>,
    /// Left, then right.
    pub feet: [DraftFoot; 2],
    pub groups: Vec<(&'static str, Vec<usize>)>,
    pub loops: Vec<DraftLoop>,
    /// The stand pose before its loops are closed: the model's first keyframe (or qpos0), base upright at the
    /// origin, springs at rest, mirror pairs made symmetric.
    pub stand_qpos: Vec<f64>,
}

fn name(m: &Model, kind: ObjType, id: usize, path: &Path) -> Result<String> {
    m.name_of(kind, id).map(str::to_string).ok_or_else(|| {
        Error::model(path, format!("{kind} #{id} has no name: the import refers to every {kind} of a robot by name"))
    })
}

/// The draft of `m` (the model at `path`, for errors).
pub fn draft(m: &Model, path: &Path) -> Result<Draft> {
    let free: Vec<usize> = (0..m.njnt()).filter(|&j| m.jnt_type(j) == JointType::Free).collect();
    let [base_joint] = free[..] else {
        return Err(Error::model(
            path,
            format!(
                "a legged robot has one floating base (a <freejoint> on its root body); this model has {}",
                free.len()
            ),
        ));
    };
    let base = m.jnt_bodyid()[base_joint] as usize;
    let mut q = if m.nkey() > 0 { m.key_qpos(0).to_vec() } else { m.qpos0().to_vec() };
    for j in 0..m.njnt() {
        if m.jnt_stiffness()[j] > 0.0 && matches!(m.jnt_type(j), JointType::Hinge | JointType::Slide) {
            let a = m.jnt_qposadr_of(j);
            q[a] = m.qpos_spring()[a];
        }
    }
    let b = m.jnt_qposadr_of(base_joint);
    let z = q[b + 2];
    q[b..b + 7].copy_from_slice(&[0.0, 0.0, z, 1.0, 0.0, 0.0, 0.0]);

    let mut motors = motors(m, path)?;
    let joints: Vec<usize> = (0..m.nu()).map(|a| m.actuator_trnid()[a][0] as usize).collect();
    let posed = Posed::new(m, &q, base)?;
    for (mo, mirror) in motors.iter_mut().zip(mirrors(m, &posed, &joints)) {
        mo.mirror = mirror;
    }
    // The stand pose symmetric: each pair at the mean of the two sides.
    for i in 0..motors.len() {
        if let Mirror::Found { motor: k, sign: s } = motors[i].mirror {
            let (ai, ak) = (m.jnt_qposadr_of(joints[i]), m.jnt_qposadr_of(joints[k]));
            if i <= k {
                let mean = 0.5 * (q[ai] + s * q[ak]);
                q[ai] = mean;
                q[ak] = s * mean;
            }
        }
    }
    let posed = Posed::new(m, &q, base)?;
    let feet = feet(m, posed.data(), base, path)?;
    let foot_bodies = [m.id(ObjType::Body, &feet[0].body)?, m.id(ObjType::Body, &feet[1].body)?];
    let found = mechanism::loops(m);
    let loops = loops(m, &found, path)?;
    // A motor on a crank beside the leg (not on the chain from the base to a foot) moves a kinematic joint
    // through its loop: which one is the user's choice.
    let chains: Vec<Vec<usize>> = foot_bodies.iter().map(|&f| ancestors(m, f)).collect();
    for (i, mo) in motors.iter_mut().enumerate() {
        let body = m.jnt_bodyid()[joints[i]] as usize;
        if !chains.iter().any(|c| c.contains(&body)) {
            let via = found
                .iter()
                .find(|f| f.driven.contains(&joints[i]))
                .and_then(|f| m.name_of(ObjType::Equality, f.equality))
                .map_or(String::new(), |e| format!(" through the loop of '{e}'"));
            mo.kinematic = Some(format!("{CHOOSE}: the kinematic joint '{}' moves{via} (a passive joint)", mo.joint));
        }
    }
    let groups = groups(m, posed.data(), base, &joints, &chains);
    Ok(Draft {
        base_body: name(m, ObjType::Body, base, path)?,
        base_joint: name(m, ObjType::Joint, base_joint, path)?,
        motors,
        feet,
        groups,
        loops,
        stand_qpos: q,
    })
}

/// Each actuator: its name, its joint, the joint's range and the torque limit (the mirror still to find).
fn motors(m: &Model, path: &Path) -> Result<Vec<DraftMotor>> {
    let mut out = Vec::new();
    for a in 0..m.nu() {
        let actuator = name(m, ObjType::Actuator, a, path)?;
        if m.actuator_trntype(a) != Transmission::Joint {
            return Err(Error::model(
                path,
                format!(
                    "actuator '{actuator}' acts through a {}: the import maps actuators on a joint only (a motor on a \
                     tendon or site has no joint target for the policy)",
                    m.actuator_trntype(a)
                ),
            ));
        }
        let j = m.actuator_trnid()[a][0] as usize;
        let joint = name(m, ObjType::Joint, j, path)?;
        if !matches!(m.jnt_type(j), JointType::Hinge | JointType::Slide) {
            return Err(Error::model(
                path,
                format!("actuator '{actuator}' drives '{joint}', which is not a hinge or slide"),
            ));
        }
        if m.jnt_limited()[j] == 0 {
            return Err(Error::model(
                path,
                format!("joint '{joint}' (actuator '{actuator}') has no range: give it one, the policy's targets stay inside it"),
            ));
        }
        let gear = m.actuator_gear()[a][0].abs();
        let mut limit = f64::INFINITY;
        if m.actuator_forcelimited()[a] != 0 {
            let [lo, hi] = m.actuator_forcerange()[a];
            limit = lo.abs().max(hi.abs());
        }
        // A torque motor's control is a torque at the gear's input.
        let is_motor = m.actuator_gaintype()[a] == 0 && m.actuator_biastype()[a] == 0;
        if is_motor && m.actuator_ctrllimited()[a] != 0 {
            let [lo, hi] = m.actuator_ctrlrange()[a];
            limit = limit.min(gear * m.actuator_gainprm()[a][0] * lo.abs().max(hi.abs()));
        }
        if !(limit.is_finite() && limit > 0.0) {
            return Err(Error::model(
                path,
                format!(
                    "actuator '{actuator}' has no torque limit: give it a forcerange (or a ctrlrange on a <motor>)"
                ),
            ));
        }
        out.push(DraftMotor {
            actuator,
            joint,
            range: m.jnt_range()[j],
            torque_limit: limit,
            mirror: Mirror::Choose(String::new()),
            kinematic: None,
        });
    }
    if out.is_empty() {
        return Err(Error::model(path, "no actuators: a robot needs its motors as <actuator> elements"));
    }
    Ok(out)
}

/// The mirror of each actuated joint: the joint named as its other side whose axis the geometry confirms, else
/// the joint whose anchor is nearest its reflection (within 1 cm) with a mirrored axis.
fn mirrors(m: &Model, posed: &Posed, joints: &[usize]) -> Vec<Mirror> {
    let names: Vec<&str> = joints.iter().map(|&j| m.name_of(ObjType::Joint, j).unwrap_or("")).collect();
    (0..joints.len())
        .map(|i| {
            let by_name = SIDES.iter().flat_map(|&(l, r)| [(l, r), (r, l)]).find_map(|(from, to)| {
                let other = names[i].contains(from).then(|| names[i].replacen(from, to, 1))?;
                names.iter().position(|n| *n == other)
            });
            if let Some(k) = by_name {
                return match posed.mirror_sign(joints[i], joints[k]) {
                    Some(sign) => Mirror::Found { motor: k, sign },
                    None => Mirror::Choose(format!(
                        "{CHOOSE}: '{}' is named as the mirror of '{}' but their axes are not mirror images",
                        names[k], names[i]
                    )),
                };
            }
            let nearest = (0..joints.len())
                .filter_map(|k| posed.mirror_sign(joints[i], joints[k]).map(|s| (k, s)))
                .map(|(k, s)| (posed.anchor_asymmetry(joints[i], joints[k]), k, s))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            match nearest {
                Some((d, k, sign)) if d < 0.01 => Mirror::Found { motor: k, sign },
                _ => Mirror::Choose(format!("{CHOOSE}: the other side's joint of '{}'", names[i])),
            }
        })
        .collect()
}

/// The foot on each side of the sagittal plane: the collision geom that reaches lowest (left first).
fn feet(m: &Model, d: &Data, base: usize, path: &Path) -> Result<[DraftFoot; 2]> {
    let r = d.xmat()[base];
    let (normal, origin) = ([r[1], r[4], r[7]], d.xpos()[base]);
    let mut best: [Option<(f64, usize, [f64; 3])>; 2] = [None, None];
    for g in 0..m.ngeom() {
        let body = m.geom_bodyid()[g] as usize;
        let collides = m.geom_contype()[g] != 0 || m.geom_conaffinity()[g] != 0;
        if body == 0 || body == base || !collides {
            continue;
        }
        let p = lowest_point(d, g);
        let c = d.geom_xpos()[g];
        let side = if (0..3).map(|k| (c[k] - origin[k]) * normal[k]).sum::<f64>() >= 0.0 { 0 } else { 1 };
        if best[side].is_none_or(|(z, _, _)| p[2] < z) {
            best[side] = Some((p[2], g, p));
        }
    }
    let foot = |side: usize| -> Result<DraftFoot> {
        let Some((_, g, p)) = best[side] else {
            return Err(Error::model(
                path,
                format!(
                    "no collision geom on the {} side: the import finds the feet as each side's lowest collision geom",
                    ["left", "right"][side]
                ),
            ));
        };
        let body = m.geom_bodyid()[g] as usize;
        let body_name = name(m, ObjType::Body, body, path)?;
        let geom_name = m.name_of(ObjType::Geom, g).map(str::to_string);
        Ok(DraftFoot {
            geom: geom_name.clone().unwrap_or_else(|| format!("{body_name}-sole")),
            geom_named: geom_name.is_some(),
            geom_in_body: g - m.body_geomadr()[body] as usize,
            site: format!("{body_name}-sole-site"),
            site_pos: in_body_frame(d, body, p),
            body: body_name,
        })
    };
    Ok([foot(0)?, foot(1)?])
}

/// The joint-deviation groups by axis in the base frame: the first roll and the first yaw joint from the base down
/// each leg, and the last pitch joint (the ankle's).
fn groups(
    m: &Model,
    d: &Data,
    base: usize,
    joints: &[usize],
    chains: &[Vec<usize>],
) -> Vec<(&'static str, Vec<usize>)> {
    let r = d.xmat()[base];
    let axis_kind = |j: usize| {
        let a = d.xaxis()[j];
        let local: [f64; 3] = std::array::from_fn(|k| r[k] * a[0] + r[3 + k] * a[1] + r[6 + k] * a[2]);
        (0..3).max_by(|&x, &y| local[x].abs().total_cmp(&local[y].abs())).unwrap_or(0)
    };
    let mut out: Vec<(&'static str, Vec<usize>)> =
        vec![("hip_roll", vec![]), ("hip_yaw", vec![]), ("ankle_pitch", vec![])];
    for chain in chains {
        // Motors on this leg, base first (a chain lists the foot first).
        let mut leg: Vec<usize> = (0..joints.len())
            .filter(|&i| {
                m.jnt_type(joints[i]) == JointType::Hinge && chain.contains(&(m.jnt_bodyid()[joints[i]] as usize))
            })
            .collect();
        leg.sort_by_key(|&i| std::cmp::Reverse(chain.iter().position(|&b| b == m.jnt_bodyid()[joints[i]] as usize)));
        if let Some(&i) = leg.iter().find(|&&i| axis_kind(joints[i]) == 0) {
            out[0].1.push(i);
        }
        if let Some(&i) = leg.iter().find(|&&i| axis_kind(joints[i]) == 2) {
            out[1].1.push(i);
        }
        let pitches: Vec<usize> = leg.iter().copied().filter(|&i| axis_kind(joints[i]) == 1).collect();
        if pitches.len() > 1 {
            out[2].1.push(pitches[pitches.len() - 1]);
        }
    }
    out.retain(|(_, v)| v.len() == 2);
    out
}

/// The model's loops, those that share a passive joint merged into one (a two-rod ankle is one loop).
fn loops(m: &Model, found: &[mechanism::ClosedLoop], path: &Path) -> Result<Vec<DraftLoop>> {
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, l) in found.iter().enumerate() {
        let shares = |g: &Vec<usize>| g.iter().any(|&k| found[k].passive.iter().any(|p| l.passive.contains(p)));
        match groups.iter_mut().find(|g| shares(g)) {
            Some(g) => g.push(i),
            None => groups.push(vec![i]),
        }
    }
    let joint_names = |js: &mut dyn Iterator<Item = usize>| -> Result<Vec<String>> {
        let mut out: Vec<String> = Vec::new();
        for j in js {
            let n = name(m, ObjType::Joint, j, path)?;
            if !out.contains(&n) {
                out.push(n);
            }
        }
        Ok(out)
    };
    groups
        .into_iter()
        .map(|g| {
            let equality =
                g.iter().map(|&k| name(m, ObjType::Equality, found[k].equality, path)).collect::<Result<Vec<_>>>()?;
            Ok(DraftLoop {
                name: equality[0].clone(),
                passive: joint_names(&mut g.iter().flat_map(|&k| found[k].passive.clone()))?,
                springs: joint_names(&mut g.iter().flat_map(|&k| found[k].springs.clone()))?,
                equality,
            })
        })
        .collect()
}
