//! `topa play`: one policy, one command, on the closed model (evaluation settings), optionally recorded to MCAP
//! for Foxglove. The recording ends cleanly when the robot falls.

use std::path::PathBuf;

use serde::Serialize;
use serde_json::json;
use topa_env::{assets, RobotEnv, Task};

use crate::error::Result;
use crate::recording::Recorder;
use crate::settings::EvalSettings;
use crate::video::{self, VideoRecorder};
use topa_env::policy_runner::PolicyRunner;

/// What to play and what to write.
#[derive(Debug, Clone, Default)]
pub struct PlayOptions {
    pub command: [f64; 3],
    pub seconds: f64,
    /// MCAP recording.
    pub record: Option<PathBuf>,
    /// Video (.gif or .mp4), its frame size and rate.
    pub video: Option<PathBuf>,
    pub video_size: (usize, usize),
    pub fps: u32,
    pub quality: Option<mujoco::render::Quality>,
    /// Constant force on the torso in its own frame from the command's start, N (the push experiment's cells).
    pub torso_force: Option<[f64; 2]>,
}

#[derive(Debug, Clone, Serialize)]
pub struct PlaySummary {
    pub command: [f64; 3],
    pub seconds: f64,
    pub fell: bool,
    pub fell_at_s: Option<f64>,
    /// Horizontal distance travelled, m.
    pub distance_m: f64,
    /// Mean measured (v_x, v_y, w_z) in the torso frame.
    pub mean_velocity: [f64; 3],
    pub recording: Option<PathBuf>,
    pub video: Option<PathBuf>,
    pub video_frames: usize,
}

fn named(names: &[String], v: &[f64]) -> serde_json::Value {
    serde_json::Value::Object(names.iter().zip(v).map(|(n, x)| (n.clone(), json!(x))).collect())
}

/// Joint torques from motor torques by virtual work, τ_j = J⁻ᵀ τ_m, where the robot's linkage is linear (its J
/// constant); `None` leaves them out of the recording.
fn joint_torque_map(env: &RobotEnv) -> Option<nalgebra::DMatrix<f64>> {
    let idx = env.indices();
    let map = topa_env::linkage::JointMap::new(&idx.spec, env.data().model()).ok()?;
    map.inverse_matrix(idx.n_motors).map(|inv| inv.transpose())
}

fn record_step(rec: &mut Recorder, env: &RobotEnv, torque_map: &Option<nalgebra::DMatrix<f64>>, t: f64) -> Result<()> {
    let s = env.robot_state();
    let spec = &env.indices().spec;
    let joints: Vec<String> = spec.motors.iter().map(|m| m.joint.clone()).collect();
    let motors: Vec<String> = spec.motors.iter().map(|m| m.actuator.clone()).collect();
    rec.write_transforms(env.data(), t)?;
    let mut joint_plot = json!({"position": named(&joints, &s.joint_pos), "velocity": named(&joints, &s.joint_vel)});
    if let Some(m) = torque_map {
        let tau: Vec<f64> = (m * nalgebra::DVector::from_column_slice(&s.motor_torque)).iter().copied().collect();
        joint_plot["torque"] = named(&joints, &tau);
    }
    rec.write_plot("/joints", t, joint_plot)?;
    rec.write_plot("/motors", t, json!({"position": named(&motors, &s.motor_pos), "velocity": named(&motors, &s.motor_vel), "torque": named(&motors, &s.motor_torque)}))?;
    let mut base = json!({"height": s.base_pos[2], "roll": s.roll, "pitch": s.pitch, "yaw": s.yaw,
               "v_x": s.lin_vel[0], "v_y": s.lin_vel[1], "v_z": s.lin_vel[2], "w_x": s.ang_vel[0], "w_y": s.ang_vel[1], "w_z": s.ang_vel[2]});
    if let Some(s2s) = env.sim2sim() {
        // What the policy was given (torso frame) beside the truth above: the estimator's velocity, the gyro.
        let seen = s2s.latest();
        base["sensed"] = json!({"v_x": seen.lin_vel[0], "v_y": seen.lin_vel[1], "v_z": seen.lin_vel[2],
            "w_x": seen.ang_vel[0], "w_y": seen.ang_vel[1], "w_z": seen.ang_vel[2], "filter_resets": s2s.filter_resets});
    }
    rec.write_plot("/base", t, base)?;
    let c = env.command();
    rec.write_plot("/command", t, json!({"v_x": c[0], "v_y": c[1], "w_z": c[2], "measured_v_x": s.lin_vel[0], "measured_v_y": s.lin_vel[1], "measured_w_z": s.ang_vel[2]}))?;
    let contact = s.foot_contact();
    rec.write_plot("/contacts", t, json!({"left_force_n": s.foot_force[0], "right_force_n": s.foot_force[1], "left_contact": contact[0], "right_contact": contact[1]}))?;
    let names: Vec<String> = env.term_names().iter().map(|n| n.to_string()).collect();
    rec.write_plot("/rewards", t, named(&names, env.terms()))?;
    Ok(())
}

pub fn run(policy: &std::path::Path, o: &PlayOptions, settings: &EvalSettings) -> Result<PlaySummary> {
    let (command, seconds) = (o.command, o.seconds);
    let mut runner = PolicyRunner::load(policy, "policy")?;
    let cfg = settings.env_config(&runner)?;
    let (_, model) = assets::load_robot(&cfg)?;
    let mut env = RobotEnv::new(model, std::sync::Arc::new(cfg.clone()), settings.seed, 0)?;
    let torque_map = joint_torque_map(&env);
    let mut obs = vec![0.0f32; env.obs_dim()];
    env.reset(&mut obs)?;
    env.set_command_override(Some([0.0; 3]));
    let mut rec = match &o.record {
        Some(p) => Some(Recorder::create(p, env.data().model())?),
        None => None,
    };
    let mut vid = match &o.video {
        Some(p) => Some(VideoRecorder::create(
            p,
            &env,
            o.video_size,
            o.fps,
            o.quality.unwrap_or(mujoco::render::Quality::Fast),
        )?),
        None => None,
    };
    if let Some(r) = rec.as_mut() {
        r.write_scene(env.data().model(), 0.0)?;
        record_step(r, &env, &torque_map, 0.0)?;
    }
    let dt = cfg.policy_dt();
    let settle = (settings.settle_s / dt).round() as usize;
    let steps = settle + (seconds / dt).round() as usize;
    let start = env.robot_state().base_pos;
    let (mut sum, mut n) = ([0.0; 3], 0usize);
    let mut fell_at = None;
    let mut actions = Vec::with_capacity(env.action_dim());
    for k in 0..steps {
        if k == settle {
            env.set_command_override(Some(command));
            if let Some(f) = o.torso_force {
                let mut p = *env.perturbation();
                p.torso_force_local = [f[0], f[1], 0.0];
                env.set_perturbation_struct(p);
            }
        }
        runner.act(&obs, &mut actions);
        let out = env.step(&actions, &mut obs);
        let t = (k + 1) as f64 * dt;
        if let Some(r) = rec.as_mut() {
            record_step(r, &env, &torque_map, t)?;
        }
        if let Some(v) = vid.as_mut() {
            let text = video::overlay(&env, t);
            v.advance(t, &mut env, &text)?;
        }
        if out.done {
            fell_at = Some(t);
            break;
        }
        if k >= settle {
            let s = env.robot_state();
            for (acc, v) in sum.iter_mut().zip([s.lin_vel[0], s.lin_vel[1], s.ang_vel[2]]) {
                *acc += v;
            }
            n += 1;
        }
    }
    let end = env.robot_state().base_pos;
    let recording = match rec.as_mut() {
        Some(r) => Some(r.finish()?),
        None => None,
    };
    let video_frames = vid.as_ref().map_or(0, |v| v.frames());
    let video = match vid {
        Some(v) => Some(v.finish()?),
        None => None,
    };
    Ok(PlaySummary {
        command,
        seconds,
        fell: fell_at.is_some(),
        fell_at_s: fell_at,
        distance_m: (end[0] - start[0]).hypot(end[1] - start[1]),
        mean_velocity: sum.map(|x| x / n.max(1) as f64),
        recording,
        video,
        video_frames,
    })
}
