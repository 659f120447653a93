//! The safe layer's cost: MuJoCo's bare `mj_step` (the raw FFI call) against our `Data::step` (error guard and
//! capacity check around the same call) on TopA's closed chain, from the same keyframe with the same controls.
//! Rounds alternate the two sides; the best of each is kept. Prints safe / bare (goal ≥ 0.98).

use std::sync::Arc;
use std::time::Instant;

use mujoco::{Data, Model, ObjType, Result};
use mujoco_sys::ffi;

const STEPS: usize = 20_000;

fn run(model: &Arc<Model>, bare: bool) -> Result<f64> {
    let mut d = Data::new(model.clone())?;
    let key = model.id(ObjType::Key, "stand")?;
    d.reset_keyframe(key)?;
    let start = Instant::now();
    for _ in 0..STEPS {
        if bare {
            // SAFETY: d was made for this model; a benchmark of the unguarded call.
            unsafe { ffi::mj_step(model.raw(), d.raw_mut()) };
        } else {
            d.step()?;
        }
    }
    Ok(STEPS as f64 / start.elapsed().as_secs_f64())
}

fn main() -> Result<()> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/mjcf/topa_closed.xml");
    let model = Arc::new(Model::from_xml_path(&path)?);
    let (mut bare, mut safe) = (0.0f64, 0.0f64);
    for round in 0..6 {
        if round % 2 == 0 {
            bare = bare.max(run(&model, true)?);
            safe = safe.max(run(&model, false)?);
        } else {
            safe = safe.max(run(&model, false)?);
            bare = bare.max(run(&model, true)?);
        }
    }
    println!("physics: TopA closed chain, {STEPS} steps from the stand keyframe, best of 6 alternating rounds");
    println!("  bare mj_step     {bare:>10.0} steps/s");
    println!("  Data::step       {safe:>10.0} steps/s");
    println!("  ratio safe/bare  {:>10.3}   (goal ≥ 0.98)", safe / bare);
    Ok(())
}
