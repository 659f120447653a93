//! `topa bench render`: milliseconds per frame of MuJoCo's offscreen renderer on the headless EGL context
//! (scene update + render + overlay + pixel read-back), at a given size, on the standing then walking robot; and
//! the GIF encoder's cost per frame, measured apart.

use std::time::Instant;

use mujoco::render::{Quality, Renderer};
use topa_env::{assets, EnvConfig, ModelKind, RobotEnv, Task};

use topa_eval::video::{GlContext, VideoWriter};

use crate::error::Result;

pub fn run(width: usize, height: usize, frames: usize, quality: Quality) -> Result<()> {
    let _gl = GlContext::headless(width, height)?;
    let model = assets::load_model(ModelKind::Closed)?;
    let mut env = RobotEnv::new(model.clone(), std::sync::Arc::new(EnvConfig::default()), 1, 0)?;
    let mut obs = vec![0.0f32; 42];
    env.reset(&mut obs)?;
    let mut r = Renderer::new(model, width, height, quality)?;
    r.track(env.indices().torso_body, 1.6, 150.0, -12.0);
    let text = ("time\ncommand\nmeasured".to_string(), "0.00 s\n+0.50 +0.00 +0.00\n+0.48 +0.01 -0.02".to_string());
    r.render(env.data_mut(), Some((&text.0, &text.1)))?; // warm-up: shaders, textures
    let mut times = Vec::with_capacity(frames);
    let mut last = Vec::new();
    for k in 0..frames {
        env.step(&[0.05 * ((k as f32) * 0.3).sin(); 10], &mut obs);
        let t = Instant::now();
        last = r.render(env.data_mut(), Some((&text.0, &text.1)))?.to_vec();
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let mean = times.iter().sum::<f64>() / times.len() as f64;
    let tmp = std::env::temp_dir().join(format!("topa-bench-render-{}.gif", std::process::id()));
    let mut w = VideoWriter::create(&tmp, width, height, 30)?;
    let t = Instant::now();
    for _ in 0..10 {
        w.write(&last)?;
    }
    let gif_ms = t.elapsed().as_secs_f64() * 1e3 / 10.0;
    drop(w);
    println!("MuJoCo offscreen rendering, {width}×{height}, {quality:?} quality, headless EGL ({frames} frames):");
    println!(
        "  per frame: mean {mean:.1} ms, median {:.1} ms, 95th percentile {:.1} ms (goal < 20 ms at 640×480)",
        times[times.len() / 2],
        times[times.len() * 95 / 100]
    );
    println!("  GIF encoding (not rendering): {gif_ms:.1} ms per frame");
    Ok(())
}
