//! The velocity-free policy with a concurrent estimator (`[env.observation] base_velocity = "estimated"`): the
//! estimator learns the base velocity beside PPO, a resumed run continues bit for bit, the policy file acts on the
//! actor's inputs alone, and the ONNX graph (estimator inside) reproduces it.

use std::path::{Path, PathBuf};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use topa_env::policy_runner::PolicyRunner;
use topa_eval::settings::{EvalSettings, Sim2SimMode};
use topa_eval::velocity;
use tract_onnx::prelude::*;
use trainer::policy_file::Policy;

mod common;

const RUN: &str = r#"
[run]
num_envs = 32
steps_per_env = 24
iterations = 16
threads = 1
checkpoint_every = 4
keep_checkpoints = 0

[ppo]
minibatches = 2

[network]
actor_hidden = [32, 32]
critic_hidden = [32, 32]
estimator_hidden = [32]

[env]
robot = "assets/robots/topa_closed.toml"

[env.observation]
base_velocity = "estimated"
history = 2
"#;

fn tempdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("topa-estimator-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A column of the run's metrics, one value per iteration.
fn column(run: &Path, name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(run.join("metrics.csv")).unwrap();
    let mut lines = text.lines();
    let col = lines.next().unwrap().split(',').position(|c| c == name).expect("the column");
    lines.map(|l| l.split(',').nth(col).unwrap().parse().unwrap()).collect()
}

#[test]
fn the_estimator_learns_the_velocity_and_ships_inside_the_policy() {
    let dir = tempdir("run");
    let config = dir.join("estimated.toml");
    std::fs::write(&config, RUN).unwrap();
    let run = dir.join("run");
    common::cli_train(Some(&config), &run, false, None);

    // It learns: its squared error in normalised units (the velocity's spread is 1 there, so an estimator that
    // knew nothing would score about 1) falls to a fraction of that; the error in m/s is logged beside it.
    let (loss, rmse) = (column(&run, "policy_estimator_loss"), column(&run, "policy_estimator_rmse"));
    assert_eq!(loss.len(), 16);
    eprintln!("estimator MSE (normalised): {loss:.3?}\nRMSE, m/s: {rmse:.3?}");
    let last = loss[13..].iter().sum::<f64>() / 3.0;
    assert!(loss[0] > 0.5 && last < 0.5 * loss[0], "the estimator's normalised MSE went from {} to {last}", loss[0]);
    assert!(rmse.iter().all(|r| r.is_finite() && *r > 0.0));

    // A run resumed from its iteration-8 checkpoint ends with the same policy and estimator, bit for bit.
    let resumed = dir.join("resumed");
    copy_dir(&run, &resumed);
    let ck = resumed.join("checkpoints");
    for late in ["ckpt_0000012", "ckpt_0000016"] {
        for ext in ["json", "safetensors"] {
            std::fs::remove_file(ck.join(format!("{late}.{ext}"))).unwrap();
        }
    }
    std::fs::write(ck.join("latest.json"), r#"{"sidecar": "ckpt_0000008.json", "iteration": 8}"#).unwrap();
    common::cli_train(None, &resumed, true, None);
    assert_eq!(
        std::fs::read(run.join("policy.safetensors")).unwrap(),
        std::fs::read(resumed.join("policy.safetensors")).unwrap(),
        "the resumed run's policy file"
    );

    // The policy file: the actor reads the row up to the privileged velocity, whatever that holds.
    let mut p = Policy::load(&run.join("policy.json")).unwrap();
    let view = p.view().clone();
    assert_eq!((view.inputs, view.estimate.clone()), (39 + 2 * 36, Some(111..114)));
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let rows = 64;
    let obs: Vec<f32> = (0..rows * view.obs_dim).map(|_| rng.random_range(-1.5f32..1.5)).collect();
    let mut other = obs.clone();
    for r in other.chunks_exact_mut(view.obs_dim) {
        r[111..].iter_mut().for_each(|v| *v = rng.random_range(-50.0f32..50.0));
    }
    let (mut a, mut b) = (Vec::new(), Vec::new());
    p.act(&obs, &mut a);
    let estimate = p.estimate().unwrap();
    assert_eq!(estimate.len(), rows * 3);
    p.act(&other, &mut b);
    assert_eq!(a, b, "the privileged values are not read");

    // ONNX: one graph from the actor's inputs to the action, the estimator inside; tract agrees within 1e-5.
    let onnx = dir.join("estimated.onnx");
    let (width, n) = topa_tools::export::export(&run.join("policy.json"), &onnx, false).unwrap();
    assert_eq!((width, n), (view.inputs, 10));
    let inputs: Vec<f32> = obs.chunks_exact(view.obs_dim).flat_map(|r| r[..view.inputs].to_vec()).collect();
    let model = tract_onnx::onnx()
        .model_for_path(&onnx)
        .unwrap()
        .with_input_fact(0, f32::fact([rows, width]).into())
        .unwrap()
        .into_optimized()
        .unwrap()
        .into_runnable()
        .unwrap();
    let input: Tensor = tract_ndarray::Array2::from_shape_vec((rows, width), inputs).unwrap().into();
    let out = model.run(tvec!(input.into())).unwrap();
    let onnx_actions: Vec<f32> = out[0].to_plain_array_view::<f32>().unwrap().iter().copied().collect();
    let worst = a.iter().zip(&onnx_actions).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    assert!(worst < 1e-5, "ONNX and topa differ by {worst}");
    topa_tools::export::check(&onnx, &run.join("policy.json")).unwrap();

    // On a walk in the realistic sim2sim, the learned estimate and the Kalman filter's are both measured against
    // the truth; the policy does not read the filter, so a filter with other parameters sees the very same walk.
    let mut runner = PolicyRunner::load(&run.join("policy.json"), "estimated").unwrap();
    let realistic = EvalSettings::default().with_sim2sim(&Sim2SimMode::Realistic).unwrap();
    let a = velocity::run(&mut runner, &realistic, 4.0, 1.0).unwrap();
    let (learned, filter) = (a.learned.unwrap(), a.filter.unwrap());
    assert!(a.steps > 0 && learned.horizontal.is_finite() && filter.horizontal > 0.0, "{a:?}");
    assert_ne!(learned, filter);
    let mut other = realistic.clone();
    other.sim2sim.estimator.filter.q_velocity *= 10.0;
    let b = velocity::run(&mut runner, &other, 4.0, 1.0).unwrap();
    assert_eq!((a.walk_checksum, a.learned), (b.walk_checksum, b.learned), "the same walk, the same estimate");
    assert_ne!(a.filter, b.filter, "another filter's error on it");
    // A policy that reads the velocity has no estimate of its own.
    let mut shipped = PolicyRunner::load(Path::new("assets/policies/C/seed1.json"), "C").unwrap();
    assert_eq!(velocity::run(&mut shipped, &realistic, 1.0, 1.0).unwrap().learned, None);
    // Several policies with a second filter (`--tuned-filter`): its column is that filter on the same walk; a policy
    // that reads the filter walks differently under it and is refused, naming it.
    let load = |p: &std::path::PathBuf| -> topa_eval::Result<PolicyRunner> { Ok(PolicyRunner::load(p, "p")?) };
    let tuned = std::path::PathBuf::from("tuned.toml");
    let free = [run.join("policy.json")];
    let r = velocity::run_policies(&free, load, &realistic, Some((&tuned, &other)), 4.0, 1.0).unwrap();
    assert_eq!((r.rows[0].walk.learned, r.rows[0].second), (a.learned, b.filter));
    assert!(velocity::report_markdown(&r).contains("| Kalman filter, tuned.toml |"));
    let fed = [std::path::PathBuf::from("assets/policies/C/seed1.json")];
    let err = velocity::run_policies(&fed, load, &realistic, Some((&tuned, &other)), 2.0, 1.0).unwrap_err();
    assert!(err.to_string().contains("C/seed1.json") && err.to_string().contains("reads the"), "{err}");
    std::fs::remove_dir_all(dir).ok();
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}
