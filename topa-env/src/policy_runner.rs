//! The adapter between a policy file and a robot: it loads the policy, finds the robot it runs on (the one it was
//! trained on, or — for a policy trained on a simplified model — the real robot), and turns the robot's
//! observations into motor targets. Evaluation, play, export and the benches all drive policies through it.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::DMatrix;
use trainer::policy_file::Policy;

use crate::assets;
use crate::error::{EnvError, Result};
use crate::indices::RobotIndices;
use crate::linkage::JointMap;
use crate::observation::{Block, ObsLayout};
use crate::spec::RobotSpec;
use crate::topa::ModelKind;

/// A policy ready to act on the robot it is evaluated on: the robot it was trained on, or — for a policy trained
/// on a simplified model (TopA's serial chain, whose spec `approximates` the closed one) — the real robot, through
/// its linkage: observed motor positions, velocities and previous actions are mapped to joint space with the
/// linkage's constant J (the paper's M, computed from the constraints), and the joint-space action back with J⁻¹
/// (motor targets = J⁻¹ · joint targets, since the nominal pose maps the same way).
pub struct PolicyRunner {
    pub policy: Policy,
    pub name: String,
    /// The spec the policy was trained on, and the robot it runs on here.
    trained_on: Arc<RobotSpec>,
    robot: Arc<RobotSpec>,
    /// (J, J⁻¹) where the two differ.
    map: Option<(DMatrix<f64>, DMatrix<f64>)>,
    layout: ObsLayout,
    /// Its training config (the sidecar's, parsed and validated once).
    training: crate::EnvConfig,
    /// The robot's motor positions in its stand keyframe (what actions are offsets from).
    nominal_motors: Vec<f64>,
    action_zero: Vec<f64>,
    obs_buf: Vec<f32>,
    act_buf: Vec<f32>,
}

/// The spec a policy file names: its `robot`, a spec path or a bundled robot's name.
fn policy_robot(meta: &trainer::policy_file::PolicyMeta) -> Result<PathBuf> {
    let named = meta.robot.as_deref().filter(|r| r.ends_with(".toml"));
    Ok(match named {
        Some(r) => assets::resolve_path(r),
        None => assets::resolve_path(ModelKind::of_policy(meta.robot.as_deref())?.spec_path()),
    })
}

impl PolicyRunner {
    pub fn load(path: &Path, name: &str) -> Result<Self> {
        let policy = Policy::load(path)?;
        let m = &policy.meta;
        let refuse = |message: String| EnvError::Policy { path: path.to_path_buf(), message };
        let spec_path = policy_robot(m).map_err(|e| refuse(e.to_string()))?;
        let (trained_on, trained_model) = RobotSpec::load(&spec_path)?;
        let (robot, model) = match &trained_on.approximates {
            Some(real) => RobotSpec::load(real)?,
            None => (trained_on.clone(), trained_model),
        };
        let n = robot.n_motors();
        // The observation the policy was trained on: the paper's, a height scan if its config had one, and the
        // options of `[env.observation]` (no base velocity, earlier frames).
        let trained = crate::EnvConfig::from_table(&m.provenance.config.env)
            .map_err(|e| refuse(format!("its training config: {e}")))?;
        let layout = trained.observation.layout(ObsLayout::new(n).with_scan(trained.height_scan.grid()));
        if m.obs_dim != layout.dim() || m.action_dim != n {
            return Err(refuse(format!(
                "a {}→{} policy cannot drive {} ({} observations → {n} motor targets)",
                m.obs_dim,
                m.action_dim,
                robot.name,
                layout.dim()
            )));
        }
        let map = if trained_on.approximates.is_some() {
            for (a, b) in trained_on.motors.iter().zip(&robot.motors) {
                if a.drives != b.joint {
                    return Err(EnvError::Config(format!(
                        "{}: its motor '{}' drives '{}', not {}'s joint '{}'",
                        trained_on.name, a.actuator, a.drives, robot.name, b.joint
                    )));
                }
            }
            let joint_map = JointMap::new(&robot, &model)?;
            let (Some(j), Some(inv)) = (joint_map.matrix(n), joint_map.inverse_matrix(n)) else {
                return Err(refuse(format!(
                    "a policy trained on {} needs {}'s linkage to be linear to map its joint-space actions; this \
                     one is nonlinear",
                    trained_on.name, robot.name
                )));
            };
            Some((j, inv))
        } else {
            None
        };
        let robot = Arc::new(robot);
        let idx = RobotIndices::resolve(&model, &robot)?;
        let (nominal_motors, action_zero) = (idx.nominal_actuated, idx.action_zero);
        Ok(PolicyRunner {
            policy,
            name: name.to_string(),
            trained_on: Arc::new(trained_on),
            robot,
            map,
            layout,
            training: trained,
            nominal_motors,
            action_zero,
            obs_buf: Vec::new(),
            act_buf: Vec::new(),
        })
    }

    /// The env config the policy was trained with.
    pub fn training_config(&self) -> &crate::EnvConfig {
        &self.training
    }

    /// The name of the robot spec the policy was trained on (e.g. topa_open for the paper's O).
    pub fn trained_on(&self) -> &str {
        &self.trained_on.name
    }

    /// The paper's group this policy belongs to, for the paper's numbers beside ours: O (trained on TopA's serial
    /// model), C (on its closed chain), CA (C with the adversary); None for another robot.
    pub fn paper_group(&self) -> Option<&'static str> {
        match (self.trained_on(), self.policy.meta.provenance.with_adversary) {
            ("topa_open", _) => Some("O"),
            ("topa_closed", false) => Some("C"),
            ("topa_closed", true) => Some("CA"),
            _ => None,
        }
    }

    /// The robot it is evaluated on.
    pub fn robot(&self) -> &RobotSpec {
        &self.robot
    }

    /// The robot's observation layout (what `act` takes).
    pub fn layout(&self) -> ObsLayout {
        self.layout
    }

    /// (J, J⁻¹) between the robot's motor space and the joint space the policy acts in, where the two differ.
    pub fn joint_map(&self) -> Option<&(DMatrix<f64>, DMatrix<f64>)> {
        self.map.as_ref()
    }

    /// The robot's motor positions in its stand pose, rad.
    pub fn nominal_motors(&self) -> &[f64] {
        &self.nominal_motors
    }

    /// The motor targets of a zero action, rad: the stand pose plus the spec's feed-forward over each kp.
    pub fn action_zero(&self) -> &[f64] {
        &self.action_zero
    }

    /// Actions (the robot's motor space) for the robot's observations, row by row.
    pub fn act(&mut self, obs: &[f32], actions: &mut Vec<f32>) {
        let Some((j, inv)) = &self.map else {
            return self.policy.act(obs, actions);
        };
        let l = self.layout;
        let n = l.n_motors;
        let apply = |m: &DMatrix<f64>, v: &[f32], out: &mut [f32]| {
            for (i, o) in out.iter_mut().enumerate() {
                *o = (0..n).fold(0.0, |acc, k| acc + m[(i, k)] * v[k] as f64) as f32;
            }
        };
        self.obs_buf.clear();
        self.obs_buf.extend_from_slice(obs);
        let mut tmp = vec![0.0f32; n];
        // The motor blocks of the current frame (it starts at ω) and of every earlier one.
        let now = l.offset(Block::AngVel);
        let frames = std::iter::once(now).chain((0..l.history).map(|f| l.offset(Block::History) + f * l.frame()));
        let starts: Vec<usize> = frames
            .flat_map(|at| [Block::MotorPos, Block::MotorVel, Block::LastAction].map(|b| at + l.offset(b) - now))
            .collect();
        for row in self.obs_buf.chunks_exact_mut(l.dim()) {
            for &at in &starts {
                apply(j, &row[at..at + n], &mut tmp);
                row[at..at + n].copy_from_slice(&tmp);
            }
        }
        self.policy.act(&self.obs_buf, &mut self.act_buf);
        actions.clear();
        for a in self.act_buf.chunks_exact(n) {
            apply(inv, a, &mut tmp);
            actions.extend_from_slice(&tmp);
        }
    }
}
