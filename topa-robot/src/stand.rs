//! The stand keyframe of a spec and its gravity feed-forward. The keyframe: the spec's nominal pose with every loop
//! closed (the robot's own linkage solver; springs at rest) and the base lowered until the lowest collision geom
//! touches the floor. The feed-forward: the motor torques that hold that pose under the robot's weight, from
//! MuJoCo's inverse dynamics at the settled stand — found by letting the robot settle on its PD loops with the
//! torques found so far (a harness holding only its base's tilt and place, never its weight), taking the torques
//! the settled state needs, and again until the pose stops moving. Whether it also stands with the harness off is
//! reported, not required: balance on line feet is the policy's job.

use std::path::Path;
use std::sync::Arc;

use mujoco::{Data, Model, ObjType};
use topa_env::linkage::Linkage;
use topa_env::mechanism::Posed;
use topa_env::spec::RobotSpec;
use topa_env::RobotIndices;

use crate::error::{Error, Result};
use crate::geometry::lowest_point;

/// Settling time per round, s, and the rounds of the fixed point.
const SETTLE_S: f64 = 1.5;
const ROUNDS: usize = 8;

#[derive(Debug, Clone)]
pub struct StandReport {
    /// How far the base was lowered (negative: raised) to put the robot on the floor, m.
    pub lowered: f64,
    /// The largest passive-joint change that closing the loops made, rad.
    pub closure_change: f64,
    /// Per motor (spec order): its actuator and feed-forward torque, N·m.
    pub feedforward: Vec<(String, f64)>,
    /// The largest kinematic-joint deviation from the nominal pose on PD alone, and with the feed-forward, rad
    /// (base harness on: the tilt it holds is not the motors' job).
    pub sag_without: f64,
    pub sag_with: f64,
    /// Whether the robot also stands without the harness on its PD loops and the feed-forward (a robot on line
    /// feet, such as Cassie, does not: its balance is the policy's).
    pub stands_alone: bool,
}

/// Solves `spec_path`'s stand keyframe (written into its MJCF) and feed-forward (written into the spec).
pub fn stand(spec_path: &Path) -> Result<StandReport> {
    let (spec, model) = RobotSpec::load(spec_path)?;
    let key = model.id(ObjType::Key, &spec.stand_keyframe)?;
    let mut qpos = model.key_qpos(key).to_vec();
    let mut closure_change = 0.0f64;
    if !spec.loops.is_empty() {
        let idx = RobotIndices::resolve(&model, &Arc::new(spec.clone()))?;
        let mut linkage = Linkage::unchecked(&spec, &model)?;
        let closed = linkage.closed_qpos(&idx.nominal_actuated)?;
        closure_change = closed.iter().zip(&qpos).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        qpos = closed;
    }
    let base = model.id(ObjType::Body, &spec.base_body)?;
    let base_q = model.jnt_qposadr_of(model.id(ObjType::Joint, &spec.base_joint)?);
    let posed = Posed::new(&model, &qpos, base)?;
    let d = posed.data();
    let lowest = (0..model.ngeom())
        .filter(|&g| model.geom_bodyid()[g] != 0 && (model.geom_contype()[g] | model.geom_conaffinity()[g]) != 0)
        .map(|g| lowest_point(d, g)[2])
        .fold(f64::INFINITY, f64::min);
    qpos[base_q + 2] -= lowest;
    let mut root = crate::xml::parse(&spec.mjcf)?;
    if !crate::derive::has_keyframe(&root, &spec.stand_keyframe) && crate::derive::has_includes(&root) {
        let numbers: Vec<String> = qpos.iter().map(|x| format!("{x}")).collect();
        return Err(Error::model(
            &spec.mjcf,
            format!(
                "keyframe '{}' is in a file this one includes, which `topa robot stand` does not rewrite: set its \
                 qpos there to {}",
                spec.stand_keyframe,
                numbers.join(" ")
            ),
        ));
    }
    crate::derive::set_keyframe_named(&mut root, &spec.stand_keyframe, &qpos);
    let text = crate::xml::write(&root);
    // Written only once it compiles: a user's model is never replaced by one that does not load.
    Model::from_xml_string(&text, spec.mjcf.parent().unwrap_or(Path::new(".")))?;
    trainer::tensorfile::write_atomic(&spec.mjcf, text.as_bytes())?;

    // The height target is the new keyframe's (what the base-height reward and the video camera scale by).
    write_spec(spec_path, None, Some(qpos[base_q + 2]))?;
    let (spec, model) = RobotSpec::load(spec_path)?;
    let (ff, sag_without, sag_with, stands_alone) = feedforward(&spec, &model)?;
    write_spec(spec_path, Some(&ff), None)?;
    RobotSpec::load(spec_path)?;
    Ok(StandReport {
        lowered: lowest,
        closure_change,
        feedforward: spec.motors.iter().map(|m| m.actuator.clone()).zip(ff).collect(),
        sag_without,
        sag_with,
        stands_alone,
    })
}

/// A base harness: springs on the base's horizontal place, tilt and heading, none on its height. Linear: ω = 20 rad/s
/// on the robot's mass; angular: 20 m·g·h per rad (h the stand height), damped a tenth of that per rad/s. Each dof's
/// gains are capped where an explicit force held over one step would go unstable on that dof's own inertia (a yaw
/// dof has little): k ≤ M·(0.2/dt)², c ≤ M·0.4/dt.
struct Harness {
    dof: usize,
    qpos: usize,
    target: [f64; 2],
    k: [f64; 6],
    c: [f64; 6],
}

impl Harness {
    fn new(d: &mut Data, idx: &RobotIndices) -> Result<Harness> {
        d.reset_keyframe(idx.stand_key)?;
        d.forward()?;
        let m = d.model();
        let (nv, dof, dt) = (m.nv(), idx.base_dof, m.timestep());
        let mass = m.total_mass();
        let weight_height = mass * m.gravity()[2].abs().max(1.0) * idx.spec.base_height_target.max(0.1);
        let inertia = d.full_mass_matrix();
        let wanted_k =
            [400.0 * mass, 400.0 * mass, 0.0, 20.0 * weight_height, 20.0 * weight_height, 20.0 * weight_height];
        let wanted_c = [40.0 * mass, 40.0 * mass, 0.0, 2.0 * weight_height, 2.0 * weight_height, 2.0 * weight_height];
        let own = |k: usize| inertia[(dof + k) * nv + dof + k];
        let q = d.qpos();
        Ok(Harness {
            dof,
            qpos: idx.base_qpos,
            target: [q[idx.base_qpos], q[idx.base_qpos + 1]],
            k: std::array::from_fn(|k| wanted_k[k].min(own(k) * (0.2 / dt).powi(2))),
            c: std::array::from_fn(|k| wanted_c[k].min(own(k) * 0.4 / dt)),
        })
    }

    fn apply(&self, d: &mut Data, on: bool) {
        let q = d.qpos()[self.qpos..self.qpos + 7].to_vec();
        let v = d.qvel()[self.dof..self.dof + 6].to_vec();
        let f = d.qfrc_applied_mut();
        f[self.dof..self.dof + 6].iter_mut().for_each(|x| *x = 0.0);
        if !on {
            return;
        }
        for k in 0..2 {
            f[self.dof + k] = -self.k[k] * (q[k] - self.target[k]) - self.c[k] * v[k];
        }
        // Small-angle tilt and heading from the quaternion (w, x, y, z): 2·(x, y, z)·sign(w).
        let s = if q[3] < 0.0 { -2.0 } else { 2.0 };
        for k in 3..6 {
            f[self.dof + k] = -self.k[k] * s * q[1 + k] - self.c[k] * v[k];
        }
    }
}

/// Settles the robot from the keyframe with motor targets `targets`; the largest kinematic-joint deviation from
/// nominal at the end, or an error if it fell.
fn settle(d: &mut Data, idx: &RobotIndices, targets: &[f64], harness: &Harness, on: bool) -> Result<f64> {
    d.reset_keyframe(idx.stand_key)?;
    let height = d.qpos()[harness.qpos + 2];
    for (i, &t) in targets.iter().enumerate() {
        let [lo, hi] = idx.motor_range[i];
        d.ctrl_mut()[idx.actuators[i]] = t.clamp(lo, hi);
    }
    let steps = (SETTLE_S / d.model().timestep()).ceil() as usize;
    for _ in 0..steps {
        harness.apply(d, on);
        d.step()?;
    }
    let z = d.qpos()[harness.qpos + 2];
    let q = &d.qpos()[harness.qpos + 3..harness.qpos + 7];
    let tilt = 2.0 * (q[1] * q[1] + q[2] * q[2]).sqrt().asin();
    if z < 0.7 * height || tilt > 0.3 || d.is_unstable() {
        return Err(Error::model(
            &idx.spec.path,
            format!(
                "the robot does not stand on its PD loops (base at {z:.3} m of {height:.3} m, tilt {tilt:.2} rad after \
                 {SETTLE_S} s): raise the actuators' kp (gainprm) or check the feet"
            ),
        ));
    }
    Ok(idx.joint_qpos.iter().zip(&idx.nominal_joints).map(|(&a, n)| (d.qpos()[a] - n).abs()).fold(0.0, f64::max))
}

/// The feed-forward torques (mirror-symmetric, 1 mN·m steps), the sag without and with them, and whether the robot
/// stands with them and no harness.
fn feedforward(spec: &RobotSpec, model: &Model) -> Result<(Vec<f64>, f64, f64, bool)> {
    let idx = RobotIndices::resolve(model, &Arc::new(spec.clone()))?;
    let mut d = Data::new(Arc::new(model.try_clone()?))?;
    let n = idx.n_motors;
    let mut kp = Vec::with_capacity(n);
    for i in 0..n {
        let (g, b) = (model.actuator_gainprm()[idx.actuators[i]][0], model.actuator_biasprm()[idx.actuators[i]][1]);
        if g.is_nan() || g <= 0.0 || (b + g).abs() > 1e-9 * g {
            return Err(Error::model(
                &spec.mjcf,
                format!("actuator '{}' is not a PD loop (gainprm kp, biasprm '0 -kp -kd')", spec.motors[i].actuator),
            ));
        }
        kp.push(g);
    }
    let harness = Harness::new(&mut d, &idx)?;
    let sag_without = settle(&mut d, &idx, &idx.nominal_actuated, &harness, true).unwrap_or(f64::INFINITY);
    let mut ff = vec![0.0; n];
    for _ in 0..ROUNDS {
        let targets: Vec<f64> = (0..n).map(|i| idx.nominal_actuated[i] + ff[i] / kp[i]).collect();
        settle(&mut d, &idx, &targets, &harness, true)?;
        d.qvel_mut().iter_mut().for_each(|v| *v = 0.0);
        d.qacc_mut().iter_mut().for_each(|v| *v = 0.0);
        d.inverse()?;
        for i in 0..n {
            ff[i] = d.qfrc_inverse()[idx.actuated_dof[i]];
        }
    }
    // Mirror-symmetric, in 1 mN·m steps (what the spec stores and its loader checks).
    let mut sym = ff.clone();
    for i in 0..n {
        let (k, s) = (idx.mirror_perm[i], idx.mirror_sign[i] as f64);
        if i <= k {
            let v = (0.5 * (ff[i] + s * ff[k]) * 1000.0).round() / 1000.0;
            sym[i] = v;
            sym[k] = s * v;
        }
    }
    let targets: Vec<f64> = (0..n).map(|i| idx.nominal_actuated[i] + sym[i] / kp[i]).collect();
    let sag_with = settle(&mut d, &idx, &targets, &harness, true)?;
    let stands_alone = settle(&mut d, &idx, &targets, &harness, false).is_ok();
    Ok((sym, sag_without, sag_with, stands_alone))
}

/// Writes `ff` as each `[[motors]]`' `feedforward` and `height` as `base_height_target` into the spec file, its
/// comments and layout kept.
fn write_spec(path: &Path, ff: Option<&[f64]>, height: Option<f64>) -> Result<()> {
    let text = std::fs::read_to_string(path).map_err(Error::read(path))?;
    let mut doc: toml_edit::DocumentMut =
        text.parse().map_err(|e: toml_edit::TomlError| Error::malformed(path, "TOML", e))?;
    if let Some(h) = height {
        let old = doc.get("base_height_target").and_then(|v| v.as_value()).map(|v| v.decor().clone());
        doc["base_height_target"] = toml_edit::value(h);
        if let (Some(decor), Some(v)) = (old, doc["base_height_target"].as_value_mut()) {
            *v.decor_mut() = decor;
        }
    }
    if let Some(ff) = ff {
        let motors = doc
            .get_mut("motors")
            .and_then(|m| m.as_array_of_tables_mut())
            .ok_or_else(|| Error::model(path, "no [[motors]] tables to write the feed-forward into"))?;
        for (t, &f) in motors.iter_mut().zip(ff) {
            t.insert("feedforward", toml_edit::value(f));
        }
    }
    trainer::tensorfile::write_atomic(path, doc.to_string().as_bytes())?;
    Ok(())
}
