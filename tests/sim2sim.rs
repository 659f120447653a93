//! Realistic sim2sim: the state estimator against the simulator's truth on the bundled C policy, the sensor and
//! latency models' statistics inside the env, determinism, and robustness to a fall and to bad sensor values.

use std::path::Path;
use std::sync::Arc;

use topa_env::policy_runner::PolicyRunner;
use topa_env::{assets, ModelKind, RobotEnv, Task};
use topa_eval::settings::{EvalSettings, Sim2SimMode};

fn realistic() -> EvalSettings {
    EvalSettings::default().with_sim2sim(&Sim2SimMode::Realistic).unwrap()
}

fn c_policy() -> PolicyRunner {
    PolicyRunner::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/policies/C/seed1.json")), "C").unwrap()
}

/// Runs the C policy for `seconds` after 2 s of standing, returning per policy step (true world velocity,
/// estimated world velocity) after `skip` seconds of the command.
fn walk(command: [f64; 3], seconds: f64, skip: f64, seed: u64) -> Vec<([f64; 3], [f64; 3])> {
    let mut runner = c_policy();
    let settings = EvalSettings { seed, ..realistic() };
    let cfg = settings.env_config(&runner).unwrap();
    let mut env =
        RobotEnv::new(assets::load_model(ModelKind::Closed).unwrap(), Arc::new(cfg.clone()), seed, 0).unwrap();
    let mut obs = vec![0.0f32; env.obs_dim()];
    env.reset(&mut obs).unwrap();
    env.set_command_override(Some([0.0; 3]));
    let dt = cfg.policy_dt();
    let (settle, n) = ((2.0 / dt) as usize, ((seconds + 2.0) / dt) as usize);
    let mut out = Vec::new();
    let mut actions = Vec::new();
    for k in 0..n {
        if k == settle {
            env.set_command_override(Some(command));
        }
        runner.act(&obs, &mut actions);
        let r = env.step(&actions, &mut obs);
        assert!(!r.done, "the C policy falls under realistic sim2sim at step {k}");
        assert!(obs.iter().all(|x| x.is_finite()));
        if k as f64 * dt >= 2.0 + skip {
            let dof = env.indices().base_dof;
            let q = env.data().qvel();
            let est = env.sim2sim().unwrap().estimate_world;
            out.push(([q[dof], q[dof + 1], q[dof + 2]], [est.x, est.y, est.z]));
        }
    }
    out
}

#[test]
fn the_estimator_tracks_walking_and_does_not_drift_while_standing() {
    let run = walk([0.5, 0.0, 0.0], 10.0, 1.0, 1);
    let rmse =
        (run.iter().map(|(t, e)| (t[0] - e[0]).powi(2) + (t[1] - e[1]).powi(2)).sum::<f64>() / run.len() as f64).sqrt();
    let mean_vx = run.iter().map(|(t, _)| t[0]).sum::<f64>() / run.len() as f64;
    assert!(mean_vx > 0.35, "the robot walks forward ({mean_vx} m/s)");
    // The default filter's error depends on the gait it sees (0.049 m/s on the previous preset's C seed 1, 0.050
    // on this one); a filter that lost the velocity would be off by about the walking speed.
    assert!(rmse <= 0.06, "horizontal velocity RMSE {rmse} m/s while walking at 0.5 m/s");
    eprintln!("walking at 0.5 m/s: horizontal velocity RMSE {rmse:.4} m/s");
    let stand = walk([0.0; 3], 10.0, 0.0, 2);
    // Drift: the estimate's horizontal speed averaged over each second, against the truth's.
    let mut worst = 0.0f64;
    for w in stand.chunks(50) {
        // Mean estimate-minus-truth of horizontal component k over the window.
        let mean = |k: usize| w.iter().map(|(t, e)| e[k] - t[k]).sum::<f64>() / w.len() as f64;
        let drift = mean(0).hypot(mean(1));
        assert!(drift <= 0.02, "estimate drifts {drift} m/s from the truth while standing");
        worst = worst.max(drift);
    }
    eprintln!("standing 10 s: largest 1-s mean drift {worst:.4} m/s");
}

/// Collects log records (to check that a filter reset is reported).
struct Collect(std::sync::Mutex<Vec<String>>);
impl log::Log for Collect {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, r: &log::Record) {
        self.0.lock().unwrap().push(r.args().to_string());
    }
    fn flush(&self) {}
}
static LOGS: Collect = Collect(std::sync::Mutex::new(Vec::new()));

#[test]
fn bad_sensor_values_reset_the_filter_with_a_warning_and_a_fall_stays_finite() {
    let _ = log::set_logger(&LOGS).map(|()| log::set_max_level(log::LevelFilter::Warn));
    let settings = realistic();
    let mut cfg = settings.env_config(&c_policy()).unwrap();
    cfg.termination.enabled = false;
    let model = assets::load_model(ModelKind::Closed).unwrap();
    let cfg = Arc::new(cfg);
    let mut env = RobotEnv::new(model.clone(), cfg.clone(), 3, 0).unwrap();
    let idx = env.indices().clone();
    // The filter on its own, fed a NaN accelerometer reading: it refuses it, resets, says so, stays finite.
    let mut s = topa_env::sim2sim::Sim2Sim::new(Arc::new(cfg.sim2sim.clone()), model.clone(), &idx, 1, 0).unwrap();
    let mut d = mujoco::Data::new(model).unwrap();
    d.reset_keyframe(idx.stand_key).unwrap();
    d.forward().unwrap();
    s.reset(&d, &idx, cfg.decimation).unwrap();
    d.step().unwrap();
    s.after_physics_step(&d, &idx, cfg.timestep).unwrap();
    assert_eq!(s.filter_resets, 0);
    d.sensordata_mut()[idx.imu_accel] = f64::NAN;
    s.after_physics_step(&d, &idx, cfg.timestep).unwrap();
    assert_eq!(s.filter_resets, 1, "a NaN reading resets the filter");
    assert!(s.latest().lin_vel.iter().all(|v| v.is_finite()) && s.estimate_world.iter().all(|v| v.is_finite()));
    assert!(LOGS.0.lock().unwrap().iter().any(|m| m.contains("filter reset")), "the reset is logged");
    // A fall (knees folded) with the estimator running, the robot left on the floor: no panic, no NaN.
    let mut obs = vec![0.0f32; env.obs_dim()];
    env.reset(&mut obs).unwrap();
    let mut fold = [0.0f32; 10];
    for leg in 0..2 {
        fold[leg * 5 + 3] = 6.0;
        fold[leg * 5 + 4] = 6.0;
    }
    let mut fell = false;
    for _ in 0..250 {
        env.step(&fold, &mut obs);
        fell |= env.has_fallen();
        assert!(obs.iter().all(|x| x.is_finite()));
    }
    assert!(fell, "folding the knees drops the robot");
}

#[test]
fn sim2sim_is_seeded_and_its_delays_are_whole_steps() {
    let base = realistic().env_config(&c_policy()).unwrap();
    let model = assets::load_model(ModelKind::Closed).unwrap();
    let rollout = |cfg: &topa_env::EnvConfig, seed: u64, steps: usize| -> Vec<Vec<f32>> {
        let mut env = RobotEnv::new(model.clone(), Arc::new(cfg.clone()), seed, 0).unwrap();
        let mut obs = vec![0.0f32; env.obs_dim()];
        env.reset(&mut obs).unwrap();
        let mut out = vec![obs.clone()];
        for k in 0..steps {
            let a: Vec<f32> = (0..10).map(|i| 0.3 * ((k * 3 + i) as f32 * 0.7).sin()).collect();
            env.step(&a, &mut obs);
            out.push(obs.clone());
        }
        out
    };
    // Same seed, same readings; another seed, other noise.
    assert_eq!(rollout(&base, 4, 30), rollout(&base, 4, 30));
    assert_ne!(rollout(&base, 4, 30), rollout(&base, 5, 30));
    // Observation delay of k policy steps: the sensor part of the observation is the undelayed one of k steps
    // before (the previous action and the command are the robot's own, never late).
    let mut undelayed = base.clone();
    undelayed.sim2sim.latency.observation_policy_steps = 0;
    let mut delayed = base.clone();
    delayed.sim2sim.latency.observation_policy_steps = 3;
    let (a, b) = (rollout(&undelayed, 9, 20), rollout(&delayed, 9, 20));
    for k in 3..20 {
        assert_eq!(&b[k][..29], &a[k - 3][..29], "step {k}: sensors 3 steps old");
        assert_eq!(&b[k][29..], &a[k][29..], "step {k}: last action and command are current");
    }
}

#[test]
fn an_action_reaches_the_motors_after_the_configured_latency() {
    let mut cfg = realistic().env_config(&c_policy()).unwrap();
    cfg.sim2sim.latency.action_policy_steps = 1;
    cfg.sim2sim.latency.action_physics_steps = 3;
    let model = assets::load_model(ModelKind::Closed).unwrap();
    let env = RobotEnv::new(model.clone(), Arc::new(cfg.clone()), 1, 0).unwrap();
    let idx = env.indices().clone();
    let mut s = topa_env::sim2sim::Sim2Sim::new(Arc::new(cfg.sim2sim.clone()), model.clone(), &idx, 1, 0).unwrap();
    let mut d = mujoco::Data::new(model).unwrap();
    d.reset_keyframe(idx.stand_key).unwrap();
    d.forward().unwrap();
    let initial = d.ctrl()[0];
    s.reset(&d, &idx, cfg.decimation).unwrap();
    let latency = cfg.decimation + 3;
    let mut target = [0.0; 10];
    target[0] = initial + 0.2;
    s.set_target(&target);
    for k in 0..latency + 2 {
        s.before_physics_step(&mut d, &idx);
        let want = if k < latency { initial } else { initial + 0.2 };
        assert_eq!(d.ctrl()[0], want, "physics step {k} (latency {latency})");
    }
}
