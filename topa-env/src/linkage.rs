//! Motor↔joint maps of a robot with closed kinematic loops, computed from its MJCF's own constraints instead of
//! typed in: positions by solving the loop closure (Gauss–Newton on the loops' passive joints), velocities by the
//! closure's Jacobian J = ∂q_joint/∂q_motor, torques by virtual work, τ_motor = Jᵀ τ_joint. Nonlinear linkages
//! (four-bar knees, two-rod ankles) work the same as TopA's linear one; a loop's passive joints may be hinges,
//! slides or ball joints (Cassie's achilles rods); its springs stay at their keyframe (rest) angle. A passive set that cannot follow the motors (a joint of the loop
//! left out) is an error naming the loop and the joints it also moves through, never a least-squares J.

use std::sync::Arc;

use mujoco::{ConstraintType, Data, JointType, Model, ObjType};
use nalgebra::{DMatrix, DVector};

use crate::error::{EnvError, Result};
use crate::indices::RobotIndices;
use crate::spec::RobotSpec;

/// Loop closure is solved to this residual (m for a connect, rad for a joint equality).
const CLOSURE_TOL: f64 = 1e-12;
const MAX_ITERATIONS: usize = 60;
/// The largest motor move between loop closures when solving far from the stand pose, rad.
const CONTINUATION_STEP: f64 = 0.1;
/// The closure's velocity equation must hold to this (per unit motor velocity) for J to be the linkage's.
const JACOBIAN_TOL: f64 = 1e-8;

pub struct Linkage {
    data: Data,
    key: usize,
    /// qpos address and dof of each motor's driven joint, and of its kinematic joint.
    motor_qpos: Vec<usize>,
    motor_dof: Vec<usize>,
    joint_qpos: Vec<usize>,
    /// Passive joints of all loops, and their dofs in that order (a ball joint has three).
    passive: Vec<Passive>,
    passive_dof: Vec<usize>,
    /// Dofs of the loops' springs: held at the keyframe's angle (their rest), not solved for.
    spring_dof: Vec<usize>,
    /// For each motor, the passive dof that is its kinematic joint (None: the motor drives it directly).
    joint_is_passive: Vec<Option<usize>>,
    equalities: Vec<usize>,
    /// Each loop's name and its equality constraints (for errors).
    loop_names: Vec<(String, Vec<usize>)>,
    spec_path: String,
    nominal_motors: Vec<f64>,
}

/// A passive joint: its first qpos address and first dof; a ball joint's qpos is a unit quaternion, its three
/// dofs an angular velocity in the child frame.
#[derive(Debug, Clone, Copy)]
struct Passive {
    qpos: usize,
    dof: usize,
    ball: bool,
}

impl Passive {
    fn nq(self) -> usize {
        if self.ball {
            4
        } else {
            1
        }
    }
    fn nv(self) -> usize {
        if self.ball {
            3
        } else {
            1
        }
    }
}

/// `q` ⊗ exp(ω/2) for a unit quaternion `q` (w, x, y, z) and a rotation vector ω in the child frame: MuJoCo's
/// integration of a ball joint's position, renormalised.
fn rotate_local(q: &mut [f64], omega: [f64; 3]) {
    let angle = (omega[0] * omega[0] + omega[1] * omega[1] + omega[2] * omega[2]).sqrt();
    if angle < 1e-300 {
        return;
    }
    let (s, c) = ((angle / 2.0).sin() / angle, (angle / 2.0).cos());
    let d = [c, s * omega[0], s * omega[1], s * omega[2]];
    let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
    let r = [
        w * d[0] - x * d[1] - y * d[2] - z * d[3],
        w * d[1] + x * d[0] + y * d[3] - z * d[2],
        w * d[2] - x * d[3] + y * d[0] + z * d[1],
        w * d[3] + x * d[2] - y * d[1] + z * d[0],
    ];
    let n = r.iter().map(|v| v * v).sum::<f64>().sqrt();
    for (o, v) in q.iter_mut().zip(r) {
        *o = v / n;
    }
}

impl Linkage {
    /// The maps of `spec` on `model` (its own copy, with a dense constraint Jacobian); its stand keyframe must
    /// close the loops.
    pub fn new(spec: &RobotSpec, model: &Model) -> Result<Self> {
        let mut linkage = Linkage::unchecked(spec, model)?;
        let key_qpos = model.key_qpos(linkage.key).to_vec();
        linkage.check_keyframe(spec, &key_qpos)?;
        Ok(linkage)
    }

    /// The maps of a spec whose stand keyframe need not close the loops yet (what solves that keyframe).
    pub fn unchecked(spec: &RobotSpec, model: &Model) -> Result<Self> {
        let mut m = model.try_clone()?;
        m.set_dense_jacobian();
        let m = Arc::new(m);
        // The addresses the env uses (actuated and kinematic joints, loops, stand keyframe), on this copy.
        let idx = RobotIndices::resolve(&m, &Arc::new(spec.clone()))?;
        let (motor_qpos, motor_dof, joint_qpos) = (idx.actuated_qpos, idx.actuated_dof, idx.joint_qpos);
        let mut passive = vec![];
        for p in spec.loops.iter().flat_map(|l| &l.passive) {
            let j = m.id(ObjType::Joint, p)?;
            let ball = m.jnt_type(j) == JointType::Ball;
            passive.push(Passive { qpos: m.jnt_qposadr_of(j), dof: m.jnt_dofadr_of(j), ball });
        }
        let passive_dof: Vec<usize> = passive.iter().flat_map(|p| p.dof..p.dof + p.nv()).collect();
        let spring_dof = spec
            .loops
            .iter()
            .flat_map(|l| &l.springs)
            .map(|p| Ok(m.jnt_dofadr_of(m.id(ObjType::Joint, p)?)))
            .collect::<Result<Vec<usize>>>()?;
        let joint_is_passive = (0..spec.motors.len())
            .map(|i| {
                if motor_qpos[i] == joint_qpos[i] {
                    None
                } else {
                    let p = passive.iter().find(|p| !p.ball && p.qpos == joint_qpos[i])?;
                    passive_dof.iter().position(|&d| d == p.dof)
                }
            })
            .collect::<Vec<_>>();
        for (i, p) in joint_is_passive.iter().enumerate() {
            if p.is_none() && motor_qpos[i] != joint_qpos[i] {
                return Err(EnvError::Config(format!(
                    "{}: motor '{}' drives '{}' but its joint '{}' is in no loop: add it to a [[loops]] passive list",
                    spec.path.display(),
                    spec.motors[i].actuator,
                    spec.motors[i].drives,
                    spec.motors[i].joint
                )));
            }
        }
        let key = idx.stand_key;
        let equality = |name: &String| m.id(ObjType::Equality, name);
        let loop_names = spec
            .loops
            .iter()
            .map(|l| Ok((l.name.clone(), l.equality.iter().map(equality).collect::<mujoco::Result<Vec<_>>>()?)))
            .collect::<Result<Vec<_>>>()?;
        Ok(Linkage {
            data: Data::new(m)?,
            key,
            motor_qpos,
            motor_dof,
            joint_qpos,
            passive,
            passive_dof,
            spring_dof,
            joint_is_passive,
            equalities: idx.loops,
            loop_names,
            spec_path: spec.path.display().to_string(),
            nominal_motors: idx.nominal_actuated,
        })
    }

    /// The stand keyframe must already close the loops: the env starts every episode from it.
    fn check_keyframe(&mut self, spec: &RobotSpec, key_qpos: &[f64]) -> Result<()> {
        if self.passive.is_empty() {
            return Ok(());
        }
        self.data.reset_keyframe(self.key)?;
        self.data.fwd_position()?;
        let residual = self.rows().0.norm();
        if residual > 1e-6 {
            let motors = self.nominal_motors.clone();
            let closed = self.closed_qpos(&motors).ok();
            let addresses: Vec<usize> = self.passive.iter().flat_map(|p| p.qpos..p.qpos + p.nq()).collect();
            let worst = closed.map(|q| addresses.iter().map(|&a| (q[a] - key_qpos[a]).abs()).fold(0.0, f64::max));
            return Err(EnvError::Config(format!(
                "{}: keyframe '{}' does not close the loops (constraint residual {residual:.2e}{}): solve it with \
                 `topa robot stand {}`",
                spec.path.display(),
                spec.stand_keyframe,
                worst.map_or(String::new(), |w| format!(", passive joints off by up to {w:.2e} rad")),
                spec.path.display()
            )));
        }
        Ok(())
    }

    pub fn n_motors(&self) -> usize {
        self.motor_qpos.len()
    }

    /// Motor positions in the stand pose (the keyframe's driven joints).
    pub fn nominal_motors(&self) -> &[f64] {
        &self.nominal_motors
    }

    /// Sets the motors, closes the loops; leaves the data at the closed configuration. The motors move from the
    /// stand pose in steps of at most `CONTINUATION_STEP`, closing the loops after each: a full Newton step from
    /// the keyframe to a distant motor position can land on the linkage's other assembly branch (a parallelogram
    /// folded over), which satisfies the constraints but is not the robot.
    fn close(&mut self, motors: &[f64]) -> Result<()> {
        if motors.len() != self.n_motors() {
            return Err(EnvError::Shape(format!("{} motor positions for {} motors", motors.len(), self.n_motors())));
        }
        self.data.reset_keyframe(self.key)?;
        let span = motors.iter().zip(&self.nominal_motors).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        let steps = ((span / CONTINUATION_STEP).ceil() as usize).max(1);
        for s in 1..=steps {
            let t = s as f64 / steps as f64;
            for k in 0..motors.len() {
                let q0 = self.nominal_motors[k];
                self.data.qpos_mut()[self.motor_qpos[k]] = q0 + t * (motors[k] - q0);
            }
            self.newton(motors)?;
        }
        Ok(())
    }

    /// Gauss–Newton on the passive joints from the current configuration until the loops close.
    fn newton(&mut self, motors: &[f64]) -> Result<()> {
        for _ in 0..MAX_ITERATIONS {
            self.data.fwd_position()?;
            let (r, jp, _, _) = self.rows();
            if r.norm() < CLOSURE_TOL || self.passive.is_empty() {
                return Ok(());
            }
            let step = jp.pseudo_inverse(1e-12).map_err(|e| EnvError::Config(e.to_string()))? * &r;
            let mut k = 0;
            for p in self.passive.clone() {
                let qpos = self.data.qpos_mut();
                if p.ball {
                    rotate_local(&mut qpos[p.qpos..p.qpos + 4], [-step[k], -step[k + 1], -step[k + 2]]);
                } else {
                    qpos[p.qpos] -= step[k];
                }
                k += p.nv();
            }
        }
        self.data.fwd_position()?;
        let (r, _, _, _) = self.rows();
        if r.norm() < 1e-9 {
            return Ok(());
        }
        Err(EnvError::Config(format!(
            "the loops do not close for motor positions {motors:?} (residual {:.2e}): outside the linkage's reach",
            r.norm()
        )))
    }

    /// The constraint rows of the loops' equalities at the current configuration.
    fn loop_rows(&self) -> Vec<usize> {
        let d = &self.data;
        (0..d.nefc())
            .filter(|&i| {
                d.efc_type(i) == ConstraintType::Equality && self.equalities.contains(&(d.efc_id()[i] as usize))
            })
            .collect()
    }

    /// The loops' equality rows at the current configuration: violations r, the Jacobian's columns of the
    /// passive joints (J_p) and of the motors (J_m), and the rows themselves (`loop_rows`).
    fn rows(&self) -> (DVector<f64>, DMatrix<f64>, DMatrix<f64>, Vec<usize>) {
        let d = &self.data;
        let nv = d.model().nv();
        let jac = d.efc_jacobian().expect("the linkage's model stores its Jacobian dense");
        let rows = self.loop_rows();
        let r = DVector::from_iterator(rows.len(), rows.iter().map(|&i| d.efc_pos()[i]));
        let cols = |dofs: &[usize]| DMatrix::from_fn(rows.len(), dofs.len(), |i, k| jac[rows[i] * nv + dofs[k]]);
        (r, cols(&self.passive_dof), cols(&self.motor_dof), rows)
    }

    /// The error for passive joints that cannot follow the motors: `unmatched[i]` is the share of the motor
    /// motion they leave unmatched in `rows[i]` (rows as `rows` returns them). It names each such loop and the
    /// joints its rows also move through (neither passive nor driven nor the floating base): the candidates for
    /// its passive list.
    fn unclosable(&self, rows: &[usize], unmatched: &[f64]) -> EnvError {
        let d = &self.data;
        let m = d.model();
        let nv = m.nv();
        let jac = d.efc_jacobian().expect("the linkage's model stores its Jacobian dense");
        let mut msgs = Vec::new();
        for (name, eqs) in &self.loop_names {
            let mine: Vec<usize> = (0..rows.len()).filter(|&i| eqs.contains(&(d.efc_id()[rows[i]] as usize))).collect();
            let worst = mine.iter().map(|&i| unmatched[i]).fold(0.0, f64::max);
            if worst <= JACOBIAN_TOL {
                continue;
            }
            let mut also: Vec<&str> = Vec::new();
            for dof in 0..nv {
                let joint = m.dof_jntid()[dof] as usize;
                let known =
                    self.passive_dof.contains(&dof) || self.motor_dof.contains(&dof) || self.spring_dof.contains(&dof);
                let moves = mine.iter().any(|&i| jac[rows[i] * nv + dof].abs() > 1e-9);
                if moves && !known && m.jnt_type(joint) != JointType::Free {
                    let n = m.name_of(ObjType::Joint, joint).unwrap_or("(unnamed)");
                    if !also.contains(&n) {
                        also.push(n);
                    }
                }
            }
            let hint = if also.is_empty() {
                "no other joint moves it: the loop is overconstrained or a passive joint is the wrong one".to_string()
            } else {
                format!("it also moves through {}: add the free one(s) to its passive list", also.join(", "))
            };
            msgs.push(format!(
                "loop '{name}': its passive joints cannot follow the motors (a motor's motion {worst:.1e} unmatched); {hint}"
            ));
        }
        EnvError::Config(format!("{}: {}", self.spec_path, msgs.join("; ")))
    }

    /// The whole qpos of the stand keyframe with these motor positions and the loops closed (the base and any
    /// joint outside the loops as in the keyframe).
    pub fn closed_qpos(&mut self, motors: &[f64]) -> Result<Vec<f64>> {
        self.close(motors)?;
        Ok(self.data.qpos().to_vec())
    }

    /// Kinematic-joint angles for motor positions.
    pub fn joints(&mut self, motors: &[f64]) -> Result<Vec<f64>> {
        self.close(motors)?;
        Ok(self.joint_qpos.iter().map(|&a| self.data.qpos()[a]).collect())
    }

    /// J = ∂q_joint/∂q_motor at motor positions (n × n): joint velocities are J·q̇_motor. The loops' passive
    /// velocities follow from the closure, J_p q̇_p + J_m q̇_m = 0.
    pub fn jacobian(&mut self, motors: &[f64]) -> Result<DMatrix<f64>> {
        self.close(motors)?;
        let n = self.n_motors();
        let (_, jp, jm, rows) = self.rows();
        let passive = if self.passive_dof.is_empty() {
            DMatrix::zeros(0, n)
        } else {
            -(jp.clone().pseudo_inverse(1e-12).map_err(|e| EnvError::Config(e.to_string()))? * &jm)
        };
        // The closure must hold exactly, J_p q̇_p + J_m q̇_m = 0: a least-squares answer is a wrong J.
        if !self.passive_dof.is_empty() {
            let left = &jp * &passive + &jm;
            let unmatched: Vec<f64> = left.row_iter().map(|r| r.abs().max()).collect();
            if unmatched.iter().any(|&u| u > JACOBIAN_TOL) {
                return Err(self.unclosable(&rows, &unmatched));
            }
        }
        Ok(DMatrix::from_fn(n, n, |i, k| match self.joint_is_passive[i] {
            Some(p) => passive[(p, k)],
            None => {
                if i == k {
                    1.0
                } else {
                    0.0
                }
            }
        }))
    }

    /// Motor positions for kinematic-joint angles (Newton on `joints`, from the stand pose).
    pub fn motors(&mut self, joints: &[f64]) -> Result<Vec<f64>> {
        let mut q = self.nominal_motors.clone();
        for _ in 0..MAX_ITERATIONS {
            let f: Vec<f64> = self.joints(&q)?.iter().zip(joints).map(|(a, b)| a - b).collect();
            if f.iter().map(|x| x * x).sum::<f64>().sqrt() < 1e-12 {
                return Ok(q);
            }
            let j = self.jacobian(&q)?;
            let step = j
                .lu()
                .solve(&DVector::from_vec(f))
                .ok_or_else(|| EnvError::Config(format!("the linkage is singular at motor positions {q:?}")))?;
            for (x, s) in q.iter_mut().zip(step.iter()) {
                *x -= s;
            }
        }
        Err(EnvError::Config(format!("no motor positions reach joint angles {joints:?}")))
    }

    /// Motor torques that produce joint torques `tau_joint` at motor positions: τ_m = Jᵀ τ_j.
    pub fn motor_torques(&mut self, motors: &[f64], tau_joint: &[f64]) -> Result<Vec<f64>> {
        let j = self.jacobian(motors)?;
        Ok((j.transpose() * DVector::from_column_slice(tau_joint)).iter().copied().collect())
    }
}

/// Motor → joint maps for use every step: the identity (no loops), a constant matrix (a linear linkage such as
/// TopA's parallelogram, detected by comparing the Jacobian across configurations), or the solver (nonlinear).
pub enum JointMap {
    Identity,
    /// q_joint = J q_motor + c.
    Linear {
        j: DMatrix<f64>,
        c: DVector<f64>,
    },
    Solve(Box<Linkage>),
}

/// Entries this close to an integer are that integer: the closure is solved to 1e-12, so an entry of TopA's M
/// computed as 0.999999999999 is 1, and the linear map then reproduces M·q bit for bit.
fn snap(x: f64) -> f64 {
    if (x - x.round()).abs() < 1e-9 {
        x.round()
    } else {
        x
    }
}

impl JointMap {
    pub fn new(spec: &RobotSpec, model: &Model) -> Result<JointMap> {
        if spec.loops.is_empty() {
            return Ok(JointMap::Identity);
        }
        JointMap::from_linkage(Linkage::new(spec, model)?)
    }

    /// The map of an already built linkage (identity when it has no loops).
    pub fn from_linkage(mut l: Linkage) -> Result<JointMap> {
        if l.passive.is_empty() {
            return Ok(JointMap::Identity);
        }
        let q0 = l.nominal_motors.clone();
        let j0 = l.jacobian(&q0)?;
        let mut linear = true;
        // Probes within 0.1 rad of the stand pose: each must close, or the map is not known there.
        for k in 0..4 {
            let q: Vec<f64> = q0.iter().enumerate().map(|(i, x)| x + 0.1 * ((i + k) as f64 * 2.3).sin()).collect();
            linear &= (l.jacobian(&q)? - &j0).abs().max() < 1e-9;
        }
        if !linear {
            return Ok(JointMap::Solve(Box::new(l)));
        }
        let j = j0.map(snap);
        let qj0 = DVector::from_vec(l.joints(&q0)?);
        let c = (qj0 - &j * DVector::from_column_slice(&q0)).map(snap);
        Ok(JointMap::Linear { j, c })
    }

    /// Kinematic-joint angles for motor positions, into `out`.
    pub fn positions(&mut self, motors: &[f64], out: &mut [f64]) -> Result<()> {
        match self {
            JointMap::Identity => out.copy_from_slice(motors),
            JointMap::Linear { j, c } => {
                for (i, o) in out.iter_mut().enumerate() {
                    *o = (0..motors.len()).fold(0.0, |acc, k| acc + j[(i, k)] * motors[k]) + c[i];
                }
            }
            JointMap::Solve(l) => out.copy_from_slice(&l.joints(motors)?),
        }
        Ok(())
    }

    /// Joint velocities for motor positions and velocities (J q̇_motor), into `out`.
    pub fn velocities(&mut self, motors: &[f64], motor_vel: &[f64], out: &mut [f64]) -> Result<()> {
        match self {
            JointMap::Identity => out.copy_from_slice(motor_vel),
            JointMap::Linear { j, .. } => {
                for (i, o) in out.iter_mut().enumerate() {
                    *o = (0..motor_vel.len()).fold(0.0, |acc, k| acc + j[(i, k)] * motor_vel[k]);
                }
            }
            JointMap::Solve(l) => {
                let jac = l.jacobian(motors)?;
                for (i, o) in out.iter_mut().enumerate() {
                    *o = (0..motor_vel.len()).fold(0.0, |acc, k| acc + jac[(i, k)] * motor_vel[k]);
                }
            }
        }
        Ok(())
    }

    /// The inverse of the constant matrix (joint → motor), entries snapped like the matrix's.
    pub fn inverse_matrix(&self, n: usize) -> Option<DMatrix<f64>> {
        self.matrix(n)?.try_inverse().map(|m| m.map(snap))
    }

    /// The constant matrix of an identity or linear map (what a deployment graph can embed).
    pub fn matrix(&self, n: usize) -> Option<DMatrix<f64>> {
        match self {
            JointMap::Identity => Some(DMatrix::identity(n, n)),
            JointMap::Linear { j, .. } => Some(j.clone()),
            JointMap::Solve(_) => None,
        }
    }
}
