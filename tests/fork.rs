//! `--init-from` into a task with more inputs (a height scan added to a blind policy): the forked policy acts
//! exactly as its source whatever the new inputs hold, then learns to use them; sizes that do not add up are refused.

mod common;

use common::view::ObsView;
use common::{cartpole_config, cartpole_trainer};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use trainer::checkpoint;
use trainer::ppo::ActOutput;
use trainer::vec_env::VecEnv;
use trainer::Trainer;

/// The cart-pole with `extra` more observation values after its own, copies of its last one (so that a policy
/// has something to learn from them).
fn widened(inner: Box<dyn VecEnv>, extra: usize) -> ObsView {
    let d = inner.obs_dim();
    let widen = move |src: &[f32]| -> Vec<f32> {
        src.chunks_exact(d).flat_map(|r| r.iter().copied().chain(std::iter::repeat_n(r[d - 1], extra))).collect()
    };
    ObsView::new(inner, d + extra, Box::new(widen))
}

fn first_layer(t: &Trainer) -> Vec<f32> {
    t.policy.ac.actor.layers[0].weight.as_tensor().flatten_all().unwrap().to_vec1::<f32>().unwrap()
}

#[test]
fn a_policy_forked_with_added_inputs_acts_as_its_source_then_learns_them() {
    const EXTRA: usize = 3;
    let cfg = cartpole_config(5, 30);
    let mut source = cartpole_trainer(&cfg, false);
    for _ in 0..3 {
        source.iterate().unwrap();
    }
    let dir = std::env::temp_dir().join(format!("topa-fork-widen-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    checkpoint::save(&source, &dir, "test", 0).unwrap();
    let (side, loaded) = checkpoint::read_sidecar(&checkpoint::latest(&dir).unwrap()).unwrap();

    let mut forked =
        Trainer::new(cfg.clone(), Box::new(widened(cartpole_trainer(&cfg, false).env, EXTRA)), false).unwrap();
    let err = checkpoint::init_policy_from(&mut forked, &side, &loaded, 0).unwrap_err().to_string();
    assert!(err.contains("4→1") && err.contains("7→1"), "{err}");
    checkpoint::init_policy_from(&mut forked, &side, &loaded, EXTRA).unwrap();
    let (d, n) = (4, 64);

    // The file's statistics as they were; the added inputs' from the task's first observations, with their weight.
    let (src, norm) = (&source.policy.normalizer, &forked.policy.normalizer);
    assert_eq!((norm.count, &norm.mean[..d], &norm.m2[..d]), (src.count, &src.mean[..], &src.m2[..]));
    let first: Vec<f64> = forked.env.obs().chunks_exact(d + EXTRA).map(|r| r[d - 1] as f64).collect();
    let mean = first.iter().sum::<f64>() / first.len() as f64;
    let var = first.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / first.len() as f64;
    for k in d..d + EXTRA {
        assert!((norm.mean[k] - mean).abs() < 1e-9, "mean {} against {mean}", norm.mean[k]);
        assert!((norm.m2[k] / norm.count / var.max(1e-6) - 1.0).abs() < 1e-9, "variance {}", norm.m2[k] / norm.count);
    }

    // The same actions and values on any observation, whatever the added inputs hold.
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let obs: Vec<f32> = (0..n * d).map(|_| rng.random_range(-2.0..2.0)).collect();
    let wide: Vec<f32> = obs
        .chunks_exact(d)
        .flat_map(|r| r.iter().copied().chain((0..EXTRA).map(|_| rng.random_range(-50.0f32..50.0))).collect::<Vec<_>>())
        .collect();
    let act = |t: &mut Trainer, o: &[f32]| -> (Vec<f32>, Vec<f32>) {
        t.policy.normalizer.frozen = true;
        let (mut norm, mut a, mut m, mut lp, mut v) =
            (vec![0.0; o.len()], vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let out = ActOutput {
            obs_norm: &mut norm,
            actions: &mut a,
            means: &mut m,
            log_probs: &mut lp,
            values: &mut v,
            estimates: &mut [],
        };
        t.policy.act(o, &mut ChaCha8Rng::seed_from_u64(1), false, out).unwrap();
        t.policy.normalizer.frozen = false;
        (m, v)
    };
    let (ms, vs) = act(&mut source, &obs);
    let (mf, vf) = act(&mut forked, &wide);
    for (a, b) in ms.iter().zip(&mf).chain(vs.iter().zip(&vf)) {
        assert!((a - b).abs() <= 1e-5 * (1.0 + a.abs()), "source {a} vs forked {b}");
    }
    assert_eq!(forked.iteration, source.iteration);
    let w = first_layer(&forked);
    assert!(w.chunks_exact(d + EXTRA).all(|r| r[d..].iter().all(|&x| x == 0.0)), "added columns start at zero");

    // Training moves the added inputs' weights, by steps no larger than the others' (Adam's second moment).
    let before = first_layer(&forked);
    forked.iterate().unwrap();
    let w = first_layer(&forked);
    let step = |cols: std::ops::Range<usize>| -> f32 {
        let moved = w.chunks_exact(d + EXTRA).zip(before.chunks_exact(d + EXTRA));
        moved.flat_map(|(a, b)| cols.clone().map(move |j| (a[j] - b[j]).abs())).fold(0.0, f32::max)
    };
    let (old, new) = (step(0..d), step(d..d + EXTRA));
    assert!(new > 0.0, "the added columns did not move");
    assert!(new <= 1.5 * old, "the added columns moved by up to {new}, the others by up to {old}");
    std::fs::remove_dir_all(dir).ok();
}
