//! PPO end to end on the tiny cart-pole task: it learns, a seed fixes the run, and resume is exact.

mod common;

use common::{cartpole_config, cartpole_trainer};
use trainer::Trainer;

#[test]
fn ppo_learns_to_balance_the_cartpole() {
    let cfg = cartpole_config(1, 40);
    let mut t = cartpole_trainer(&cfg, false);
    let mut lengths = vec![];
    while let Some(log) = t.iterate().unwrap() {
        eprintln!(
            "iter {:>3} len {:>6.1} ret {:>6.1} kl {:.4} lr {:.2e}",
            log.iteration,
            log.episodes.mean_length,
            log.episodes.mean_return,
            log.policy.as_ref().unwrap().kl,
            log.policy.as_ref().unwrap().learning_rate
        );
        if log.episodes.episodes > 0 {
            lengths.push(log.episodes.mean_length);
        }
    }
    let first = lengths[0];
    let best = lengths.iter().cloned().fold(0.0, f64::max);
    assert!(first < 40.0, "a fresh policy should not balance yet ({first})");
    assert!(best > 150.0, "PPO did not learn: best mean episode length {best} (200 = whole episode)");
}

fn weights(t: &Trainer) -> Vec<Vec<f32>> {
    t.policy.ac.vars().iter().map(|v| v.as_tensor().flatten_all().unwrap().to_vec1::<f32>().unwrap()).collect()
}

fn tempdir(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("topa-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn checkpoint_then_resume_equals_the_straight_run_bit_for_bit() {
    let cfg = cartpole_config(3, 6);
    let mut straight = cartpole_trainer(&cfg, false);
    for _ in 0..6 {
        straight.iterate().unwrap();
    }
    let dir = tempdir("resume");
    let mut first = cartpole_trainer(&cfg, false);
    for _ in 0..3 {
        first.iterate().unwrap();
    }
    trainer::checkpoint::save(&first, &dir, "test", 2).unwrap();
    // Keep going on the original to make sure saving did not disturb it.
    drop(first);
    let side = trainer::checkpoint::latest(&dir).unwrap();
    let (meta, loaded) = trainer::checkpoint::read_sidecar(&side).unwrap();
    let mut resumed = cartpole_trainer(&meta.config, false);
    trainer::checkpoint::restore(&mut resumed, &meta, &loaded).unwrap();
    assert_eq!(resumed.iteration, 3);
    for _ in 0..3 {
        resumed.iterate().unwrap();
    }
    assert_eq!(weights(&resumed), weights(&straight), "resumed weights differ from the straight run");
    assert_eq!(resumed.policy.opt.state, straight.policy.opt.state);
    assert_eq!(resumed.policy.normalizer, straight.policy.normalizer);
    assert_eq!(resumed.env.obs(), straight.env.obs());
    assert_eq!(resumed.policy.lr, straight.policy.lr);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn an_entropy_decay_acts_on_the_updates_through_the_bonus_alone() {
    let run = |entropy: f64, end: f64, decay: usize| {
        let mut cfg = cartpole_config(5, 4);
        (cfg.ppo.entropy_coef, cfg.ppo.entropy_coef_end, cfg.ppo.entropy_decay_iterations) = (entropy, end, decay);
        let mut t = cartpole_trainer(&cfg, false);
        let mut after = Vec::new();
        for _ in 0..4 {
            t.iterate().unwrap();
            after.push(weights(&t));
        }
        after
    };
    let constant = run(0.05, 0.0, 0);
    assert_eq!(run(0.05, 0.05, 3), constant, "a decay to the same weight is the constant bonus, bit for bit");
    let decayed = run(0.05, 0.0, 1);
    assert_eq!(decayed[0], constant[0], "iteration 0 updates with the starting weight");
    assert_ne!(decayed[3], constant[3], "from iteration 1 the bonus is gone");
}

#[test]
fn a_corrupt_or_mismatched_checkpoint_is_a_clear_error() {
    let cfg = cartpole_config(4, 1);
    let mut t = cartpole_trainer(&cfg, false);
    t.iterate().unwrap();
    let dir = tempdir("corrupt");
    let side = trainer::checkpoint::save(&t, &dir, "test", 0).unwrap();
    let weights = dir.join("ckpt_0000001.safetensors");
    let mut bytes = std::fs::read(&weights).unwrap();
    let last = bytes.len() - 3;
    bytes[last] ^= 0xff;
    std::fs::write(&weights, &bytes).unwrap();
    let err = trainer::checkpoint::read_sidecar(&side).err().unwrap().to_string();
    assert!(err.contains("corrupt") && err.contains("ckpt_0000001.safetensors"), "{err}");
    bytes.truncate(bytes.len() / 2);
    std::fs::write(&weights, &bytes).unwrap();
    let err = format!("{:#}", trainer::checkpoint::read_sidecar(&side).err().unwrap());
    assert!(err.contains("corrupt or truncated"), "{err}");
    // A checkpoint for another batch size cannot be restored into this run.
    let mut other_cfg = cfg.clone();
    other_cfg.run.num_envs = 8;
    let mut fresh = cartpole_trainer(&cfg, false);
    trainer::checkpoint::save(&fresh, &dir, "test", 0).unwrap();
    let (meta, loaded) = trainer::checkpoint::read_sidecar(&trainer::checkpoint::latest(&dir).unwrap()).unwrap();
    let mut small = cartpole_trainer(&other_cfg, false);
    let err = trainer::checkpoint::restore(&mut small, &meta, &loaded).err().unwrap().to_string();
    assert!(err.contains("16 envs") && err.contains("8"), "{err}");
    fresh.iterate().unwrap();
    std::fs::remove_dir_all(dir).ok();
}
