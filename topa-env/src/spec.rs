//! A legged robot as data: a TOML spec beside its MJCF names the actuated degrees of freedom (actuator, the joint
//! it drives, the kinematic joint, nominal angle, limits, peak torque, left↔right mirror), the base, IMU, feet,
//! body-height target, reward-term joint groups and closed kinematic loops. `RobotSpec::load` parses it and
//! checks it against the compiled MJCF; every problem is one error naming the spec's line and the fix.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use mujoco::{JointType, Model, ObjType, Transmission};
use serde::Deserialize;
use toml::Spanned;

/// Limits read back from the compiled model are compared with this tolerance (MJCF numbers parse as doubles).
const TOL: f64 = 1e-9;

#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    #[error("robot spec {path}: {message}")]
    Read { path: String, message: String },
    #[error("{path}:{line}: {message}")]
    At { path: String, line: usize, message: String },
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Raw {
    name: String,
    mjcf: Spanned<String>,
    base_body: Spanned<String>,
    base_joint: Spanned<String>,
    floor_geom: Spanned<String>,
    imu_site: Spanned<String>,
    imu_accelerometer: Spanned<String>,
    stand_keyframe: Spanned<String>,
    base_height_target: f64,
    feet: Spanned<Vec<RawFoot>>,
    motors: Spanned<Vec<RawMotor>>,
    #[serde(default)]
    groups: BTreeMap<String, Spanned<Vec<String>>>,
    #[serde(default)]
    loops: Vec<RawLoop>,
    #[serde(default)]
    approximates: Option<Spanned<String>>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFoot {
    body: Spanned<String>,
    geom: Spanned<String>,
    site: Spanned<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMotor {
    actuator: Spanned<String>,
    drives: Spanned<String>,
    joint: Spanned<String>,
    nominal: Spanned<f64>,
    motor_range: Spanned<[f64; 2]>,
    joint_range: Spanned<[f64; 2]>,
    torque_limit: Spanned<f64>,
    mirror: Spanned<String>,
    mirror_sign: Spanned<f64>,
    #[serde(default)]
    feedforward: Option<Spanned<f64>>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLoop {
    name: Spanned<String>,
    equality: Spanned<Vec<String>>,
    passive: Spanned<Vec<String>>,
    #[serde(default)]
    springs: Option<Spanned<Vec<String>>>,
}

/// One foot: its body, the geom that touches the ground, the site at the sole's centre.
#[derive(Debug, Clone, PartialEq)]
pub struct Foot {
    pub body: String,
    pub geom: String,
    pub site: String,
}

/// One actuated degree of freedom, in actuator order.
#[derive(Debug, Clone, PartialEq)]
pub struct Motor {
    /// The actuator (its index in the MJCF is its place in the spec).
    pub actuator: String,
    /// The joint the actuator drives (a motor joint inside a linkage, or the kinematic joint itself).
    pub drives: String,
    /// The kinematic joint of this degree of freedom (what rewards, limits and the nominal pose are about).
    pub joint: String,
    /// Kinematic-joint angle in the stand pose, rad.
    pub nominal: f64,
    /// Range of the driven joint (= the actuator's control range), and of the kinematic joint, rad.
    pub motor_range: [f64; 2],
    pub joint_range: [f64; 2],
    /// Peak torque of the motor (= the actuator's force range), N·m.
    pub torque_limit: f64,
    /// The mirrored degree of freedom (index into `motors`) and the sign the mirror puts on the motor's position
    /// (its driven joint's angle: a pitch-axis crank keeps its sign even where its kinematic joint is a roll).
    pub mirror: usize,
    pub mirror_sign: f64,
    /// Torque the motor adds in the stand pose, N·m (gravity compensation from inverse dynamics; 0 for none):
    /// the action's zero is the PD target that produces it at the nominal pose.
    pub feedforward: f64,
}

/// A closed kinematic loop: the equality constraints that close it, its passive joints (the ones the motors
/// position through the linkage) and its springs (compliant joints, such as Cassie's shin and heel leaf springs,
/// which the linkage holds at their rest angle and the simulation lets flex).
#[derive(Debug, Clone, PartialEq)]
pub struct Loop {
    pub name: String,
    pub equality: Vec<String>,
    pub passive: Vec<String>,
    pub springs: Vec<String>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct RobotSpec {
    pub name: String,
    /// The spec file and its MJCF (resolved relative to the spec).
    pub path: PathBuf,
    pub mjcf: PathBuf,
    pub base_body: String,
    pub base_joint: String,
    pub floor_geom: String,
    pub imu_site: String,
    pub imu_accelerometer: String,
    pub stand_keyframe: String,
    pub base_height_target: f64,
    /// Left foot, then right foot.
    pub feet: [Foot; 2],
    pub motors: Vec<Motor>,
    /// Reward-term joint groups: group name → indices into `motors` (their kinematic joints).
    pub groups: BTreeMap<String, Vec<usize>>,
    pub loops: Vec<Loop>,
    /// For a simplified model (TopA's serial chain): the spec of the real robot it stands in for, which
    /// policies trained on it are evaluated on. Its motors drive the real robot's kinematic joints.
    pub approximates: Option<PathBuf>,
}

/// Where a spec's values came from, to point errors at lines.
struct Source<'a> {
    path: String,
    text: &'a str,
}

impl Source<'_> {
    fn at(&self, span: Range<usize>, message: impl Into<String>) -> SpecError {
        let line = self.text[..span.start.min(self.text.len())].matches('\n').count() + 1;
        SpecError::At { path: self.path.clone(), line, message: message.into() }
    }
}

impl RobotSpec {
    /// Reads `path`, compiles the MJCF it names and checks the one against the other.
    pub fn load(path: &Path) -> Result<(RobotSpec, Model), SpecError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SpecError::Read {
            path: p.clone(),
            message: format!("{e} (robot specs live beside their MJCF, e.g. assets/robots/topa_closed.toml)"),
        })?;
        let src = Source { path: p.clone(), text: &text };
        let raw: Raw = toml::from_str(&text).map_err(|e| {
            let span = e.span().unwrap_or(0..0);
            src.at(span, e.message().to_string())
        })?;
        let mjcf = path.parent().unwrap_or(Path::new(".")).join(raw.mjcf.get_ref());
        let model = Model::from_xml_path(&mjcf)
            .map_err(|e| src.at(raw.mjcf.span(), format!("mjcf '{}' does not compile: {e}", raw.mjcf.get_ref())))?;
        let spec = resolve(&raw, &src, path, mjcf)?;
        check_against(&spec, &raw, &src, &model)?;
        if let (Some(a), Some(at)) = (&spec.approximates, &raw.approximates) {
            if !a.exists() {
                return Err(src.at(at.span(), format!("approximates '{}': no such spec beside this one", at.get_ref())));
            }
        }
        Ok((spec, model))
    }

    pub fn n_motors(&self) -> usize {
        self.motors.len()
    }

    /// Indices of the motors of a reward group (empty if the spec has no such group).
    pub fn group(&self, name: &str) -> &[usize] {
        self.groups.get(name).map_or(&[], Vec::as_slice)
    }

    /// The mirror as a signed permutation of motor-indexed vectors: `out[i] = sign[i] · in[perm[i]]`.
    pub fn mirror_map(&self) -> (Vec<usize>, Vec<f32>) {
        (self.motors.iter().map(|m| m.mirror).collect(), self.motors.iter().map(|m| m.mirror_sign as f32).collect())
    }

    /// Nominal kinematic-joint angles (the stand pose).
    pub fn nominal_joints(&self) -> Vec<f64> {
        self.motors.iter().map(|m| m.nominal).collect()
    }
}

/// Names → indices, the mirror and groups checked for consistency (no MJCF needed yet).
fn resolve(raw: &Raw, src: &Source, path: &Path, mjcf: PathBuf) -> Result<RobotSpec, SpecError> {
    let feet = raw.feet.get_ref();
    if feet.len() != 2 {
        return Err(
            src.at(raw.feet.span(), format!("a biped has 2 feet (left, then right); the spec lists {}", feet.len()))
        );
    }
    let motors_raw = raw.motors.get_ref();
    if motors_raw.is_empty() {
        return Err(src.at(raw.motors.span(), "no [[motors]]: list the actuated degrees of freedom in actuator order"));
    }
    let index_of = |name: &str| motors_raw.iter().position(|m| m.joint.get_ref() == name);
    let mut motors = Vec::new();
    for m in motors_raw {
        let Some(mirror) = index_of(m.mirror.get_ref()) else {
            return Err(src.at(
                m.mirror.span(),
                format!("mirror '{}' is not the joint of any motor: name the other leg's joint", m.mirror.get_ref()),
            ));
        };
        let s = *m.mirror_sign.get_ref();
        if s != 1.0 && s != -1.0 {
            return Err(src.at(m.mirror_sign.span(), format!("mirror_sign must be 1 or -1, not {s}")));
        }
        for (name, r) in [("motor_range", &m.motor_range), ("joint_range", &m.joint_range)] {
            let [lo, hi] = *r.get_ref();
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(src.at(r.span(), format!("{name} [{lo}, {hi}] must be finite with low < high")));
            }
        }
        let [lo, hi] = *m.joint_range.get_ref();
        if !(lo..=hi).contains(m.nominal.get_ref()) {
            return Err(src
                .at(m.nominal.span(), format!("nominal {} is outside joint_range [{lo}, {hi}]", m.nominal.get_ref())));
        }
        let t = *m.torque_limit.get_ref();
        if !(t.is_finite() && t > 0.0) {
            return Err(src.at(m.torque_limit.span(), "torque_limit must be positive (N·m)"));
        }
        motors.push(Motor {
            actuator: m.actuator.get_ref().clone(),
            drives: m.drives.get_ref().clone(),
            joint: m.joint.get_ref().clone(),
            nominal: *m.nominal.get_ref(),
            motor_range: *m.motor_range.get_ref(),
            joint_range: *m.joint_range.get_ref(),
            torque_limit: *m.torque_limit.get_ref(),
            mirror,
            mirror_sign: s,
            feedforward: m.feedforward.as_ref().map_or(0.0, |f| *f.get_ref()),
        });
    }
    for (i, m) in motors.iter().enumerate() {
        let back = &motors[m.mirror];
        let at = motors_raw[i].mirror.span();
        if back.mirror != i || back.mirror_sign != m.mirror_sign {
            return Err(src.at(
                at,
                format!(
                    "the mirror must be an involution: '{}' mirrors to '{}' (sign {}), which mirrors to '{}' (sign {})",
                    m.joint, back.joint, m.mirror_sign, motors[back.mirror].joint, back.mirror_sign
                ),
            ));
        }
    }
    let mut groups = BTreeMap::new();
    for (g, names) in &raw.groups {
        let idx: Result<Vec<usize>, SpecError> = names
            .get_ref()
            .iter()
            .map(|n| {
                index_of(n)
                    .ok_or_else(|| src.at(names.span(), format!("group '{g}': '{n}' is not the joint of any motor")))
            })
            .collect();
        groups.insert(g.clone(), idx?);
    }
    let loops = raw
        .loops
        .iter()
        .map(|l| Loop {
            name: l.name.get_ref().clone(),
            equality: l.equality.get_ref().clone(),
            passive: l.passive.get_ref().clone(),
            springs: l.springs.as_ref().map_or_else(Vec::new, |s| s.get_ref().clone()),
        })
        .collect();
    let foot = |f: &RawFoot| Foot {
        body: f.body.get_ref().clone(),
        geom: f.geom.get_ref().clone(),
        site: f.site.get_ref().clone(),
    };
    Ok(RobotSpec {
        name: raw.name.clone(),
        path: path.to_path_buf(),
        mjcf,
        base_body: raw.base_body.get_ref().clone(),
        base_joint: raw.base_joint.get_ref().clone(),
        floor_geom: raw.floor_geom.get_ref().clone(),
        imu_site: raw.imu_site.get_ref().clone(),
        imu_accelerometer: raw.imu_accelerometer.get_ref().clone(),
        stand_keyframe: raw.stand_keyframe.get_ref().clone(),
        base_height_target: raw.base_height_target,
        feet: [foot(&feet[0]), foot(&feet[1])],
        motors,
        groups,
        loops,
        approximates: raw.approximates.as_ref().map(|a| path.parent().unwrap_or(Path::new(".")).join(a.get_ref())),
    })
}

fn close(a: [f64; 2], b: [f64; 2]) -> bool {
    (a[0] - b[0]).abs() < TOL && (a[1] - b[1]).abs() < TOL
}

/// One list of a found loop's joints (its passive joints, or its springs).
type LoopJoints = fn(&crate::mechanism::ClosedLoop) -> &[usize];

/// Every name exists in the model with the right kind, actuators in spec order drive the named joints, limits and
/// the stand keyframe agree with the spec, and each loop's passive joints are hinges not driven by an actuator.
fn check_against(spec: &RobotSpec, raw: &Raw, src: &Source, m: &Model) -> Result<(), SpecError> {
    let mjcf = raw.mjcf.get_ref();
    let find = |kind: ObjType, name: &Spanned<String>, what: &str| -> Result<usize, SpecError> {
        m.id(kind, name.get_ref()).map_err(|_| {
            let have = m.names(kind);
            let shown = if have.len() > 12 { format!("{}, …", have[..12].join(", ")) } else { have.join(", ") };
            src.at(name.span(), format!("{what} '{}' is not in {mjcf} (its {what}s: {shown})", name.get_ref()))
        })
    };
    find(ObjType::Body, &raw.base_body, "body")?;
    let base = find(ObjType::Joint, &raw.base_joint, "joint")?;
    if m.jnt_type(base) != JointType::Free {
        return Err(src.at(raw.base_joint.span(), format!("base_joint '{}' must be a free joint", spec.base_joint)));
    }
    find(ObjType::Geom, &raw.floor_geom, "geom")?;
    find(ObjType::Site, &raw.imu_site, "site")?;
    find(ObjType::Sensor, &raw.imu_accelerometer, "sensor")?;
    let key = find(ObjType::Key, &raw.stand_keyframe, "keyframe")?;
    for f in raw.feet.get_ref() {
        find(ObjType::Body, &f.body, "body")?;
        find(ObjType::Geom, &f.geom, "geom")?;
        find(ObjType::Site, &f.site, "site")?;
    }
    if m.nu() != spec.n_motors() {
        return Err(src.at(
            raw.motors.span(),
            format!(
                "{mjcf} has {} actuators and the spec lists {} motors: one [[motors]] per actuator, in order",
                m.nu(),
                spec.n_motors()
            ),
        ));
    }
    let key_qpos = m.key_qpos(key);
    for (i, (mm, r)) in spec.motors.iter().zip(raw.motors.get_ref()).enumerate() {
        let a = find(ObjType::Actuator, &r.actuator, "actuator")?;
        if a != i {
            return Err(src.at(
                r.actuator.span(),
                format!(
                    "actuator '{}' is #{a} in {mjcf} but motor #{i} in the spec: list the motors in actuator order",
                    mm.actuator
                ),
            ));
        }
        let driven = find(ObjType::Joint, &r.drives, "joint")?;
        let joint = find(ObjType::Joint, &r.joint, "joint")?;
        if m.actuator_trntype(a) != Transmission::Joint || m.actuator_trnid()[a][0] != driven as i32 {
            let got = m.name_of(ObjType::Joint, m.actuator_trnid()[a][0].max(0) as usize).unwrap_or("?");
            return Err(src
                .at(r.drives.span(), format!("actuator '{}' drives joint '{got}', not '{}'", mm.actuator, mm.drives)));
        }
        if m.actuator_ctrllimited()[a] == 0 || !close(m.actuator_ctrlrange()[a], mm.motor_range) {
            return Err(src.at(
                r.motor_range.span(),
                format!(
                    "actuator '{}' has ctrlrange {:?} in {mjcf}, the spec says {:?}",
                    mm.actuator,
                    m.actuator_ctrlrange()[a],
                    mm.motor_range
                ),
            ));
        }
        let t = mm.torque_limit;
        if m.actuator_forcelimited()[a] == 0 || !close(m.actuator_forcerange()[a], [-t, t]) {
            return Err(src.at(
                r.torque_limit.span(),
                format!(
                    "actuator '{}' has forcerange {:?} in {mjcf}, the spec says ±{t}",
                    mm.actuator,
                    m.actuator_forcerange()[a]
                ),
            ));
        }
        for (j, want, span) in
            [(driven, mm.motor_range, r.motor_range.span()), (joint, mm.joint_range, r.joint_range.span())]
        {
            if m.jnt_limited()[j] == 0 || !close(m.jnt_range()[j], want) {
                let name = m.name_of(ObjType::Joint, j).unwrap_or("?");
                return Err(src.at(
                    span,
                    format!("joint '{name}' has range {:?} in {mjcf}, the spec says {want:?}", m.jnt_range()[j]),
                ));
            }
        }
        let mirrored = &spec.motors[mm.mirror];
        let (q_m, q_mirror) = (
            key_qpos[m.jnt_qposadr_of(driven)],
            key_qpos[m.jnt_qposadr_of(m.id(ObjType::Joint, &mirrored.drives).unwrap_or(driven))],
        );
        if (q_m - mm.mirror_sign * q_mirror).abs() > 1e-9 {
            return Err(src.at(
                r.mirror_sign.span(),
                format!(
                    "the stand pose must be symmetric: keyframe '{}' puts '{}' at {q_m} and its mirror '{}' at {q_mirror} (sign {})",
                    spec.stand_keyframe, mm.drives, mirrored.drives, mm.mirror_sign
                ),
            ));
        }
        let q = key_qpos[m.jnt_qposadr_of(joint)];
        if (q - mm.nominal).abs() > 1e-6 {
            return Err(src.at(
                r.nominal.span(),
                format!(
                    "keyframe '{}' puts joint '{}' at {q}, the spec's nominal is {}",
                    spec.stand_keyframe, mm.joint, mm.nominal
                ),
            ));
        }
    }
    check_mirror_geometry(spec, raw, src, m, key)?;
    check_feedforward(spec, raw, src, m)?;
    let driven: Vec<usize> = (0..m.nu()).map(|a| m.actuator_trnid()[a][0] as usize).collect();
    let found = crate::mechanism::loops(m);
    for l in &raw.loops {
        for e in l.equality.get_ref() {
            m.id(ObjType::Equality, e).map_err(|_| {
                src.at(l.equality.span(), format!("loop '{}': equality '{e}' is not in {mjcf}", l.name.get_ref()))
            })?;
        }
        for p in l.passive.get_ref() {
            let j = m.id(ObjType::Joint, p).map_err(|_| {
                src.at(l.passive.span(), format!("loop '{}': joint '{p}' is not in {mjcf}", l.name.get_ref()))
            })?;
            if driven.contains(&j) {
                return Err(src.at(
                    l.passive.span(),
                    format!("loop '{}': '{p}' is driven by an actuator, so it is not passive", l.name.get_ref()),
                ));
            }
            if !matches!(m.jnt_type(j), JointType::Hinge | JointType::Slide | JointType::Ball) {
                return Err(src.at(
                    l.passive.span(),
                    format!(
                        "loop '{}': passive joint '{p}' must be a hinge, a slide or a ball joint",
                        l.name.get_ref()
                    ),
                ));
            }
        }
        let mut listed: Vec<usize> = l.passive.get_ref().iter().filter_map(|p| m.id(ObjType::Joint, p).ok()).collect();
        if let Some(springs) = &l.springs {
            for p in springs.get_ref() {
                let j = m.id(ObjType::Joint, p).map_err(|_| {
                    src.at(springs.span(), format!("loop '{}': joint '{p}' is not in {mjcf}", l.name.get_ref()))
                })?;
                if m.jnt_stiffness()[j] <= 0.0 || driven.contains(&j) || listed.contains(&j) {
                    return Err(src.at(
                        springs.span(),
                        format!(
                            "loop '{}': spring '{p}' must be a joint with a stiffness in {mjcf}, no actuator's and \
                             not also passive",
                            l.name.get_ref()
                        ),
                    ));
                }
                listed.push(j);
            }
        }
        // Every joint the loop moves through that no actuator drives must be passive or a spring: one left out
        // gives a loop the solver cannot close as the motors move (a wrong J, where nothing checked it).
        let eqs: Vec<usize> = l.equality.get_ref().iter().filter_map(|e| m.id(ObjType::Equality, e).ok()).collect();
        let in_loop = |f: &&crate::mechanism::ClosedLoop| eqs.contains(&f.equality);
        let kinds: [(&str, &str, LoopJoints); 2] = [
            ("passive", "no actuator drives", |f| &f.passive),
            ("springs", "a spring (stiffness) moves", |f| &f.springs),
        ];
        for (kind, what, joints) in kinds {
            let missing: Vec<&str> = found
                .iter()
                .filter(in_loop)
                .flat_map(|f| joints(f).iter().copied())
                .filter(|j| !listed.contains(j))
                .map(|j| m.name_of(ObjType::Joint, j).unwrap_or("(unnamed)"))
                .collect();
            if !missing.is_empty() {
                return Err(src.at(
                    l.passive.span(),
                    format!(
                        "loop '{}': it also moves through {}, which {what}: add {} to its {kind} list",
                        l.name.get_ref(),
                        missing.join(", "),
                        if missing.len() == 1 { "it" } else { "them" }
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Each motor's mirror sign agrees with the geometry of the stand pose: the mirrored motor's joint axis is this
/// one's reflected through the base's sagittal plane (sign +1) or its reverse (−1).
fn check_mirror_geometry(spec: &RobotSpec, raw: &Raw, src: &Source, m: &Model, key: usize) -> Result<(), SpecError> {
    let at_key = |e: mujoco::MujocoError| src.at(raw.stand_keyframe.span(), format!("posing the stand keyframe: {e}"));
    let base = m.id(ObjType::Body, &spec.base_body).map_err(at_key)?;
    let posed = crate::mechanism::Posed::new(m, m.key_qpos(key), base).map_err(at_key)?;
    for (mm, r) in spec.motors.iter().zip(raw.motors.get_ref()) {
        let other = &spec.motors[mm.mirror];
        let (Ok(a), Ok(b)) = (m.id(ObjType::Joint, &mm.drives), m.id(ObjType::Joint, &other.drives)) else {
            continue;
        };
        match posed.mirror_sign(a, b) {
            Some(s) if s == mm.mirror_sign => {}
            Some(s) => {
                return Err(src.at(
                    r.mirror_sign.span(),
                    format!(
                        "mirror_sign {} disagrees with the geometry: in keyframe '{}' the axis of '{}' is that of \
                         '{}' mirrored{}, so the sign is {s}",
                        mm.mirror_sign,
                        spec.stand_keyframe,
                        other.drives,
                        mm.drives,
                        if s < 0.0 { " and reversed" } else { "" }
                    ),
                ))
            }
            None => {
                return Err(src.at(
                    r.mirror.span(),
                    format!(
                        "'{}' and '{}' are not a mirror pair: in keyframe '{}' their axes are not mirror images \
                         through the sagittal plane of '{}'",
                        mm.drives, other.drives, spec.stand_keyframe, spec.base_body
                    ),
                ))
            }
        }
    }
    Ok(())
}

/// A feed-forward torque becomes a PD target offset, so its actuator must be a PD one (gain kp > 0 and bias
/// −kp·q); mirrored motors carry mirrored torques.
fn check_feedforward(spec: &RobotSpec, raw: &Raw, src: &Source, m: &Model) -> Result<(), SpecError> {
    for (i, (mm, r)) in spec.motors.iter().zip(raw.motors.get_ref()).enumerate() {
        let Some(ff) = &r.feedforward else { continue };
        let (kp, bias) = (m.actuator_gainprm()[i][0], m.actuator_biasprm()[i][1]);
        if !mm.feedforward.is_finite() || kp.is_nan() || kp <= 0.0 || (bias + kp).abs() > TOL * kp.max(1.0) {
            return Err(src.at(
                ff.span(),
                format!(
                    "feedforward needs a finite torque on a PD actuator (gainprm kp > 0, biasprm '0 -kp -kd'): '{}' \
                     has kp {kp} and bias {bias}",
                    mm.actuator
                ),
            ));
        }
        let other = &spec.motors[mm.mirror];
        if (mm.feedforward - mm.mirror_sign * other.feedforward).abs() > 1e-6 * mm.feedforward.abs().max(1.0) {
            return Err(src.at(
                ff.span(),
                format!(
                    "feedforward {} of '{}' is not the mirror of '{}''s {} (sign {}): solve both with `topa robot \
                     stand`",
                    mm.feedforward, mm.actuator, other.actuator, other.feedforward, mm.mirror_sign
                ),
            ));
        }
    }
    Ok(())
}
