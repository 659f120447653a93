//! The robot-side controller's tick on one core: a standing C+A seed 1 in the policy mode, 20 000 ticks, each
//! timed; median, p99 and max, beside the policy's forward pass alone on the same rows (its share of a tick).

use std::path::Path;
use std::time::Instant;

use anyhow::Result;
use topa_control::network::Networks;
use topa_control::{Controller, ControllerSpec, SensorFrame};

const TICKS: usize = 20_000;

#[path = "common/stats.rs"]
mod stats;
use stats::quantiles;

fn main() -> Result<()> {
    let dir = std::env::temp_dir().join(format!("topa-bench-controller-{}", std::process::id()));
    topa_tools::controller_export::export(Path::new("assets/policies/CA/seed1.json"), &dir)?;
    let mut c = Controller::load(&dir)?;
    let n = c.spec().n_motors();
    let dt = c.spec().control_period_s;
    let pos: Vec<f64> = c.spec().motors.iter().map(|m| m.nominal).collect();
    let vel = vec![0.0; n];
    let frame = |k: usize| SensorFrame {
        timestamp_s: k as f64 * dt,
        orientation: [1.0, 0.0, 0.0, 0.0],
        gyro: [0.01, 0.0, 0.02],
        motor_pos: &pos,
        motor_vel: &vel,
        base_velocity: Some([0.1, 0.0, 0.0]),
    };
    c.start();
    let mut k = 0;
    while c.mode() != topa_control::Mode::Policy {
        c.tick(&frame(k)).map_err(anyhow::Error::msg)?;
        k += 1;
    }
    let mut ticks = Vec::with_capacity(TICKS);
    for _ in 0..TICKS {
        k += 1;
        let f = frame(k);
        let t = Instant::now();
        std::hint::black_box(c.tick(&f).map_err(anyhow::Error::msg)?);
        ticks.push(t.elapsed().as_secs_f64() * 1e6);
    }
    let (spec, weights) = ControllerSpec::load(&dir)?;
    let mut nets = Networks::load(&spec, &weights)?;
    let row = vec![0.1f32; spec.observation.inputs];
    let mut action = vec![0.0; n];
    let mut forward = Vec::with_capacity(TICKS);
    for _ in 0..TICKS {
        let t = Instant::now();
        nets.act(std::hint::black_box(&row), &mut action);
        forward.push(t.elapsed().as_secs_f64() * 1e6);
    }
    let (t50, t99, tmax) = quantiles(ticks);
    let (f50, f99, _) = quantiles(forward);
    println!("controller tick, C+A seed 1 ({} inputs), {TICKS} ticks, 1 thread:", spec.observation.inputs);
    println!("  tick          median {t50:7.1} µs   p99 {t99:7.1} µs   max {tmax:7.1} µs");
    println!("  forward pass  median {f50:7.1} µs   p99 {f99:7.1} µs");
    println!("  tick / forward pass (median): {:.2}", t50 / f50);
    std::fs::remove_dir_all(dir).ok();
    Ok(())
}
