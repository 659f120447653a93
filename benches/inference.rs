//! Policy inference, as the rollout runs it: a batch of 512 observations through the CPU preset's actor
//! (42 → 256 → 128 → 64 → 10, ELU). Our allocation-free `Mlp::forward_inference` against the same network as
//! candle-nn `Linear` layers and candle's `elu`, in one run (alternating, best kept). Prints ours / candle-nn.

use std::time::Instant;

use anyhow::Result;
use candle_core::{Device, Tensor};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use trainer::nn::{Mlp, MlpScratch};

const ROWS: usize = 512;
const CALLS: usize = 400;

fn main() -> Result<()> {
    trainer::nn::init_threads(1)?;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mlp = Mlp::new(&[42, 256, 128, 64, 10], &mut rng)?;
    let x: Vec<f32> = (0..ROWS * 42).map(|_| rng.random_range(-2.0f32..2.0)).collect();
    let xt = Tensor::from_vec(x.clone(), (ROWS, 42), &Device::Cpu)?;
    let (mut out, mut scratch) = (Vec::new(), MlpScratch::default());
    mlp.forward_inference(&x, ROWS, &mut out, &mut scratch); // warm-up: buffers, packed weights
    let (mut ours, mut candle) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..5 {
        let t = Instant::now();
        for _ in 0..CALLS {
            mlp.forward_inference(&x, ROWS, &mut out, &mut scratch);
        }
        ours = ours.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        for _ in 0..CALLS {
            std::hint::black_box(mlp.forward_reference(&xt)?);
        }
        candle = candle.min(t.elapsed().as_secs_f64());
    }
    let per_s = |s: f64| (ROWS * CALLS) as f64 / s;
    println!("inference: {ROWS} observations × {CALLS} calls, 1 thread, best of 5 alternating rounds");
    println!("  Mlp::forward_inference     {:>10.0} observations/s", per_s(ours));
    println!("  candle-nn Linear + elu     {:>10.0} observations/s", per_s(candle));
    println!("  ratio ours/candle-nn       {:>10.2}×", candle / ours);
    Ok(())
}
