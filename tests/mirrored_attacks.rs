//! `adversary.mirror_attacks`: the odd envs are attacked through the mirror, so robots that are each other's mirror
//! image meet attacks that are each other's mirror image; a task without the mirror is refused.

mod common;

use anyhow::Result;
use common::view::{Applied, ObsView};
use common::{cartpole_config, cartpole_trainer, set_push_bound};
use trainer::config::TrainConfig;
use trainer::Trainer;

/// One cycle of one iteration per phase; phase 3 attacks every env with the adversary's mean (deterministic).
fn config(mirror_attacks: bool) -> TrainConfig {
    let mut c = cartpole_config(3, 3);
    let a = &mut c.adversary;
    (a.phase1_policy_iters, a.phase2_adversary_iters, a.phase3_policy_iters, a.cycles) = (1, 1, 1, 1);
    a.hidden = vec![32, 32];
    (a.sample_when_frozen, a.attack_share, a.mirror_attacks) = (false, 1.0, mirror_attacks);
    set_push_bound(&mut c, 1.5);
    c
}

/// The cart-pole batch seen in pairs: each odd env observes the mirror image of the env before it (its current and
/// its terminal observation alike); `with_mirror`: the view gives the push's mirror.
fn paired_trainer(cfg: &TrainConfig, with_mirror: bool) -> Result<(Trainer, Applied)> {
    let inner = cartpole_trainer(cfg, false).env;
    let sym = inner.symmetry().unwrap();
    let d = sym.obs.len();
    let map = sym.obs.clone();
    let paired = move |src: &[f32]| -> Vec<f32> {
        let mut out = src.to_vec();
        for pair in out.chunks_exact_mut(2 * d) {
            let (even, odd) = pair.split_at_mut(d);
            map.apply(even, odd);
        }
        out
    };
    let mut env = ObsView::new(inner, d, Box::new(paired));
    env.symmetry = Some(sym);
    env.channels = env.inner().perturbation_channels();
    env.perturbation_mirror = env.inner().perturbation_mirror().filter(|_| with_mirror);
    let applied = env.applied.clone();
    Ok((Trainer::new(cfg.clone(), Box::new(env), true)?, applied))
}

/// Phase 3's perturbations (the last rollout's), as (even env, odd env) pairs, one per pair of envs and step.
fn phase3_pairs(cfg: &TrainConfig) -> Vec<(f32, f32)> {
    let (mut t, applied) = paired_trainer(cfg, true).unwrap();
    while t.iterate().unwrap().is_some() {}
    let applied = applied.lock().unwrap();
    let steps = cfg.run.steps_per_env;
    assert!(applied.len() >= steps);
    applied[applied.len() - steps..].iter().flat_map(|p| p.chunks_exact(2).map(|c| (c[0], c[1]))).collect()
}

#[test]
fn mirror_image_robots_meet_mirror_image_attacks() {
    let pairs = phase3_pairs(&config(true));
    assert!(pairs.iter().all(|&(even, _)| even != 0.0), "the adversary attacks every env");
    for (even, odd) in &pairs {
        assert_eq!(*odd, -*even, "the mirror image of a push on the pole is the opposite push");
    }
    // Without the mirror the adversary answers the mirror image with whatever it learned for it.
    let pairs = phase3_pairs(&config(false));
    assert!(pairs.iter().any(|&(even, odd)| odd != -even), "an unmirrored adversary happened to be odd");
}

#[test]
fn mirrored_attacks_need_the_tasks_perturbation_mirror() {
    let err = paired_trainer(&config(true), false).err().expect("refused").to_string();
    assert!(err.contains("mirror_attacks") && err.contains("set it to false"), "{err}");
    assert!(paired_trainer(&config(false), false).is_ok(), "no mirror needed without mirrored attacks");
}
