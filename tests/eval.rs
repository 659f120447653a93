//! Sim2sim evaluation: metrics on known trajectories, scripted policies with known behaviour, the push grid's
//! forces and frame, seeded noise runs, open-policy mapping, and MCAP recordings read back.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use candle_core::{Device, Tensor};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use topa as topa_ref;
use topa::N_MOTORS;
use topa_env::policy_runner::PolicyRunner;
use topa_env::ModelKind;

#[path = "../topa-env/tests/reference/topa.rs"]
mod topa;

use topa_env::{assets, EnvConfig, RobotEnv, Task};
use topa_eval::play::PlayOptions;
use topa_eval::settings::EvalSettings;
use topa_eval::{noise, push, results, tracking};
use trainer::nn::Mlp;
use trainer::normalizer::Normalizer;
use trainer::policy_file::{self, PolicyMeta, Provenance};
use trainer::TrainConfig;

fn tempdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("topa-eval-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A policy file whose action is the constant `action` (zero weights, output bias = action), trained "on" `model`.
fn constant_policy(dir: &Path, name: &str, model: ModelKind, action: [f32; N_MOTORS]) -> PathBuf {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mlp = Mlp::new(&[42, 8, 10], &mut rng).unwrap();
    for l in &mlp.layers {
        l.weight.set(&l.weight.as_tensor().zeros_like().unwrap()).unwrap();
    }
    mlp.layers[1].bias.set(&Tensor::new(&action, &Device::Cpu).unwrap()).unwrap();
    let mut cfg = TrainConfig::default();
    let env = EnvConfig { robot: model.spec_path().into(), ..EnvConfig::default() };
    cfg.env = env.to_table();
    let meta = PolicyMeta {
        format: policy_file::FORMAT.into(),
        version: policy_file::VERSION,
        robot: Some(model.spec_path().into()),
        obs_dim: 42,
        action_dim: 10,
        hidden: vec![8],
        activation: Default::default(),
        action_scale: env.action_scale,
        action_clip: env.action_clip,
        policy_dt: env.policy_dt(),
        actor_view: None,
        estimator_hidden: None,
        weights: String::new(),
        weights_crc32: 0,
        provenance: Provenance {
            command: "test".into(),
            config: cfg,
            seed: 0,
            iterations: 0,
            samples: 0,
            wall_time_s: 0.0,
            with_adversary: false,
            trained_on: "test".into(),
            segments: vec![],
            averaged_iterations: vec![],
        },
    };
    policy_file::save(&dir.join(name), &mlp, None, &Normalizer::new(42, None), meta).unwrap()
}

/// The action that sends the closed model's keyframe targets (nominal pose + gravity compensation): it stands.
fn hold_action() -> [f32; N_MOTORS] {
    let m = assets::load_model(ModelKind::Closed).unwrap();
    let key = m.id(mujoco::ObjType::Key, topa_ref::STAND_KEY).unwrap();
    let nominal = topa_ref::nominal_motors();
    let scale = EnvConfig::default().action_scale;
    std::array::from_fn(|i| ((m.key_ctrl(key)[i] - nominal[i]) / scale) as f32)
}

/// Knee motors to the top of their range, ankles following: the robot folds down.
fn crouch_action() -> [f32; N_MOTORS] {
    let mut a = [0.0f32; N_MOTORS];
    for leg in 0..2 {
        a[leg * 5 + topa_ref::KNEE] = 6.0;
        a[leg * 5 + topa_ref::ANKLE] = 6.0;
    }
    a
}

fn quick() -> EvalSettings {
    EvalSettings { settle_s: 1.0, ..EvalSettings::default() }
}

#[test]
fn tracking_metrics_on_hand_made_trajectories() {
    let mut acc = tracking::TrackingAccumulator::default();
    // Commanded (0.5, 0, 0); measured v_x alternates 0.4 / 0.6, v_y 0.1, w_z −0.2; torques sum to 10 and 30.
    for k in 0..100 {
        let vx = if k % 2 == 0 { 0.4 } else { 0.6 };
        let tau = if k % 2 == 0 { [1.0; 10] } else { [-3.0; 10] };
        acc.add([0.5, 0.0, 0.0], [vx, 0.1, 0.0], [0.0, 0.0, -0.2], &tau, 0.02, -0.04);
    }
    let m = acc.finish();
    for (got, want) in m.components.iter().zip([0.1, 0.1, 0.2]) {
        assert!((got - want).abs() < 1e-12, "{m:?}");
    }
    assert!((m.mae() - (0.1 + 0.1 + 0.2) / 3.0).abs() < 1e-12, "{m:?}");
    assert!((m.torque - 20.0).abs() < 1e-12);
    assert!((m.roll - 0.02).abs() < 1e-12 && (m.pitch + 0.04).abs() < 1e-12);
    assert!(tracking::TrackingAccumulator::default().finish().mae().is_nan());
    assert!((m.velocity[0] - 0.5).abs() < 1e-12 && (m.velocity[2] + 0.2).abs() < 1e-12, "{m:?}");
    // Along the command it moves at the commanded speed: it walks. Turning at w_z = 1.0 it would stand still, and
    // so would a robot moving backwards against the command; a zero command or an empty window never counts.
    assert!(!m.stood_still([0.5, 0.0, 0.0]));
    assert!(m.stood_still([0.0, 0.0, 1.0]));
    assert!(m.stood_still([-0.5, 0.0, 0.0]));
    assert!(!m.stood_still([0.0; 3]));
    assert!(!tracking::TrackingAccumulator::default().finish().stood_still([0.5, 0.0, 0.0]));
}

#[test]
fn a_commands_row_is_the_mean_over_its_starts_with_falls_and_stand_stills_counted() {
    // Three starts of a 1 rad/s turn: one turns at 0.9 rad/s, one stands still, one turns and falls at 6 s.
    let start = |w: f64, fell_at: Option<f64>| {
        let mut acc = tracking::TrackingAccumulator::default();
        for _ in 0..10 {
            acc.add([0.0, 0.0, 1.0], [0.0; 3], [0.0, 0.0, w], &[2.0; 10], 0.0, 0.1);
        }
        tracking::StartResult { ours: acc.finish(), whole: acc.finish(), gait: Default::default(), fell_at }
    };
    let starts = [start(0.9, None), start(0.02, None), start(0.8, Some(6.0))];
    let row = tracking::combine("rotate_ccw", [0.0, 0.0, 1.0], &starts);
    assert!((row.mae_whole[2] - (0.1 + 0.98 + 0.2) / 3.0).abs() < 1e-12, "{row:?}");
    assert!((row.mae_paper - row.mae_whole.iter().sum::<f64>()).abs() < 1e-12);
    assert!((row.mean_torque - 20.0).abs() < 1e-12 && (row.mean_pitch - 0.1).abs() < 1e-12);
    assert_eq!((row.starts, row.falls, row.stood_still, row.fell, row.fell_at), (3, Some(1), Some(1), true, Some(6.0)));
    let one = tracking::combine("rotate_ccw", [0.0, 0.0, 1.0], &starts[..1]);
    assert_eq!((one.falls, one.stood_still, one.fell), (Some(0), Some(0), false));
    assert!((one.mae_whole[2] - 0.1).abs() < 1e-12);
    // Counted over several rows in runs (command × start); a row from a report that did not count stand-stills
    // leaves them unknown, its fall counted from `fell`.
    let n = results::RunCounts::of([&row, &one]);
    assert_eq!((n.falls_cell(), n.still_cell()), ("1/4".to_string(), "1/4".to_string()));
    let old = results::TrackingRow { starts: 1, falls: None, stood_still: None, ..row.clone() };
    let n = results::RunCounts::of([&row, &old]);
    assert_eq!((n.runs, n.falls, n.still_cell()), (4, 2, "–".to_string()));
}

#[test]
fn scripted_policies_behave_as_known() {
    let dir = tempdir("scripted");
    // Zero action = the bare nominal motor targets: without gravity compensation the knees sag a little and the
    // robot stands, leaning forward by the sag, tracking nothing.
    let zero = constant_policy(&dir, "zero", ModelKind::Closed, [0.0; N_MOTORS]);
    let mut r = PolicyRunner::load(&zero, "zero").unwrap();
    let rows = tracking::run(&mut r, &quick(), 4.0, 1.0, 2).unwrap();
    for row in &rows {
        assert!(!row.fell && row.mean_pitch > 0.03 && row.mean_pitch < 0.2, "zero action stands, leaning: {row:?}");
    }
    // Folding the knees to their stop drops the torso: every command ends in a fall.
    let crouch = constant_policy(&dir, "crouch", ModelKind::Closed, crouch_action());
    let mut r = PolicyRunner::load(&crouch, "crouch").unwrap();
    let rows = tracking::run(&mut r, &quick(), 4.0, 1.0, 2).unwrap();
    assert!(rows.iter().all(|row| row.falls == Some(2)), "a crouching policy falls from every start: {rows:?}");
    for row in &rows {
        // The paper-comparable error goes on over the robot on the floor: each component's error is about its
        // command's magnitude, and their sum about the command's L1 norm.
        let l1: f64 = row.command.iter().map(|c| c.abs()).sum();
        assert!(row.mae_paper > 0.8 * l1 && row.mae_paper < l1 + 0.3, "fallen: sum ≈ ‖c‖₁ = {l1}: {row:?}");
        assert!(row.mean_pitch.abs() > 0.2 || row.mean_roll.abs() > 0.2, "averaged over the fallen robot: {row:?}");
    }
    // Holding the keyframe targets stands for the whole window on every command, without tracking it.
    let hold = constant_policy(&dir, "hold", ModelKind::Closed, hold_action());
    let mut r = PolicyRunner::load(&hold, "hold").unwrap();
    let rows = tracking::run(&mut r, &quick(), 4.0, 1.0, 2).unwrap();
    for row in &rows {
        assert!(!row.fell, "{row:?}");
        assert_eq!((row.starts, row.falls, row.stood_still), (2, Some(0), Some(2)), "it stands from both starts");
        let expected = (row.command[0].abs() + row.command[1].abs() + row.command[2].abs()) / 3.0;
        assert!((row.mae - expected).abs() < 0.02, "standing still, MAE = mean |command|: {row:?}");
        assert!(row.mean_roll.abs() < 0.01 && row.mean_pitch.abs() < 0.02);
        assert!(row.mean_torque > 5.0, "holding the pose takes torque: {row:?}");
        let g = &row.gait;
        assert_eq!(g.steps_per_s, 0.0, "standing takes no steps: {g:?}");
        assert!(g.double_support > 0.99 && (g.base_height_m - 0.56).abs() < 0.02, "{g:?}");
        assert!(g.slip_per_stance_m < 0.005, "a standing foot does not slide: {g:?}");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn push_grid_has_the_papers_cells_and_a_standing_robot_scores_the_window() {
    let ax = push::axis(30.0, 5.0).unwrap();
    assert_eq!(ax.len(), 13);
    assert_eq!((ax[0], ax[6], ax[12]), (-30.0, 0.0, 30.0));
    let cells = push::cells(&ax);
    assert_eq!(cells.len(), 169);
    assert_eq!(cells[0], [-30.0, -30.0]);
    assert_eq!(cells[1], [-25.0, -30.0], "F_x varies fastest");
    assert_eq!(cells[168], [30.0, 30.0]);
    assert!(push::axis(30.0, 7.0).is_err());
    let dir = tempdir("push");
    let hold = constant_policy(&dir, "hold", ModelKind::Closed, hold_action());
    let mut r = PolicyRunner::load(&hold, "hold").unwrap();
    // No force at all (range 0): nothing falls, so t_fall is the whole window.
    let g = push::run(&mut r, &quick(), 0.0, 5.0, 3.0, [0.0; 3]).unwrap();
    assert_eq!(g.t_fall, vec![3.0]);
    assert_eq!(g.mean_t_fall(), 3.0);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_forward_push_accelerates_the_torso_along_its_own_x() {
    let mut cfg = EnvConfig::default().for_evaluation();
    cfg.episode_length_s = 100.0;
    let mut env = RobotEnv::new(assets::load_model(ModelKind::Closed).unwrap(), Arc::new(cfg), 1, 0).unwrap();
    let mut obs = vec![0.0f32; 42];
    env.reset(&mut obs).unwrap();
    // Turn the robot to face world +y (yaw 90°), so torso +x and world +x differ.
    let b = env.indices().base_qpos;
    let (c, s) = ((std::f64::consts::FRAC_PI_4).cos(), (std::f64::consts::FRAC_PI_4).sin());
    env.data_mut().qpos_mut()[b + 3..b + 7].copy_from_slice(&[c, 0.0, 0.0, s]);
    env.data_mut().qvel_mut().iter_mut().for_each(|v| *v = 0.0);
    env.refresh(&mut obs).unwrap();
    let mut p = *env.perturbation();
    p.torso_force_local = [30.0, 0.0, 0.0];
    env.set_perturbation_struct(p);
    let hold = hold_action();
    for _ in 0..10 {
        env.step(&hold, &mut obs);
    }
    let d = env.data();
    let v_world = [d.qvel()[env.indices().base_dof], d.qvel()[env.indices().base_dof + 1]];
    let s = env.robot_state();
    assert!(s.lin_vel[0] > 0.05, "torso-frame forward velocity {}", s.lin_vel[0]);
    assert!(
        v_world[1] > 0.05 && v_world[1] > 5.0 * v_world[0].abs(),
        "world velocity {v_world:?} should point along +y"
    );
}

#[test]
fn noise_runs_are_seeded_and_success_is_counted_right() {
    assert_eq!(noise::success_pct(&[None, Some(1.0), None, None]), (3, 75.0));
    assert_eq!(noise::success_pct(&[Some(0.0), Some(2.0)]), (0, 0.0));
    // Each run's noise stream is fixed by (seed, level, run) and differs between runs and seeds.
    let draw = |seed, l, r| {
        let mut g = noise::stream(seed, l, r);
        (0..6).map(|_| trainer::actor_critic::standard_normal(&mut g)).collect::<Vec<_>>()
    };
    assert_eq!(draw(5, 1, 2), draw(5, 1, 2));
    assert_ne!(draw(5, 1, 2), draw(5, 1, 3));
    assert_ne!(draw(5, 1, 2), draw(6, 1, 2));
    let dir = tempdir("noise");
    // Through the whole pipeline: a robot that holds its pose (ignoring the commands) never falls, one that
    // crouches always does.
    let hold = constant_policy(&dir, "hold", ModelKind::Closed, hold_action());
    let zero = constant_policy(&dir, "crouch", ModelKind::Closed, crouch_action());
    let run = |p: &Path, seed: u64| {
        let mut r = PolicyRunner::load(p, "p").unwrap();
        noise::run(&mut r, &EvalSettings { seed, ..quick() }, 3, 2.0, 0.5).unwrap()
    };
    let rows = run(&hold, 5);
    assert_eq!(rows.len(), 4);
    assert!(rows.iter().all(|r| r.runs == 3 && r.successes == 3 && r.success_pct == 100.0), "{rows:?}");
    assert_eq!(rows, run(&hold, 5));
    assert!(run(&zero, 5).iter().all(|r| r.successes == 0 && r.success_pct == 0.0));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn open_policies_are_mapped_through_m() {
    // joint → motor → joint is exact to 1e-12.
    let q: [f64; N_MOTORS] = std::array::from_fn(|i| 0.37 * i as f64 - 1.1);
    let back = topa_ref::motor_to_joint(&topa_ref::joint_to_motor(&q));
    assert!(q.iter().zip(back).all(|(a, b)| (a - b).abs() < 1e-12));
    // An open-model policy's joint-space action comes out in motor space: a_m = M⁻¹ a_j.
    let dir = tempdir("open");
    let aj: [f32; N_MOTORS] = std::array::from_fn(|i| 0.1 * (i as f32 + 1.0));
    let p = constant_policy(&dir, "open", ModelKind::Open, aj);
    let mut r = PolicyRunner::load(&p, "O").unwrap();
    assert_eq!((r.trained_on(), r.robot().name.as_str()), ("topa_open", "topa_closed"));
    let mut out = Vec::new();
    r.act(&[0.0; 42], &mut out);
    let back = topa_ref::motor_to_joint(&std::array::from_fn::<f32, N_MOTORS, _>(|i| out[i]));
    for i in 0..N_MOTORS {
        assert!((back[i] - aj[i]).abs() < 1e-6, "{i}: {} vs {}", back[i], aj[i]);
    }
    assert!(
        (out[topa_ref::ANKLE] - (aj[topa_ref::KNEE] + aj[topa_ref::ANKLE])).abs() < 1e-6,
        "ankle motor = knee + ankle"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn a_policy_file_that_cannot_drive_topa_is_refused() {
    let dir = tempdir("refuse");
    let p = constant_policy(&dir, "ok", ModelKind::Closed, [0.0; N_MOTORS]);
    let mut meta: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    meta.as_object_mut().unwrap().remove("robot");
    std::fs::write(&p, serde_json::to_string(&meta).unwrap()).unwrap();
    let err = PolicyRunner::load(&p, "x").err().unwrap().to_string();
    assert!(err.contains("does not name the robot"), "{err}");
    meta["robot"] = serde_json::json!("a_robot_of_someone_else");
    std::fs::write(&p, serde_json::to_string(&meta).unwrap()).unwrap();
    let err = PolicyRunner::load(&p, "x").err().unwrap().to_string();
    assert!(err.contains("a_robot_of_someone_else"), "{err}");
    meta["robot"] = serde_json::json!("assets/robots/topa_closed.toml");
    meta["activation"] = serde_json::json!("relu");
    std::fs::write(&p, serde_json::to_string(&meta).unwrap()).unwrap();
    let err = format!("{:#}", anyhow::Error::from(PolicyRunner::load(&p, "x").err().unwrap()));
    assert!(err.contains("relu") && err.contains("elu"), "{err}");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn mcap_recording_reads_back_with_the_expected_channels() {
    let dir = tempdir("mcap");
    let hold = constant_policy(&dir, "hold", ModelKind::Closed, hold_action());
    let path = dir.join("run.mcap");
    let o = PlayOptions { command: [0.3, 0.0, 0.0], seconds: 1.0, record: Some(path.clone()), ..Default::default() };
    let s = topa_eval::play::run(&hold, &o, &EvalSettings { settle_s: 0.5, ..Default::default() }).unwrap();
    assert!(!s.fell);
    let bytes = std::fs::read(&path).unwrap();
    let mut counts = std::collections::BTreeMap::<String, usize>::new();
    let mut schemas = std::collections::BTreeMap::<String, String>::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        *counts.entry(m.channel.topic.clone()).or_default() += 1;
        if let Some(sc) = &m.channel.schema {
            schemas.insert(m.channel.topic.clone(), sc.name.clone());
        }
        let _: serde_json::Value = serde_json::from_slice(&m.data).expect("JSON messages");
    }
    let steps = 1 + ((0.5 + 1.0) / 0.02_f64).round() as usize;
    let nbody = assets::load_model(ModelKind::Closed).unwrap().nbody();
    assert_eq!(schemas["/tf"], "foxglove.FrameTransform");
    assert_eq!(schemas["/scene"], "foxglove.SceneUpdate");
    assert_eq!(counts["/scene"], 1);
    assert_eq!(counts["/tf"], steps * (nbody - 1));
    for topic in ["/joints", "/motors", "/base", "/command", "/contacts", "/rewards"] {
        assert_eq!(counts[topic], steps, "{topic}");
    }
    // A run that ends in a fall is still a complete, readable file.
    let zero = constant_policy(&dir, "crouch", ModelKind::Closed, crouch_action());
    let fall_path = dir.join("fall.mcap");
    let o = PlayOptions { seconds: 10.0, record: Some(fall_path.clone()), ..Default::default() };
    let s = topa_eval::play::run(&zero, &o, &EvalSettings::default()).unwrap();
    assert!(s.fell);
    let bytes = std::fs::read(&fall_path).unwrap();
    let n = mcap::MessageStream::new(&bytes).unwrap().count();
    assert!(n > 0);
    assert!(
        mcap::read::Summary::read(&bytes).unwrap().is_some(),
        "the file has its summary section (finished cleanly)"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn the_bundled_closed_chain_policy_takes_real_steps() {
    let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/policies/C/seed1.json"));
    let mut r = PolicyRunner::load(path, "C").unwrap();
    let rows = tracking::run(&mut r, &EvalSettings::default(), 6.0, 2.0, 2).unwrap();
    for row in &rows {
        let g = &row.gait;
        assert_eq!((row.falls, row.stood_still), (Some(0), Some(0)), "it walks off from both starts: {row:?}");
        assert!((g.seconds - 8.0).abs() < 0.1, "gait over the window after the transient, both starts: {g:?}");
        assert!(g.steps_per_s > 1.0 && g.steps_per_s < 6.0, "{}: walking means stepping: {g:?}", row.key);
        assert!(g.air_time_s > 0.04 && g.air_time_s < 0.6 && g.clearance_m > 0.005, "{}: {g:?}", row.key);
        assert!(g.double_support < 0.6, "{}: feet alternate: {g:?}", row.key);
        // Both error definitions agree for a robot that walks all along, up to the transient they differ by.
        assert!((row.mae_paper - row.mae_whole.iter().sum::<f64>()).abs() < 1e-12);
        assert!(row.mae_paper < 0.6 && row.mae < 0.2, "{}: it tracks: {row:?}", row.key);
    }
}

#[test]
fn every_shipped_policy_loads_with_its_own_weights() {
    // A sidecar names its weights file; moving a policy (`git mv`) without rewriting that name leaves a policy
    // that cannot load, so every shipped pair is checked: same stem, checksum, shapes, robot spec.
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "json" || x == "safetensors") {
                out.push(p);
            }
        }
    }
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/policies"));
    let mut files = Vec::new();
    walk(root, &mut files);
    let sidecars: Vec<&PathBuf> = files.iter().filter(|p| p.extension().unwrap() == "json").collect();
    for p in &files {
        let pair = p.with_extension(if p.extension().unwrap() == "json" { "safetensors" } else { "json" });
        assert!(pair.exists(), "{} has no {}", p.display(), pair.display());
    }
    for p in &sidecars {
        let r = PolicyRunner::load(p, "shipped").unwrap_or_else(|e| panic!("{}: {e:#}", p.display()));
        let stem = p.file_stem().unwrap().to_string_lossy();
        let weights = &r.policy.meta.weights;
        assert_eq!(weights, &format!("{stem}.safetensors"), "{}: the sidecar names another file", p.display());
    }
    for group in ["O", "C", "CA"] {
        let n = sidecars.iter().filter(|p| p.parent() == Some(&root.join(group))).count();
        assert!(n >= 2, "assets/policies/{group}/ holds the group's seeds ({n} found)");
    }
}

/// A 4 m course along +y from (2, 3): a robot must be put at the start facing along the path to make progress.
const SHORT_COURSE: &str = r#"
name = "short"
path = [[2.0, 3.0], [2.0, 7.0]]
[materials.tiles]
friction = 0.45
[[floor]]
material = "tiles"
min = [0.0, 1.0]
max = [4.0, 9.0]
[[threshold]]
at_m = 2.0
height = 0.01
"#;

#[test]
fn a_walking_policy_drives_a_course_and_a_standing_one_is_helped_until_time_runs_out() {
    use topa_eval::course;
    let map = topa_env::course::Course::parse(SHORT_COURSE).unwrap();
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/policies/CA/seed1.json"));
    let mut r = PolicyRunner::load(path, "CA").unwrap();
    let res = course::run(&mut r, &map, &EvalSettings::default(), &[0.5], None).unwrap();
    let run = &res.runs[0];
    assert!(run.finished && run.clean(), "{run:?}");
    // 4 m less the goal radius at up to 0.5 m/s, plus starting off.
    assert!(run.time_s > 7.0 && run.time_s < 14.0, "{run:?}");
    assert!(run.max_off_path_m < 0.3 && run.progress_m > 3.4, "{run:?}");
    assert_eq!(res.best_clean_time(), Some(run.time_s));

    let dir = tempdir("course");
    let stand = constant_policy(&dir, "stand", ModelKind::Closed, hold_action());
    let mut r = PolicyRunner::load(&stand, "stand").unwrap();
    let res = course::run(&mut r, &map, &EvalSettings::default(), &[0.5], None).unwrap();
    let run = &res.runs[0];
    let limit = 4.0 * 4.0 / 0.5 + 120.0;
    assert!(!run.finished && (run.time_s - limit).abs() < 0.05, "{run:?}");
    assert_eq!(run.stuck, (limit / course::STUCK_S).floor() as usize - usize::from(limit % course::STUCK_S < 0.05));
    assert_eq!((run.falls, run.wall_contacts), (0, 0), "{run:?}");
    assert!(res.best_clean_time().is_none());
    // A speed the policy was never commanded is refused before anything runs.
    let err = course::run(&mut r, &map, &EvalSettings::default(), &[0.9], None).unwrap_err().to_string();
    assert!(err.contains("0.9") && err.contains("command range"), "{err}");
}

#[test]
fn an_endurance_run_counts_each_fall_with_its_cause() {
    use topa_eval::endurance::{self, Operator};
    let dir = tempdir("endurance");
    let crouch = constant_policy(&dir, "crouch", ModelKind::Closed, crouch_action());
    let mut r = PolicyRunner::load(&crouch, "crouch").unwrap();
    let runs = endurance::run(&mut r, &EvalSettings::default(), 0.5, 1, &Operator::default()).unwrap();
    let e = &runs[0];
    assert!(e.interventions >= 3, "a folding robot falls again after every restart: {e:?}");
    assert_eq!(e.interventions, e.during_push + e.during_turn + e.during_walk + e.during_stand);
    assert!(e.minutes_to_first < 0.1, "{e:?}");
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/policies/CA/seed1.json"));
    let mut r = PolicyRunner::load(path, "CA").unwrap();
    let op = Operator { push_every_s: [10.0, 12.0], ..Operator::default() };
    let runs = endurance::run(&mut r, &EvalSettings::default(), 1.0, 2, &op).unwrap();
    for e in &runs {
        assert!((4..=5).contains(&e.pushes), "a push every 10–12 s in a minute: {e:?}");
        assert!(e.distance_m > 3.0, "the operator drives it around: {e:?}");
    }
    assert_ne!(runs[0], runs[1], "each run has its own operator");
}

#[test]
fn a_single_policys_tables_print_the_papers_value_for_its_group_beside_ours() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_topa"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["eval", "tracking", "--policy", "assets/policies/C/seed1.json", "--starts", "1", "--seconds", "1"])
        .args(["--threads", "1", "--out"])
        .arg(tempdir("paper-beside"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    // Walk forward, C: the paper's summed MAE 0.76 (fell) and τ̄ 23.18 N·m (data/paper_tables.toml).
    let row = text.lines().find(|l| l.starts_with("| C |")).expect("a row named after the policy's group");
    assert!(row.contains("(0.76*)") && row.contains("(23.18)"), "{row}");
}
