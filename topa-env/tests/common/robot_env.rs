//! Shared helpers of the env tests: a quiet config, one env, a mirrored state, a snapshot round trip.

use std::sync::Arc;

use topa_env::symmetry::mirror_mj_state;
use topa_env::{assets, EnvConfig, ModelKind, RobotEnv, VecEnv};

/// Training config without randomness in the dynamics or the observation.
pub fn quiet(kind: ModelKind) -> EnvConfig {
    let mut c = EnvConfig { robot: kind.spec_path().into(), ..EnvConfig::default() };
    c.noise.enabled = false;
    c.domain_rand.enabled = false;
    c.push.enabled = false;
    c
}

pub fn env(cfg: EnvConfig, seed: u64) -> RobotEnv {
    let (_, model) = assets::load_robot(&cfg).unwrap();
    RobotEnv::new(model, Arc::new(cfg), seed, 0).unwrap()
}

/// Mirrors the whole simulation state of `src` into `dst` (same model).
pub fn mirror_into(src: &RobotEnv, dst: &mut RobotEnv, obs: &mut [f32]) {
    let m = src.data().model_arc();
    let (p, v) = mirror_mj_state(m, src.data().qpos(), src.data().qvel()).unwrap();
    dst.data_mut().qpos_mut().copy_from_slice(&p);
    dst.data_mut().qvel_mut().copy_from_slice(&v);
    dst.refresh(obs).unwrap();
}

/// A batch restored from a snapshot continues bit for bit.
pub fn snapshot_round_trip(cfg: &EnvConfig) {
    let cfg = cfg.clone();
    let mut a = topa_env::vec_env::robot_batch(&cfg, 3, 8, 1).unwrap();
    a.reset().unwrap();
    let act = |k: usize| -> Vec<f32> { (0..30).map(|i| ((i * 7 + k * 13) % 11) as f32 / 11.0 - 0.5).collect() };
    for k in 0..20 {
        a.step(&act(k)).unwrap();
    }
    let snap = a.save_state();
    let mut b = topa_env::vec_env::robot_batch(&cfg, 3, 12345, 2).unwrap();
    b.reset().unwrap();
    b.load_state(&snap).unwrap();
    assert_eq!(a.obs(), b.obs());
    for k in 20..60 {
        a.step(&act(k)).unwrap();
        b.step(&act(k)).unwrap();
        assert_eq!(a.obs(), b.obs(), "step {k}");
        assert_eq!(a.rewards(), b.rewards());
    }
}
