//! ONNX export, checked by an independent runtime (tract): for every bundled policy, the exported model's
//! actions (and motor targets) equal our own forward pass on 1 000 observations, recorded and random; corrupt or
//! mismatched files give one clear error.

use std::path::{Path, PathBuf};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use topa::N_MOTORS;
use topa_env::policy_runner::PolicyRunner;
use topa_env::ModelKind;

#[path = "../topa-env/tests/reference/topa.rs"]
mod topa;

use topa_env::{assets, RobotEnv, Task};
use topa_eval::settings::EvalSettings;
use tract_onnx::prelude::*;

fn policy(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/policies").join(format!("{name}.json"))
}

fn tempdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("topa-export-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// 500 observations of the C policy walking under changing commands, then 500 random ones.
fn observations() -> Vec<f32> {
    let mut runner = PolicyRunner::load(&policy("C/seed1"), "C").unwrap();
    let cfg = EvalSettings::default().env_config(&runner).unwrap();
    let mut env =
        RobotEnv::new(assets::load_model(ModelKind::Closed).unwrap(), std::sync::Arc::new(cfg), 1, 0).unwrap();
    let mut obs = vec![0.0f32; 42];
    env.reset(&mut obs).unwrap();
    let mut out = Vec::new();
    let mut act = Vec::new();
    for k in 0..500 {
        env.set_command_override(Some([
            0.5 * ((k / 100) as f64 - 2.0) / 2.0,
            0.0,
            if k % 200 < 100 { 0.5 } else { -0.5 },
        ]));
        runner.act(&obs, &mut act);
        env.step(&act, &mut obs);
        out.extend_from_slice(&obs);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    out.extend((0..500 * 42).map(|_| rng.random_range(-2.0f32..2.0)));
    out
}

fn run_onnx(path: &Path, obs: &[f32]) -> Vec<Vec<f32>> {
    run_onnx_dim(path, obs, 42)
}

fn run_onnx_dim(path: &Path, obs: &[f32], dim: usize) -> Vec<Vec<f32>> {
    let rows = obs.len() / dim;
    let model = tract_onnx::onnx()
        .model_for_path(path)
        .unwrap()
        .with_input_fact(0, f32::fact([rows, dim]).into())
        .unwrap()
        .into_optimized()
        .unwrap()
        .into_runnable()
        .unwrap();
    let input: Tensor = tract_ndarray::Array2::from_shape_vec((rows, dim), obs.to_vec()).unwrap().into();
    let out = model.run(tvec!(input.into())).unwrap();
    out.iter().map(|t| t.to_plain_array_view::<f32>().unwrap().iter().copied().collect()).collect()
}

#[test]
fn onnx_matches_our_forward_pass_for_every_bundled_policy() {
    let dir = tempdir("match");
    let obs = observations();
    let rows = obs.len() / 42;
    let seeds = ["O/seed1", "O/seed2", "C/seed1", "C/seed2", "C/seed3", "CA/seed1", "CA/seed2", "CA/seed3"];
    for name in seeds {
        let file = dir.join(format!("{}.onnx", name.replace('/', "_")));
        topa_tools::export::export(&policy(name), &file, true).unwrap();
        topa_tools::export::check(&file, &policy(name)).unwrap();
        let out = run_onnx(&file, &obs);
        // Ours: the evaluation's runner (motor space in and out, O mapped through M).
        let mut runner = PolicyRunner::load(&policy(name), name).unwrap();
        let mut ours = Vec::new();
        runner.act(&obs, &mut ours);
        let worst = out[0].iter().zip(&ours).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(worst <= 1e-5, "{name}: actions differ by {worst}");
        // Motor targets: nominal + scale · clip(action), clamped to the motor range — what the env sends.
        let meta = &runner.policy.meta;
        let nominal = runner.nominal_motors().to_vec();
        let range: Vec<[f64; 2]> = runner.robot().motors.iter().map(|m| m.motor_range).collect();
        let mut worst_t = 0.0f32;
        for r in 0..rows {
            for i in 0..N_MOTORS {
                let a = (ours[r * N_MOTORS + i] as f64).clamp(-meta.action_clip, meta.action_clip);
                let t = (nominal[i] + meta.action_scale * a).clamp(range[i][0], range[i][1]) as f32;
                worst_t = worst_t.max((out[1][r * N_MOTORS + i] - t).abs());
            }
        }
        assert!(worst_t <= 1e-5, "{name}: motor targets differ by {worst_t}");
        eprintln!("{name}: max |ONNX − ours| = {worst:.2e} (actions), {worst_t:.2e} (motor targets) on {rows} rows");
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn corrupt_or_mismatched_files_are_one_clear_error() {
    let dir = tempdir("bad");
    let file = dir.join("C.onnx");
    topa_tools::export::export(&policy("C/seed1"), &file, false).unwrap();
    // Exported from another policy.
    let err = topa_tools::export::check(&file, &policy("O/seed1")).unwrap_err().to_string();
    assert!(err.contains("was not exported from") && err.lines().count() == 1, "{err}");
    // Truncated.
    let bytes = std::fs::read(&file).unwrap();
    let cut = dir.join("cut.onnx");
    std::fs::write(&cut, &bytes[..bytes.len() / 3]).unwrap();
    let err = format!("{:#}", anyhow::Error::from(topa_tools::export::read(&cut).unwrap_err()));
    assert!(err.contains("is not an ONNX model") && err.contains("topa export"), "{err}");
    // Not ONNX at all.
    let junk = dir.join("junk.onnx");
    std::fs::write(&junk, b"{\"hello\": 1}").unwrap();
    assert!(topa_tools::export::read(&junk).is_err());
    // A corrupt policy cannot be exported.
    let copy = dir.join("p");
    std::fs::create_dir_all(&copy).unwrap();
    for ext in ["json", "safetensors"] {
        std::fs::copy(policy("C/seed1").with_extension(ext), copy.join(format!("seed1.{ext}"))).unwrap();
    }
    let w = copy.join("seed1.safetensors");
    let mut b = std::fs::read(&w).unwrap();
    let n = b.len();
    b[n - 5] ^= 0xff;
    std::fs::write(&w, b).unwrap();
    let err = topa_tools::export::export(&copy.join("seed1.json"), &dir.join("x.onnx"), false).unwrap_err().to_string();
    assert!(err.contains("corrupt"), "{err}");
    assert!(!dir.join("x.onnx").exists());
    std::fs::remove_dir_all(dir).ok();
}

/// A second robot exports with its own layout (Kestrel: 12 motors, 48 observations), motor order, stand pose and
/// ranges — from its spec and MJCF, no code of its own — and the model equals our forward pass.
#[test]
fn a_second_robot_exports_with_its_own_layout() {
    let dir = tempdir("kestrel");
    let file = dir.join("kestrel.onnx");
    let src = policy("kestrel/seed1");
    topa_tools::export::export(&src, &file, true).unwrap();
    let model = topa_tools::export::read(&file).unwrap();
    let meta = |k: &str| model.metadata_props.iter().find(|p| p.key == k).map(|p| p.value.clone()).unwrap();
    assert_eq!(meta("robot"), "kestrel");
    let order: Vec<String> = serde_json::from_str(&meta("motor_order")).unwrap();
    assert_eq!(order.len(), 12);
    assert_eq!((order[4].as_str(), order[5].as_str()), ("l_ankle_out", "l_ankle_in"));
    let mut runner = PolicyRunner::load(&src, "kestrel").unwrap();
    let dim = runner.layout().dim();
    assert_eq!(dim, 48);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let obs: Vec<f32> = (0..200 * dim).map(|_| rng.random_range(-2.0f32..2.0)).collect();
    let out = run_onnx_dim(&file, &obs, dim);
    let mut ours = Vec::new();
    runner.act(&obs, &mut ours);
    let worst = out[0].iter().zip(&ours).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    assert!(worst <= 1e-5, "actions differ by {worst}");
    // Motor targets at a zero action are the robot's stand pose (its cranks, not its joints).
    let nominal = runner.nominal_motors().to_vec();
    let meta_nominal: Vec<f64> = serde_json::from_str(&meta("nominal_motor_positions_rad")).unwrap();
    assert_eq!(meta_nominal, nominal);
    assert!((nominal[5] - (-0.35)).abs() < 1e-3, "inner crank at the stand: {}", nominal[5]);
    std::fs::remove_dir_all(dir).ok();
}

/// `topa export` names the graph's shapes from the robot's own layout (Kestrel: 48 observations, 12 motors).
#[test]
fn the_export_message_gives_the_robots_own_shapes() {
    let dir = tempdir("message");
    let onnx = dir.join("k.onnx");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_topa"))
        .args(["export", "--policy"])
        .arg(policy("kestrel/seed1"))
        .arg("--onnx")
        .arg(&onnx)
        .arg("--motor-targets")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}{}", String::from_utf8_lossy(&out.stderr));
    assert!(text.contains("obs[batch, 48] → action[batch, 12], motor_targets[batch, 12]"), "{text}");
    std::fs::remove_dir_all(dir).ok();
}
