//! The TopA training environment and the batched VecEnv: observation layout, symmetry, determinism,
//! randomisation, pushes, divergence handling, and the tiny cart-pole task.

use std::path::Path;
use std::sync::Arc;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use topa::{OBS_COMMAND, OBS_DIM, OBS_GRAVITY, OBS_LAST_ACTION, OBS_Q};
use topa_env::tasks::{cartpole, CartPole};

#[path = "common/robot_env.rs"]
mod robot_env;
#[path = "reference/topa.rs"]
mod topa;
use robot_env::{env, mirror_into, quiet, snapshot_round_trip};

use topa_env::{assets, BatchEnv, EnvConfig, ModelKind, RobotEnv, Task, VecEnv};

#[test]
fn observation_layout_at_the_stand_pose() {
    for kind in [ModelKind::Closed, ModelKind::Open] {
        let mut e = env(quiet(kind), 1);
        let mut obs = vec![f32::NAN; OBS_DIM];
        e.reset(&mut obs).unwrap();
        assert_eq!(e.obs_dim(), 42);
        assert_eq!(e.action_dim(), 10);
        // Upright: gravity reads (0, 0, −1) in the robot frame.
        assert!(obs[OBS_GRAVITY].abs() < 1e-6 && obs[OBS_GRAVITY + 1].abs() < 1e-6, "{:?}", &obs[6..9]);
        assert!((obs[OBS_GRAVITY + 2] + 1.0).abs() < 1e-6);
        // Motor positions are offsets from the nominal pose: zero in the stand keyframe.
        assert!(obs[OBS_Q..OBS_Q + 10].iter().all(|q| q.abs() < 1e-6), "{:?}", &obs[OBS_Q..OBS_Q + 10]);
        assert!(obs[OBS_LAST_ACTION..OBS_LAST_ACTION + 10].iter().all(|&a| a == 0.0));
        let c = e.command();
        assert_eq!(&obs[OBS_COMMAND..], &[c[0] as f32, c[1] as f32, c[2] as f32]);
        // The action just applied is the next observation's "previous action".
        let a: Vec<f32> = (0..10).map(|i| 0.01 * i as f32).collect();
        e.step(&a, &mut obs);
        assert_eq!(&obs[OBS_LAST_ACTION..OBS_LAST_ACTION + 10], &a[..]);
    }
}

#[test]
fn standing_still_earns_the_tracking_and_posture_terms() {
    let mut cfg = quiet(ModelKind::Closed);
    cfg.rewards.scale_by_dt = false;
    let mut e = env(cfg.clone(), 2);
    let mut obs = vec![0.0; OBS_DIM];
    e.reset(&mut obs).unwrap();
    e.set_command_override(Some([0.0; 3]));
    // The action that sends the keyframe's holding targets (nominal pose plus gravity compensation).
    let m = e.data().model();
    let key = e.indices().stand_key;
    let nominal = topa::nominal_actuated(ModelKind::Closed);
    let hold: Vec<f32> = (0..10).map(|i| ((m.key_ctrl(key)[i] - nominal[i]) / cfg.action_scale) as f32).collect();
    for _ in 0..50 {
        let out = e.step(&hold, &mut obs);
        assert!(!out.done);
    }
    // Keep the same action once more, so the action-rate term is exactly zero.
    e.step(&hold, &mut obs);
    let names = e.term_names();
    let t = e.terms();
    let term = |n: &str| t[names.iter().position(|x| *x == n).unwrap()];
    // Holding still on command zero: each tracking kernel ≈ exp(0) = 1, times its weight.
    assert!((term("lin_vel_xy_tracking") - 3.0).abs() < 0.05, "{}", term("lin_vel_xy_tracking"));
    assert!((term("ang_vel_z_tracking") - 1.5).abs() < 0.02);
    for (name, w) in
        [("orientation", 1.0), ("body_height", 1.0), ("hip_roll_deviation", 0.5), ("hip_yaw_deviation", 0.5)]
    {
        assert!(term(name) > 0.97 * w, "{name} = {} (weight {w})", term(name));
    }
    assert_eq!(term("action_rate"), 0.0);
    assert_eq!(term("joint_position_limits"), 0.0);
    assert_eq!(term("feet_air_time"), 0.0, "no touchdown while standing");
}

/// Steps a robot and its mirror image with mirrored actions and commands (and, given them, an adversary's
/// perturbation on each); returns the largest difference between the mirrored observation of the one and the
/// observation of the other. The maps are the env's own (derived from the robot's spec).
fn mirror_equivariance(robot: &str, perturbations: Option<([f32; 12], [f32; 12])>) -> f32 {
    let mut cfg = quiet(ModelKind::Closed);
    cfg.robot = robot.into();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut a = env(cfg.clone(), 3);
    let mut b = env(cfg, 4);
    let sym = a.symmetry().unwrap();
    let (n, dim) = (a.action_dim(), a.obs_dim());
    let (mut oa, mut ob) = (vec![0.0; dim], vec![0.0; dim]);
    a.reset(&mut oa).unwrap();
    b.reset(&mut ob).unwrap();
    let cmd = [0.3, 0.2, 0.5];
    a.set_command_override(Some(cmd));
    b.set_command_override(Some([cmd[0], -cmd[1], -cmd[2]]));
    if let Some((p_a, p_b)) = perturbations {
        a.set_perturbation(&p_a);
        b.set_perturbation(&p_b);
    }
    // Drive A into an asymmetric, physically consistent state.
    for _ in 0..10 {
        let act: Vec<f32> = (0..n).map(|_| rng.random_range(-0.5..0.5)).collect();
        a.step(&act, &mut oa);
    }
    let mut worst: f32 = 0.0;
    for _ in 0..5 {
        mirror_into(&a, &mut b, &mut ob);
        let act: Vec<f32> = (0..n).map(|_| rng.random_range(-0.5..0.5)).collect();
        let mut act_m = vec![0.0; n];
        sym.act.apply(&act, &mut act_m);
        // Same previous action on both sides of the mirror.
        a.step(&act, &mut oa);
        b.step(&act_m, &mut ob);
        let mut expect = vec![0.0; dim];
        sym.obs.apply(&oa, &mut expect);
        for i in 0..dim {
            worst = worst.max((expect[i] - ob[i]).abs());
        }
    }
    eprintln!("{robot}: max |S_o(o') − o'(S state, S_a a)| = {worst:.2e}");
    worst
}

#[test]
fn closed_model_dynamics_are_mirror_equivariant() {
    assert_eq!(env(quiet(ModelKind::Closed), 1).symmetry(), Some(topa::symmetry()));
    let worst = mirror_equivariance("assets/robots/topa_closed.toml", None);
    assert!(worst < 1e-3, "mirrored dynamics differ by {worst}: a sign in S_o/S_a or the model is wrong");
}

#[test]
fn a_mirrored_perturbation_on_the_mirrored_robot_gives_the_mirrored_motion() {
    // Every channel at once: a command offset, a tilted IMU, and a different force on each foot, each with a
    // sideways part (the values the mirror changes).
    let p = [0.2, 0.15, -0.2, 0.05, 0.08, -0.03, 6.0, 9.0, -4.0, -3.0, -12.0, 5.0];
    let mirror = env(quiet(ModelKind::Closed), 1).perturbation_mirror().unwrap();
    assert!(mirror.is_involution());
    let mut p_m = [0.0; 12];
    mirror.apply(&p, &mut p_m);
    let robot = "assets/robots/topa_closed.toml";
    let worst = mirror_equivariance(robot, Some((p, p_m)));
    assert!(worst < 1e-3, "the perturbation's mirror is not the world's: differences up to {worst}");
    // The same perturbation on both sides breaks the mirror image.
    let unmirrored = mirror_equivariance(robot, Some((p, p)));
    assert!(unmirrored > 1e-2, "an unmirrored perturbation kept the mirror image ({unmirrored})");
}

#[test]
fn the_second_robots_dynamics_are_mirror_equivariant() {
    let worst = mirror_equivariance("assets/robots/kestrel.toml", None);
    assert!(worst < 1e-3, "Kestrel's mirrored dynamics differ by {worst}: a mirror sign in its spec is wrong");
}

fn rollout(threads: usize, seed: u64, steps: usize) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let cfg = EnvConfig::default();
    let mut v = topa_env::vec_env::robot_batch(&cfg, 6, seed, threads).unwrap();
    v.reset().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let (mut obs, mut rew, mut done) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..steps {
        let act: Vec<f32> = (0..6 * 10).map(|_| rng.random_range(-1.0..1.0)).collect();
        v.step(&act).unwrap();
        obs.extend_from_slice(v.obs());
        rew.extend_from_slice(v.rewards());
        done.extend_from_slice(v.dones());
    }
    (obs, rew, done)
}

#[test]
fn a_seed_fixes_the_rollout_whatever_the_thread_count() {
    let one = rollout(1, 5, 60);
    let two = rollout(2, 5, 60);
    assert!(one == two, "1 and 2 threads must give identical rollouts");
    let other = rollout(2, 6, 60);
    assert!(one.0 != other.0, "different seeds must differ");
}

#[test]
fn a_parked_env_stands_still_and_the_others_go_on_unchanged() {
    let cfg = EnvConfig::default();
    let run = |park: bool| {
        let mut v = topa_env::vec_env::robot_batch(&cfg, 3, 7, 2).unwrap();
        v.reset().unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut frozen = None;
        for k in 0..40 {
            if park && k == 10 {
                v.set_parked(1, true);
                frozen = Some((v.obs()[OBS_DIM..2 * OBS_DIM].to_vec(), v.tasks()[1].robot_state().base_pos));
            }
            let act: Vec<f32> = (0..3 * 10).map(|_| rng.random_range(-1.0..1.0)).collect();
            v.step(&act).unwrap();
        }
        (v.obs().to_vec(), v.tasks()[1].robot_state().base_pos, v.rewards()[1], frozen)
    };
    let (all, moved, _, _) = run(false);
    let (parked, still, reward, frozen) = run(true);
    let (obs_then, pos_then) = frozen.unwrap();
    assert_eq!(still, pos_then, "a parked env's robot must not move");
    assert_ne!(moved, pos_then, "unparked, the same robot moves");
    assert_eq!(parked[OBS_DIM..2 * OBS_DIM], obs_then[..], "a parked env's observation stands still");
    assert_eq!(reward, 0.0);
    assert_eq!(all[..OBS_DIM], parked[..OBS_DIM], "the other envs are bit-identical");
    assert_eq!(all[2 * OBS_DIM..], parked[2 * OBS_DIM..]);
}

#[test]
fn domain_randomisation_stays_within_its_ranges() {
    let mut cfg = EnvConfig::default();
    cfg.domain_rand.mass_scale = [0.9, 1.1];
    cfg.domain_rand.friction_scale = [0.75, 1.25];
    let model = assets::load_model(ModelKind::Closed).unwrap();
    let nominal_mass = model.body_mass().to_vec();
    let nominal_friction: Vec<f64> = model.geom_friction().iter().map(|f| f[0]).collect();
    let mut e = RobotEnv::new(model, Arc::new(cfg), 11, 0).unwrap();
    let mut obs = vec![0.0; OBS_DIM];
    let (mut lo, mut hi) = (f64::MAX, f64::MIN);
    for _ in 0..20 {
        e.reset(&mut obs).unwrap();
        let m = e.data().model();
        for (b, (&x, &n)) in m.body_mass().iter().zip(&nominal_mass).enumerate().skip(1) {
            let s = x / n;
            assert!((0.9 - 1e-12..=1.1 + 1e-12).contains(&s), "body {b} mass scale {s}");
            lo = lo.min(s);
            hi = hi.max(s);
        }
        let floor = e.indices().floor_geom;
        let fs = m.geom_friction()[floor][0] / nominal_friction[floor];
        assert!((0.75 - 1e-12..=1.25 + 1e-12).contains(&fs), "friction scale {fs}");
        let foot = e.indices().foot_geoms[0];
        assert!((m.geom_friction()[foot][0] / nominal_friction[foot] - fs).abs() < 1e-12, "soles scale like the floor");
        assert!((m.total_mass() - m.body_subtreemass()[0]).abs() < 1e-9, "mj_setConst ran after the change");
    }
    assert!(lo < 0.92 && hi > 1.08, "the whole range is used: [{lo}, {hi}]");
}

#[test]
fn the_torso_com_and_contact_damping_ranges_are_drawn_per_episode_and_off_by_default() {
    let model = assets::load_model(ModelKind::Closed).unwrap();
    let torso = RobotEnv::new(model.clone(), Arc::new(EnvConfig::default()), 3, 0).unwrap().indices().torso_body;
    let (ipos, solref) = (model.body_ipos()[torso], model.geom_solref().to_vec());
    let mut obs = vec![0.0; OBS_DIM];
    // Off (the paper's randomisation only): the torso's CoM and every solref stay the MJCF's.
    let mut e = RobotEnv::new(model.clone(), Arc::new(EnvConfig::default()), 3, 0).unwrap();
    e.reset(&mut obs).unwrap();
    assert_eq!(e.data().model().body_ipos()[torso], ipos);
    assert_eq!(e.data().model().geom_solref(), &solref[..]);
    let mut cfg = EnvConfig::default();
    cfg.domain_rand.torso_com_offset = [0.02, 0.01, 0.0];
    cfg.domain_rand.contact_damping_ratio = [0.3, 1.0];
    let mut e = RobotEnv::new(model, Arc::new(cfg), 3, 0).unwrap();
    let (mut seen_x, mut seen_z) = (Vec::new(), Vec::new());
    for _ in 0..20 {
        e.reset(&mut obs).unwrap();
        let m = e.data().model();
        let d = [0, 1, 2].map(|k| m.body_ipos()[torso][k] - ipos[k]);
        assert!(d[0].abs() <= 0.02 && d[1].abs() <= 0.01 && d[2] == 0.0, "CoM shift {d:?}");
        let z = m.geom_solref()[0][1];
        assert!((0.3..=1.0).contains(&z), "damping ratio {z}");
        assert!(m.geom_solref().iter().zip(&solref).all(|(r, n)| r[0] == n[0] && r[1] == z), "one ratio, time kept");
        seen_x.push(d[0]);
        seen_z.push(z);
    }
    let spread = |v: &[f64]| v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min);
    assert!(spread(&seen_x) > 0.02 && spread(&seen_z) > 0.4, "draws differ between episodes");
    let mut bad = EnvConfig::default();
    bad.domain_rand.contact_damping_ratio = [-0.1, 1.0];
    assert!(bad.validate().unwrap_err().to_string().contains("contact_damping_ratio"));
}

#[test]
fn a_latency_range_draws_each_episodes_delay_within_it() {
    let mut cfg = quiet(ModelKind::Closed);
    cfg.sim2sim.latency.action_physics_steps = 1;
    cfg.sim2sim.latency.action_physics_steps_max = 4;
    cfg.validate().unwrap();
    let mut e = env(cfg.clone(), 5);
    let mut obs = vec![0.0; OBS_DIM];
    let mut delays = std::collections::BTreeSet::new();
    for _ in 0..30 {
        e.reset(&mut obs).unwrap();
        delays.insert(e.sim2sim().unwrap().action_delay_steps());
    }
    assert_eq!(delays.into_iter().collect::<Vec<_>>(), vec![1, 2, 3, 4]);
    cfg.sim2sim.latency.action_physics_steps_max = 0; // a fixed delay
    let mut e = env(cfg.clone(), 5);
    e.reset(&mut obs).unwrap();
    assert_eq!(e.sim2sim().unwrap().action_delay_steps(), 1);
    cfg.sim2sim.latency.action_physics_steps = 6;
    cfg.sim2sim.latency.action_physics_steps_max = 4;
    assert!(cfg.validate().unwrap_err().to_string().contains("action_physics_steps_max"));
}

#[test]
fn pushes_kick_the_base_by_the_configured_speed() {
    let mut pushed = quiet(ModelKind::Closed);
    pushed.push =
        topa_env::config::PushConfig { enabled: true, velocity: [1.0, 1.0], interval_s: 0.02, ..Default::default() };
    let mut a = env(pushed, 21);
    let mut b = env(quiet(ModelKind::Closed), 21);
    let (mut oa, mut ob) = (vec![0.0; OBS_DIM], vec![0.0; OBS_DIM]);
    a.reset(&mut oa).unwrap();
    b.reset(&mut ob).unwrap();
    let zero = [0.0f32; 10];
    a.step(&zero, &mut oa);
    b.step(&zero, &mut ob);
    let dof = a.indices().base_dof;
    let (va, vb) = (a.data().qvel(), b.data().qvel());
    let kick = (va[dof] - vb[dof]).hypot(va[dof + 1] - vb[dof + 1]);
    assert!((kick - 1.0).abs() < 1e-9, "push of {kick} m/s, configured 1.0");
    assert_eq!(va[dof + 2], vb[dof + 2], "pushes are horizontal");
}

#[test]
fn a_diverging_env_is_reset_and_counted_without_disturbing_the_batch() {
    let cfg = quiet(ModelKind::Closed);
    let run = |sabotage: bool| {
        let mut v = topa_env::vec_env::robot_batch(&cfg, 4, 3, 2).unwrap();
        v.reset().unwrap();
        if sabotage {
            // An absurd force on env 2's feet: the simulation blows up within a step.
            let mut p = vec![0.0f32; 4 * 12];
            p[2 * 12 + 8] = 1e30;
            v.set_perturbations(&p).unwrap();
        }
        let act = vec![0.1f32; 40];
        for _ in 0..3 {
            v.step(&act).unwrap();
        }
        (v.obs().to_vec(), v.take_episode_stats())
    };
    let (clean, _) = run(false);
    let (dirty, stats) = run(true);
    assert!(stats.diverged >= 1, "the blow-up must be counted: {stats:?}");
    assert!(dirty.iter().all(|x| x.is_finite()), "the reset env observes finite values");
    for env_i in [0, 1, 3] {
        assert_eq!(&clean[env_i * 42..(env_i + 1) * 42], &dirty[env_i * 42..(env_i + 1) * 42], "env {env_i}");
    }
}

#[test]
fn a_model_too_small_for_its_contacts_stops_the_batch_with_the_fix() {
    // TopA with room for 4 contacts: standing on two box soles needs 8. MuJoCo would drop the rest silently.
    let dir = assets::mjcf_dir();
    let xml = std::fs::read_to_string(dir.join("topa_closed.xml")).unwrap();
    let small = xml.replace(
        "<include file=\"common/sensors.xml\"/>",
        "<include file=\"common/sensors.xml\"/>\n  <size nconmax=\"4\"/>",
    );
    let model = Arc::new(mujoco::Model::from_xml_string(&small, &dir).unwrap());
    assert_eq!(model.nconmax(), 4);
    let mut v = topa_env::vec_env::robot_batch_on(model, &quiet(ModelKind::Closed), 2, 1, 1).unwrap();
    let err = (|| -> Result<(), trainer::vec_env::EnvFailure> {
        v.reset()?;
        for _ in 0..50 {
            v.step(&[0.0; 20])?;
        }
        Ok(())
    })()
    .expect_err("8 contacts cannot fit in 4");
    let msg = err.to_string();
    assert!(msg.contains("nconmax") && msg.contains("<size>"), "{msg}");
}

#[test]
fn cartpole_random_policy_falls_quickly() {
    let model = cartpole::model().unwrap();
    let tasks = (0..16).map(|i| CartPole::new(model.clone(), 1, i, 200, 1.0).unwrap()).collect();
    let mut v = BatchEnv::new(tasks, 1).unwrap();
    v.reset().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for _ in 0..400 {
        let act: Vec<f32> = (0..16).map(|_| rng.random_range(-1.0..1.0)).collect();
        v.step(&act).unwrap();
    }
    let s = v.take_episode_stats();
    assert!(s.episodes > 50, "{s:?}");
    assert!(s.mean_length < 60.0, "a random policy should not balance: {s:?}");
    assert_eq!(s.time_out_share, 0.0);
}

#[test]
fn snapshot_restore_continues_bit_for_bit() {
    let mut with_estimator = EnvConfig::default();
    with_estimator.sim2sim.estimator.enabled = true;
    with_estimator.sim2sim.estimator.contact_threshold = 5.0;
    with_estimator.sim2sim.gyro =
        topa_env::sim2sim::sensors::NoiseConfig { enabled: true, white: 0.01, bias_initial: 0.01, bias_walk: 0.001 };
    with_estimator.sim2sim.latency.observation_policy_steps = 2;
    with_estimator.sim2sim.latency.action_physics_steps = 3;
    // Ranges drawn per episode: the latency, the torso's CoM, the contacts' damping.
    let mut ranged = EnvConfig::default();
    ranged.sim2sim.latency.action_physics_steps_max = 8;
    ranged.domain_rand.torso_com_offset = [0.02, 0.02, 0.0];
    ranged.domain_rand.contact_damping_ratio = [0.3, 1.0];
    for cfg in [EnvConfig::default(), with_estimator, ranged] {
        snapshot_round_trip(&cfg);
    }
}

/// The training preset (domain randomisation, pushes on a curriculum, observation noise) with an adversary's
/// perturbations on half the envs: a restored batch continues bit for bit (a resumed C+A run equals the straight
/// one). The foot forces are what an earlier snapshot missed: the forward pass after a restore read the fresh
/// env's own applied forces and rewrote the solver's warm start from them (1-ulp differences from the first step).
#[test]
fn snapshot_restore_under_the_training_preset_and_attack() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/cpu.toml");
    let cfg = EnvConfig::from_table(&trainer::config::TrainConfig::load(&path).unwrap().env).unwrap();
    let n = 8;
    let mut a = topa_env::vec_env::robot_batch(&cfg, n, 8, 1).unwrap();
    a.reset().unwrap();
    let pd = 12;
    let perturb = |k: usize| -> Vec<f32> {
        (0..n * pd).map(|i| if i / pd < n / 2 { 0.1 * (((i * 5 + k * 3) % 7) as f32 - 3.0) } else { 0.0 }).collect()
    };
    let act = |k: usize| -> Vec<f32> { (0..n * 10).map(|i| ((i * 7 + k * 13) % 11) as f32 / 11.0 - 0.5).collect() };
    for k in 0..30 {
        a.set_perturbations(&perturb(k)).unwrap();
        a.step(&act(k)).unwrap();
    }
    let snap = a.save_state();
    let mut b = topa_env::vec_env::robot_batch(&cfg, n, 12345, 1).unwrap();
    b.reset().unwrap();
    b.load_state(&snap).unwrap();
    for k in 30..200 {
        a.set_perturbations(&perturb(k)).unwrap();
        b.set_perturbations(&perturb(k)).unwrap();
        a.step(&act(k)).unwrap();
        b.step(&act(k)).unwrap();
        let diff = a.obs().iter().zip(b.obs()).position(|(x, y)| x != y);
        assert!(diff.is_none(), "step {k}: observation {diff:?} differs after the restore");
    }
}

/// The adversary's command offset, held (`command_hold_s`): the command the policy sees and is rewarded on takes
/// the adversary's new value only at the hold's boundaries, while its foot forces change at every step; without a
/// hold the command follows every step. A negative hold is refused with its key named.
#[test]
fn a_held_command_offset_changes_only_at_the_hold_boundaries() {
    let observe = |hold: f64| {
        let mut cfg = quiet(ModelKind::Closed);
        cfg.adversary.command_hold_s = hold;
        let mut e = env(cfg, 5);
        e.set_command_override(Some([0.2, 0.0, 0.0]));
        let mut obs = vec![0.0; OBS_DIM];
        e.reset(&mut obs).unwrap();
        let mut seen = vec![];
        for k in 0..12 {
            // A new offset and a new foot force at every step.
            let mut p = [0.0f32; 12];
            p[0] = 0.01 * (k + 1) as f32;
            p[8] = k as f32;
            e.set_perturbation(&p);
            assert_eq!(e.perturbation().foot_force[0][2], k as f64, "foot forces are never held");
            seen.push(e.command()[0]);
            e.step(&[0.0; 10], &mut obs);
            assert_eq!(obs[OBS_COMMAND] as f64, e.command()[0] as f32 as f64);
        }
        seen
    };
    let free = observe(0.0);
    for (k, c) in free.iter().enumerate() {
        assert!((c - (0.2 + 0.01 * (k + 1) as f64)).abs() < 1e-6, "step {k}: {c}");
    }
    // 0.1 s = 5 policy steps at 50 Hz: the offsets of steps 0, 5 and 10 are taken, the rest ignored.
    let held = observe(0.1);
    for (k, c) in held.iter().enumerate() {
        let taken = k - k % 5;
        assert!((c - (0.2 + 0.01 * (taken + 1) as f64)).abs() < 1e-6, "step {k}: {c}");
    }
    let mut bad = quiet(ModelKind::Closed);
    bad.adversary.command_hold_s = -0.5;
    let err = bad.validate().unwrap_err().to_string();
    assert!(err.contains("adversary.command_hold_s"), "{err}");
}

/// `pure_turns_in_place`: on a turn in place the adversary's linear command offset is dropped from what the policy
/// sees and is rewarded on (the yaw offset stays); other commands, standing included, take the whole offset.
#[test]
fn a_pure_turn_in_place_stays_one_under_attack() {
    let run = |pure: bool, command: [f64; 3]| {
        let mut cfg = quiet(ModelKind::Closed);
        cfg.rewards.scale_by_dt = false;
        cfg.adversary.pure_turns_in_place = pure;
        let mut e = env(cfg, 6);
        e.set_command_override(Some(command));
        let mut obs = vec![0.0; OBS_DIM];
        e.reset(&mut obs).unwrap();
        let mut p = [0.0f32; 12];
        p[..3].copy_from_slice(&[0.3, -0.2, 0.1]);
        e.set_perturbation(&p);
        e.step(&[0.0; 10], &mut obs);
        let seen: [f64; 3] = std::array::from_fn(|i| obs[OBS_COMMAND + i] as f64);
        let names = e.term_names();
        let lin = e.terms()[names.iter().position(|x| *x == "lin_vel_xy_tracking").unwrap()];
        (e.command(), seen, lin)
    };
    let near = |a: [f64; 3], b: [f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
    let (turn, seen, lin_pure) = run(true, [0.0, 0.0, -0.8]);
    assert!(near(turn, [0.0, 0.0, -0.7]), "{turn:?}");
    assert!(near(seen, turn), "observed {seen:?}");
    let (turn_off, _, lin_off) = run(false, [0.0, 0.0, -0.8]);
    assert!(near(turn_off, [0.3, -0.2, -0.7]), "{turn_off:?}");
    // A robot barely moving after one step tracks a zero linear command far better than (0.3, −0.2) m/s.
    assert!(lin_pure > 2.9 && lin_off < 0.8 * lin_pure, "lin_vel_xy_tracking {lin_pure} vs {lin_off}");
    for command in [[0.0; 3], [0.5, 0.0, 0.0], [0.0, 0.3, 0.6]] {
        let (c, _, _) = run(true, command);
        let want: [f64; 3] = std::array::from_fn(|i| command[i] + [0.3, -0.2, 0.1][i]);
        assert!(near(c, want), "{command:?}: {c:?}");
    }
}

/// The command mix: `standing_share` of the commands all zero, `turn_share` turning in place (no linear part, a
/// yaw rate inside its range), the rest drawn from the three ranges; shares summing past one are refused.
#[test]
fn commands_stand_turn_in_place_and_move_in_their_shares() {
    let mut cfg = quiet(ModelKind::Closed);
    cfg.commands.standing_share = 0.1;
    cfg.commands.turn_share = 0.3;
    let mut e = env(cfg, 3);
    let mut obs = vec![0.0; OBS_DIM];
    let n = 3000;
    let (mut standing, mut turning) = (0, 0);
    for _ in 0..n {
        e.reset(&mut obs).unwrap();
        let c = e.command();
        assert!(c[2].abs() <= 1.2, "{c:?}");
        match (c[0] == 0.0 && c[1] == 0.0, c[2] == 0.0) {
            (true, true) => standing += 1,
            (true, false) => turning += 1,
            _ => {}
        }
    }
    // Binomial sd at n = 3000: 0.0055 (standing), 0.0084 (turning); the bounds are ~3.6 and ~4.2 sd. Uniform
    // draws give a pure turn only when the linear norm falls under 0.05 m/s (< 0.6 % of them).
    let (s, t) = (standing as f64 / n as f64, turning as f64 / n as f64);
    assert!((s - 0.1).abs() < 0.02, "standing share {s}");
    assert!((t - 0.3).abs() < 0.035, "turn-in-place share {t}");
    let mut bad = quiet(ModelKind::Closed);
    bad.commands.standing_share = 0.5;
    bad.commands.turn_share = 0.6;
    let err = bad.validate().unwrap_err().to_string();
    assert!(err.contains("commands.turn_share") && err.contains("at most 1"), "{err}");
    bad.commands.turn_share = -0.1;
    let err = bad.validate().unwrap_err().to_string();
    assert!(err.contains("commands.turn_share must be in [0, 1], got -0.1"), "{err}");
}
