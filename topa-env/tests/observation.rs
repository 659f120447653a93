//! The observation's options beyond the paper (`[env.observation]`): no base velocity for the actor, or its
//! learned estimate; earlier frames of proprioception; the critic's privileged true velocity.

#[path = "common/robot_env.rs"]
mod robot_env;
#[path = "reference/topa.rs"]
mod topa;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robot_env::{env, mirror_into, quiet, snapshot_round_trip};
use topa_env::observation::{BaseVelocity, ObservationConfig};
use topa_env::{EnvConfig, ModelKind, Task};
use trainer::actor_view::ActorView;

/// The velocity-free observation with `history` earlier frames (`[env.observation]`).
fn velocity_free(base_velocity: BaseVelocity, history: usize) -> EnvConfig {
    let mut c = quiet(ModelKind::Closed);
    c.observation = ObservationConfig { base_velocity, history };
    c
}

#[test]
fn a_velocity_free_observation_carries_the_earlier_frames_newest_first() {
    let mut e = env(velocity_free(BaseVelocity::None, 3), 2);
    let frame = 6 + 3 * 10;
    let actor = 6 + 3 * 10 + 3 + 3 * frame;
    assert_eq!(e.obs_dim(), actor + 3, "ω, g, q, q̇, a, command, three frames, then the critic's true velocity");
    assert_eq!(e.actor_view(), ActorView { obs_dim: actor + 3, inputs: actor, estimate: None });
    let mut obs = vec![f32::NAN; e.obs_dim()];
    e.reset(&mut obs).unwrap();
    let current = |o: &[f32]| o[..frame].to_vec(); // the frame starts the row when the velocity is left out
    let hist = |o: &[f32], k: usize| o[39 + k * frame..39 + (k + 1) * frame].to_vec();
    for k in 0..3 {
        assert_eq!(hist(&obs, k), current(&obs), "a new episode's earlier frames are its first");
    }
    let mut seen = vec![current(&obs)];
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..6 {
        let act: Vec<f32> = (0..10).map(|_| rng.random_range(-0.5..0.5)).collect();
        e.step(&act, &mut obs);
        for k in 0..3 {
            let back = seen.len().saturating_sub(k + 1);
            assert_eq!(hist(&obs, k), seen[back], "frame {k} is the observation {} step(s) ago", k + 1);
        }
        seen.push(current(&obs));
    }
    // The mirror maps every earlier frame as it maps the current one.
    let sym = e.symmetry().unwrap();
    assert!(sym.obs.is_involution());
    for k in 0..3 {
        for i in 0..frame {
            let (at, now) = (39 + k * frame + i, i);
            assert_eq!(sym.obs.perm[at] - (39 + k * frame), sym.obs.perm[now], "frame {k}, value {i}");
            assert_eq!(sym.obs.sign[at], sym.obs.sign[now]);
        }
    }
    // A restored batch continues bit for bit, its frames included.
    snapshot_round_trip(&velocity_free(BaseVelocity::Estimated, 3));
}

/// The same episode observed the paper's way and with an estimated velocity: the actor's part is the paper's row
/// without v, and the critic's privileged block is the paper's v (the simulator's truth).
#[test]
fn the_critic_reads_the_true_velocity_that_the_actor_does_not() {
    let (mut paper, mut est) = (env(quiet(ModelKind::Closed), 4), env(velocity_free(BaseVelocity::Estimated, 0), 4));
    let (mut a, mut b) = (vec![0.0; paper.obs_dim()], vec![0.0; est.obs_dim()]);
    assert_eq!(est.obs_dim(), topa::OBS_DIM);
    let view = est.actor_view();
    assert_eq!(view, ActorView { obs_dim: 42, inputs: 39, estimate: Some(39..42) });
    paper.reset(&mut a).unwrap();
    est.reset(&mut b).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut moved = 0.0f32;
    for _ in 0..30 {
        let act: Vec<f32> = (0..10).map(|_| rng.random_range(-0.5..0.5)).collect();
        paper.step(&act, &mut a);
        est.step(&act, &mut b);
        assert_eq!(&b[..39], &a[3..], "the actor's inputs are the paper's row after v");
        assert_eq!(&b[39..], &a[..3], "the privileged block is the true velocity");
        moved = moved.max(a[0].abs() + a[1].abs());
    }
    assert!(moved > 0.05, "the base moved ({moved} m/s), so the comparison is not of zeros");
}

/// The mirror maps of the estimated layout: the mirrored state, stepped with the mirrored action, observes the
/// mirror image — the privileged velocity included (a vector: its y flips).
#[test]
fn the_estimated_layout_is_mirror_equivariant() {
    let cfg = velocity_free(BaseVelocity::Estimated, 0);
    let (mut a, mut b) = (env(cfg.clone(), 3), env(cfg, 4));
    let sym = a.symmetry().unwrap();
    assert!(sym.obs.is_involution());
    let actor = a.actor_view().mirror(&sym.obs).unwrap();
    assert!(actor.is_involution());
    let dim = a.obs_dim();
    let (mut oa, mut ob) = (vec![0.0; dim], vec![0.0; dim]);
    a.reset(&mut oa).unwrap();
    b.reset(&mut ob).unwrap();
    a.set_command_override(Some([0.3, 0.2, 0.5]));
    b.set_command_override(Some([0.3, -0.2, -0.5]));
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..10 {
        let act: Vec<f32> = (0..10).map(|_| rng.random_range(-0.5..0.5)).collect();
        a.step(&act, &mut oa);
    }
    let mut worst = 0.0f32;
    for _ in 0..5 {
        mirror_into(&a, &mut b, &mut ob);
        let act: Vec<f32> = (0..10).map(|_| rng.random_range(-0.5..0.5)).collect();
        let mut act_m = vec![0.0; 10];
        sym.act.apply(&act, &mut act_m);
        a.step(&act, &mut oa);
        b.step(&act_m, &mut ob);
        let mut expect = vec![0.0; dim];
        sym.obs.apply(&oa, &mut expect);
        worst = (0..dim).map(|i| (expect[i] - ob[i]).abs()).fold(worst, f32::max);
        assert!(oa[40].abs() > 1e-4, "the base moves sideways, so the privileged y's sign is tested");
    }
    assert!(worst < 1e-3, "mirrored dynamics differ by {worst} in the estimated layout");
}

#[test]
fn the_observation_option_is_checked_by_name() {
    let mut table = EnvConfig::default().to_table();
    let obs: toml::Table = toml::from_str("base_velocity = \"measured\"").unwrap();
    table.insert("observation".into(), toml::Value::Table(obs));
    let e = EnvConfig::from_table(&table).unwrap_err().to_string();
    assert!(e.contains("base_velocity") || e.contains("measured"), "{e}");
    assert!(e.contains("observed") && e.contains("estimated"), "the error names the choices: {e}");
}
