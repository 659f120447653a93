//! The robot-side controller (`topa_control`) against topa's own evaluation, and its safety layer: fed the
//! simulator's readings it sends the targets the evaluation sends (the paper's C+A, O through its linkage map, a
//! velocity-free policy with its estimator); a tick allocates nothing; every failure drill ends in damping.

use std::path::{Path, PathBuf};

use topa_control::{Controller, Fault, FrameRefused, Mode, SensorFrame};
use topa_env::policy_runner::PolicyRunner;
use topa_env::VecEnv;
use topa_eval::settings::EvalSettings;

mod common;

fn tempdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("topa-controller-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The controller of `policy`, starting the policy at once (a soft start of one period) with commands applied
/// without a ramp — so that it starts as an evaluation episode does.
fn controller(policy: &Path, dir: &Path) -> Controller {
    topa_tools::controller_export::export(policy, dir).unwrap();
    let json = dir.join("controller.json");
    let mut spec: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    spec["safety"]["soft_start_s"] = 1e-6.into();
    spec["safety"]["command_rate"] = serde_json::json!([1e9, 1e9, 1e9]);
    std::fs::write(&json, spec.to_string()).unwrap();
    Controller::load(dir).unwrap()
}

/// Drives the ideal evaluation with `policy` for `steps` control periods and the controller beside it on the same
/// readings; returns the largest difference between their motor targets, rad.
fn parity(policy: &Path, tag: &str, steps: usize) -> f64 {
    let dir = tempdir(tag);
    let mut c = controller(policy, &dir);
    let mut runner = PolicyRunner::load(policy, tag).unwrap();
    let cfg = EvalSettings::default().env_config(&runner).unwrap();
    let mut batch = topa_env::vec_env::robot_batch(&cfg, 1, 3, 1).unwrap();
    let command = [0.4, 0.0, 0.3];
    batch.tasks_mut()[0].set_command_override(Some(command));
    batch.reset().unwrap();
    c.set_command(command);
    c.start();
    let dt = cfg.policy_dt();
    let (mut actions, mut worst) = (Vec::new(), 0.0f64);
    let frame_of = |e: &topa_env::RobotEnv, k: usize| {
        let s = e.robot_state();
        (s.base_quat, s.ang_vel, s.motor_pos.clone(), s.motor_vel.clone(), s.lin_vel, k as f64 * dt)
    };
    // The soft start's two ticks, on the start state.
    for k in 0..2 {
        let (q, w, p, v, lin, _) = frame_of(&batch.tasks()[0], 0);
        let f = SensorFrame {
            timestamp_s: k as f64 * 1e-3,
            orientation: q,
            gyro: w,
            motor_pos: &p,
            motor_vel: &v,
            base_velocity: Some(lin),
        };
        c.tick(&f).unwrap();
    }
    assert_eq!(c.mode(), Mode::Policy);
    for k in 0..steps {
        let (q, w, p, v, lin, t) = frame_of(&batch.tasks()[0], k + 1);
        let f = SensorFrame {
            timestamp_s: t,
            orientation: q,
            gyro: w,
            motor_pos: &p,
            motor_vel: &v,
            base_velocity: Some(lin),
        };
        let target = c.tick(&f).unwrap().target.clone();
        runner.act(batch.obs(), &mut actions);
        let spec = c.spec();
        for (i, m) in spec.motors.iter().enumerate() {
            let a = (actions[i] as f64).clamp(-spec.action_clip, spec.action_clip);
            let expect = (m.action_zero + spec.action_scale * a).clamp(m.range[0], m.range[1]);
            worst = worst.max((expect - target[i]).abs());
        }
        batch.step(&actions).unwrap();
        assert!(batch.dones()[0] < 0.5, "{tag} fell at step {k}");
    }
    std::fs::remove_dir_all(dir).ok();
    worst
}

#[test]
fn fed_the_simulators_readings_the_controller_sends_the_evaluations_targets() {
    for (policy, tag) in [("assets/policies/CA/seed1.json", "ca"), ("assets/policies/O/seed1.json", "o")] {
        let worst = parity(Path::new(policy), tag, 150);
        assert!(worst < 1e-4, "{tag}: the controller's targets differ from the evaluation's by {worst} rad");
    }
}

/// A velocity-free policy (estimator inside, four earlier frames): the same targets, without any velocity given.
#[test]
fn a_velocity_free_policy_runs_from_its_own_estimate() {
    let dir = tempdir("vfree-run");
    let config = dir.join("vfree.toml");
    std::fs::write(
        &config,
        "[run]\nnum_envs = 8\nsteps_per_env = 8\niterations = 2\nthreads = 1\n[network]\nactor_hidden = [16]\n\
         critic_hidden = [16]\nestimator_hidden = [16]\n[env]\nrobot = \"assets/robots/topa_closed.toml\"\n\
         [env.observation]\nbase_velocity = \"estimated\"\nhistory = 4\n",
    )
    .unwrap();
    common::cli_train(Some(&config), &dir.join("run"), false, None);
    let policy = dir.join("run/policy.json");
    let c = controller(&policy, &dir.join("ctl"));
    assert_eq!((c.spec().observation.inputs, c.spec().observation.row), (39 + 4 * 36, 39 + 4 * 36 + 3));
    // The random policy may fall: a few steps are enough to cover the history and the estimator.
    let worst = parity(&policy, "vfree", 12);
    assert!(worst < 1e-4, "velocity-free: the controller's targets differ by {worst} rad");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_tick_allocates_nothing_and_every_drill_ends_in_damping() {
    let dir = tempdir("drills");
    let mut c = controller(Path::new("assets/policies/CA/seed1.json"), &dir);
    let n = c.spec().n_motors();
    let dt = c.spec().control_period_s;
    let pos: Vec<f64> = c.spec().motors.iter().map(|m| m.nominal).collect();
    let vel = vec![0.0; n];
    fn frame<'a>(t: f64, pos: &'a [f64], vel: &'a [f64]) -> SensorFrame<'a> {
        SensorFrame {
            timestamp_s: t,
            orientation: [1.0, 0.0, 0.0, 0.0],
            gyro: [0.0; 3],
            motor_pos: pos,
            motor_vel: vel,
            base_velocity: Some([0.0; 3]),
        }
    }
    c.start();
    c.set_command([0.3, 0.0, 0.2]);
    c.tick(&frame(0.0, &pos, &vel)).unwrap();
    c.tick(&frame(dt, &pos, &vel)).unwrap();
    // 10 000 ticks of the policy: no allocation.
    // (allocation-counter counts this thread's allocations: the other tests of this binary run on others.)
    let mut policy_ticks = 0;
    let allocated = allocation_counter::measure(|| {
        for k in 2..10_002 {
            let out = c.tick(&frame(k as f64 * dt, &pos, &vel)).unwrap();
            policy_ticks += usize::from(out.mode == Mode::Policy);
        }
    })
    .count_total;
    assert_eq!(policy_ticks, 10_000);
    assert_eq!(allocated, 0, "{allocated} allocations in 10 000 ticks");
    let mut t = 10_002.0 * dt;
    let damping = |c: &Controller, out: &topa_control::MotorCommand, why: Fault| {
        assert_eq!(out.mode, Mode::Damping(why));
        assert!(out.kp.iter().all(|k| *k == 0.0) && out.kd.iter().zip(&c.spec().motors).all(|(d, m)| *d == m.kd));
        assert!(out.target.iter().all(|x| x.is_finite()), "never a NaN sent");
    };
    let restart = |c: &mut Controller, t: &mut f64| {
        c.reset();
        assert_eq!(c.mode(), Mode::Passive);
        c.start();
        for _ in 0..2 {
            *t += dt;
            c.tick(&frame(*t, &pos, &vel)).unwrap();
        }
        assert_eq!(c.mode(), Mode::Policy);
    };
    // Tilt past the limit.
    t += dt;
    let tilted = SensorFrame { orientation: [0.45f64.cos(), 0.45f64.sin(), 0.0, 0.0], ..frame(t, &pos, &vel) };
    let out = c.tick(&tilted).unwrap().clone();
    damping(&c, &out, Fault::Tilt);
    // A NaN in a reading.
    restart(&mut c, &mut t);
    t += dt;
    let mut bad = pos.clone();
    bad[3] = f64::NAN;
    let out = c.tick(&frame(t, &bad, &vel)).unwrap().clone();
    damping(&c, &out, Fault::NonFinite);
    // The sensor stream goes silent: damping after two periods of silence (the next tick: within three).
    restart(&mut c, &mut t);
    let silent_from = t;
    let mut k = 1;
    while c.watchdog(silent_from + k as f64 * dt).mode == Mode::Policy {
        k += 1;
    }
    assert_eq!(k, 2, "damping in the second empty period");
    assert_eq!(c.mode(), Mode::Damping(Fault::Stale));
    // A motor far outside its range; the operator's stop.
    restart(&mut c, &mut t);
    t += dt;
    let mut far = pos.clone();
    far[0] = c.spec().motors[0].range[1] + 0.5;
    assert_eq!(c.tick(&frame(t, &far, &vel)).unwrap().mode, Mode::Damping(Fault::OutOfRange));
    restart(&mut c, &mut t);
    c.stop();
    t += dt;
    assert_eq!(c.tick(&frame(t, &pos, &vel)).unwrap().mode, Mode::Damping(Fault::Stop));
    // Refused frames: the wrong size, an old timestamp — counted, never acted on.
    let refused = c.counters.refused_frames;
    assert_eq!(
        c.tick(&frame(t + dt, &pos[..n - 1], &vel[..n - 1])).unwrap_err(),
        FrameRefused::WrongSize { got: n - 1, expected: n }
    );
    assert_eq!(c.tick(&frame(t - dt, &pos, &vel)).unwrap_err(), FrameRefused::NotNewer);
    assert_eq!(c.counters.refused_frames, refused + 2);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn the_soft_start_ramps_from_the_measured_pose_and_commands_stay_in_range() {
    let dir = tempdir("soft");
    topa_tools::controller_export::export(Path::new("assets/policies/CA/seed1.json"), &dir).unwrap();
    let mut c = Controller::load(&dir).unwrap();
    let s = c.spec().clone();
    let n = s.n_motors();
    let crouched: Vec<f64> = s.motors.iter().map(|m| 0.5 * (m.range[0] + m.range[1])).collect();
    let vel = vec![0.0; n];
    let frame = |t: f64| SensorFrame {
        timestamp_s: t,
        orientation: [1.0, 0.0, 0.0, 0.0],
        gyro: [0.0; 3],
        motor_pos: &crouched,
        motor_vel: &vel,
        base_velocity: Some([0.0; 3]),
    };
    assert_eq!(c.tick(&frame(0.0)).unwrap().kp.iter().sum::<f64>(), 0.0, "passive: no stiffness");
    c.start();
    let t_ramp = s.safety.soft_start_s;
    let dt = s.control_period_s;
    let at0 = c.tick(&frame(dt)).unwrap().target.clone();
    assert_eq!(at0, crouched, "the ramp starts at the measured pose");
    let half_way = (t_ramp / 2.0 / dt).round() as usize;
    let mut t = dt;
    for _ in 0..half_way {
        t += dt;
        c.tick(&frame(t)).unwrap();
    }
    let mid = c.tick(&frame(t + 1e-9)).unwrap().target.clone();
    for i in 0..n {
        let half = 0.5 * (crouched[i] + s.motors[i].action_zero);
        assert!((mid[i] - half).abs() < 1e-6, "halfway at half the ramp: {} vs {half}", mid[i]);
    }
    while c.mode() == Mode::SoftStart {
        t += dt;
        let out = c.tick(&frame(t)).unwrap().clone();
        if out.mode == Mode::Policy {
            assert!(out.target.iter().zip(&s.motors).all(|(t, m)| (t - m.action_zero).abs() < 1e-9), "the stand pose");
        }
    }
    assert!((t - dt - t_ramp).abs() < 1.5 * dt, "the ramp took {} s", t - dt);
    // Commands: clamped to the trained ranges, reached at the configured rate.
    c.set_command([9.0, 0.0, -9.0]);
    for _ in 0..200 {
        t += s.control_period_s;
        c.tick(&frame(t)).ok();
    }
    let got = c.command();
    assert_eq!((got[0], got[2]), (s.command_ranges[0][1], s.command_ranges[2][0]));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_controller_files_are_one_clear_error_each() {
    let dir = tempdir("bad");
    topa_tools::controller_export::export(Path::new("assets/policies/CA/seed1.json"), &dir).unwrap();
    let json = dir.join("controller.json");
    let good = std::fs::read_to_string(&json).unwrap();
    std::fs::write(&json, good.replacen("\"robot\"", "\"robt\"", 1)).unwrap();
    let e = Controller::load(&dir).err().unwrap().to_string();
    assert!(e.contains("controller.json") && e.contains("export it again"), "{e}");
    std::fs::write(&json, good.replacen("\"history\": 0", "\"history\": 2", 1)).unwrap();
    let e = Controller::load(&dir).err().unwrap().to_string();
    assert!(e.contains("observation"), "{e}");
    std::fs::write(&json, &good).unwrap();
    let w = dir.join("policy.safetensors");
    let mut bytes = std::fs::read(&w).unwrap();
    let k = bytes.len() - 5;
    bytes[k] ^= 0x11;
    std::fs::write(&w, bytes).unwrap();
    let e = Controller::load(&dir).err().unwrap().to_string();
    assert!(e.contains("policy.safetensors") && e.contains("checksum"), "{e}");
    let e = Controller::load(&dir.join("missing")).err().unwrap().to_string();
    assert!(e.contains("missing"), "{e}");
    std::fs::remove_dir_all(dir).ok();
}

/// The loop a robot's driver runs: a driver whose sensors go silent gets damping within three periods, and every
/// period gets a command.
#[test]
fn through_the_driver_loop_a_silent_robot_is_damped_within_three_periods() {
    use topa_control::driver::{run_period, Driver, Readings};
    struct Fake {
        t: f64,
        pos: Vec<f64>,
        silent_from: f64,
        sent: Vec<Mode>,
    }
    impl Driver for Fake {
        fn now(&self) -> f64 {
            self.t
        }
        fn read(&mut self, r: &mut Readings) -> bool {
            r.timestamp_s = self.t;
            r.motor_pos.copy_from_slice(&self.pos);
            r.base_velocity = Some([0.0; 3]);
            self.t < self.silent_from
        }
        fn send(&mut self, c: &topa_control::MotorCommand) {
            self.sent.push(c.mode);
        }
    }
    let dir = tempdir("driver");
    let mut c = controller(Path::new("assets/policies/CA/seed1.json"), &dir);
    let dt = c.spec().control_period_s;
    let pos: Vec<f64> = c.spec().motors.iter().map(|m| m.nominal).collect();
    let mut d = Fake { t: 0.0, pos, silent_from: 50.5 * dt, sent: Vec::new() };
    let mut r = Readings::new(c.spec().n_motors());
    c.start();
    for k in 0..60 {
        d.t = k as f64 * dt;
        run_period(&mut c, &mut d, &mut r);
    }
    assert_eq!(d.sent.len(), 60, "a command every period");
    assert_eq!(d.sent[50], Mode::Policy);
    let damped = d.sent.iter().position(|m| *m == Mode::Damping(Fault::Stale)).unwrap();
    assert!((52..=54).contains(&damped), "damping {} periods after the last frame", damped - 50);
    std::fs::remove_dir_all(dir).ok();
}
