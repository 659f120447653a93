//! `topa info MODEL.xml`: what a model contains, for people (table) and for scripts (`--json`).

use std::path::Path;

use mujoco::{EqualityType, Model, ObjType, Transmission};
use serde::Serialize;

use crate::error::Result;

#[derive(Debug, Serialize)]
pub struct ModelSummary {
    pub file: String,
    pub model: String,
    pub mujoco_version: String,
    pub nq: usize,
    pub nv: usize,
    pub nu: usize,
    pub na: usize,
    pub neq: usize,
    pub bodies: usize,
    pub joints: usize,
    pub geoms: usize,
    pub sites: usize,
    pub actuators: usize,
    pub sensors: usize,
    pub keyframes: usize,
    pub total_mass_kg: f64,
    pub timestep_s: f64,
    pub integrator: String,
    pub equality: Vec<EqualitySummary>,
    pub joint_list: Vec<JointSummary>,
    pub actuator_list: Vec<ActuatorSummary>,
}

#[derive(Debug, Serialize)]
pub struct EqualitySummary {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: String,
    pub object_kind: String,
    pub obj1: String,
    pub obj2: String,
    pub active: bool,
}

#[derive(Debug, Serialize)]
pub struct JointSummary {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: String,
    pub body: String,
    pub qposadr: usize,
    pub dofadr: usize,
    pub range: Option<[f64; 2]>,
}

#[derive(Debug, Serialize)]
pub struct ActuatorSummary {
    pub name: String,
    /// What the actuator drives: "joint l_knee_pitch", "tendon #2", "site s1".
    pub target: String,
    pub ctrlrange: Option<[f64; 2]>,
    pub forcerange: Option<[f64; 2]>,
}

fn name_or_id(m: &Model, kind: ObjType, id: i32) -> String {
    if id < 0 {
        return "world".into();
    }
    m.name_of(kind, id as usize).map_or_else(|| format!("#{id}"), str::to_string)
}

fn actuator_target(m: &Model, a: usize) -> String {
    let id = m.actuator_trnid()[a][0];
    match m.actuator_trntype(a) {
        Transmission::Joint | Transmission::JointInParent => format!("joint {}", name_or_id(m, ObjType::Joint, id)),
        Transmission::SliderCrank => format!("slider-crank site {}", name_or_id(m, ObjType::Site, id)),
        Transmission::Site => format!("site {}", name_or_id(m, ObjType::Site, id)),
        Transmission::Tendon => format!("tendon #{id}"),
    }
}

pub fn summarize(path: &Path) -> Result<ModelSummary> {
    let m = Model::from_xml_path(path)?;
    let equality = (0..m.neq())
        .map(|i| {
            let t = m.eq_type(i);
            // Which kind of object an equality ties depends on its type.
            let obj_kind = match t {
                EqualityType::Joint => Some(ObjType::Joint),
                EqualityType::Connect | EqualityType::Weld => Some(ObjType::Body),
                EqualityType::Distance => Some(ObjType::Geom),
                EqualityType::Tendon => None,
            };
            let show = |id: i32| match obj_kind {
                Some(k) => name_or_id(&m, k, id),
                None => format!("tendon #{id}"),
            };
            EqualitySummary {
                name: m.name_of(ObjType::Equality, i).unwrap_or("").to_string(),
                kind: t.to_string(),
                object_kind: obj_kind.map_or("tendon".into(), |k| k.to_string()),
                obj1: show(m.eq_obj1id()[i]),
                obj2: show(m.eq_obj2id()[i]),
                active: m.eq_active()[i] != 0,
            }
        })
        .collect();
    let joint_list = (0..m.njnt())
        .map(|j| JointSummary {
            name: name_or_id(&m, ObjType::Joint, j as i32),
            kind: m.jnt_type(j).to_string(),
            body: name_or_id(&m, ObjType::Body, m.jnt_bodyid()[j]),
            qposadr: m.jnt_qposadr_of(j),
            dofadr: m.jnt_dofadr_of(j),
            range: (m.jnt_limited()[j] != 0).then(|| m.jnt_range()[j]),
        })
        .collect();
    let actuator_list = (0..m.nu())
        .map(|a| ActuatorSummary {
            name: name_or_id(&m, ObjType::Actuator, a as i32),
            target: actuator_target(&m, a),
            ctrlrange: (m.actuator_ctrllimited()[a] != 0).then(|| m.actuator_ctrlrange()[a]),
            forcerange: (m.actuator_forcelimited()[a] != 0).then(|| m.actuator_forcerange()[a]),
        })
        .collect();
    Ok(ModelSummary {
        file: path.display().to_string(),
        model: m.name().to_string(),
        mujoco_version: mujoco::version_string(),
        nq: m.nq(),
        nv: m.nv(),
        nu: m.nu(),
        na: m.na(),
        neq: m.neq(),
        bodies: m.nbody(),
        joints: m.njnt(),
        geoms: m.ngeom(),
        sites: m.nsite(),
        actuators: m.nu(),
        sensors: m.nsensor(),
        keyframes: m.nkey(),
        total_mass_kg: m.total_mass(),
        timestep_s: m.timestep(),
        integrator: m.integrator().name().to_string(),
        equality,
        joint_list,
        actuator_list,
    })
}

fn range(r: Option<[f64; 2]>) -> String {
    r.map_or("-".into(), |[lo, hi]| format!("[{lo:.3}, {hi:.3}]"))
}

pub fn print_text(s: &ModelSummary) {
    println!("model       {} ({}), MuJoCo {}", s.model, s.file, s.mujoco_version);
    println!("sizes       nq={} nv={} nu={} na={} neq={}", s.nq, s.nv, s.nu, s.na, s.neq);
    println!(
        "objects     {} bodies, {} joints, {} geoms, {} sites, {} actuators, {} sensors, {} keyframes",
        s.bodies, s.joints, s.geoms, s.sites, s.actuators, s.sensors, s.keyframes
    );
    println!("total mass  {:.3} kg", s.total_mass_kg);
    println!("timestep    {} s, integrator {}", s.timestep_s, s.integrator);
    if s.equality.is_empty() {
        println!("equality    none");
    }
    for e in &s.equality {
        let state = if e.active { "" } else { " (inactive)" };
        println!("equality    {:<20} {:<8} {} {} — {}{state}", e.name, e.kind, e.object_kind, e.obj1, e.obj2);
    }
    for j in &s.joint_list {
        println!(
            "joint       {:<20} {:<6} body {:<18} qpos@{:<3} dof@{:<3} range {}",
            j.name,
            j.kind,
            j.body,
            j.qposadr,
            j.dofadr,
            range(j.range)
        );
    }
    for a in &s.actuator_list {
        println!(
            "actuator    {:<20} {:<24} ctrl {} force {}",
            a.name,
            a.target,
            range(a.ctrlrange),
            range(a.forcerange)
        );
    }
}

/// Prints a summary as pretty JSON (for scripts) or with its text printer (for people).
pub fn show<T: Serialize>(summary: &T, json: bool, text: impl Fn(&T)) -> Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(summary)?);
    } else {
        text(summary);
    }
    Ok(())
}

pub fn run(path: &Path, json: bool) -> Result<()> {
    show(&summarize(path)?, json, print_text)
}
