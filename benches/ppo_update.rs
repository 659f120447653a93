//! The PPO update's networks on the paper's shape (actor and critic 42 → 512 → 256 → 128 → 10 | 1, ELU): per
//! minibatch of 6144 rows, actor forward, a second actor forward (the symmetry term), critic forward, a loss on all
//! three, backward, an SGD step; 24 576 samples × 5 epochs. Our fused layer chain (`nn::Mlp::forward`) against the
//! same network as candle-nn `Linear` layers with candle's backward, timed alternately in one run; prints
//! samples/s, GFLOP/s (16.76 MFLOP per sample) and ours / candle-nn. `topa bench ppo` adds the torch peer
//! (trainer/examples/torch_reference.py).
//!
//! ```text
//! cargo bench --bench ppo_update -- [--threads 2] [--repeats 3] [--variants ours,layerwise,plain] [--hidden 512,256,128]
//! ```

use anyhow::Result;
use candle_core::{Device, Tensor, Var};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;
use trainer::nn::{self, Mlp};

const OBS: usize = 42;
const ACT: usize = 10;
const SAMPLES: usize = 24_576;
const MINIBATCH: usize = 6_144;
const EPOCHS: usize = 5;

#[derive(Clone, Copy, PartialEq, Debug)]
enum Variant {
    Plain,
    Layerwise,
    Ours,
}

impl Variant {
    fn name(self) -> &'static str {
        match self {
            Variant::Plain => "candle-nn Linear",
            Variant::Layerwise => "nn::linear per layer",
            Variant::Ours => "nn::Mlp::forward",
        }
    }
    fn forward(self, m: &Mlp, x: &Tensor) -> candle_core::Result<Tensor> {
        match self {
            Variant::Plain => m.forward_reference(x),
            Variant::Layerwise => m.forward_layerwise(x),
            Variant::Ours => m.forward(x),
        }
    }
}

fn random(rows: usize, cols: usize, rng: &mut ChaCha8Rng) -> Result<Tensor> {
    let v: Vec<f32> = (0..rows * cols).map(|_| rng.random_range(-2.0f32..2.0)).collect();
    Ok(Tensor::from_vec(v, (rows, cols), &Device::Cpu)?)
}

struct Setup {
    actor: Mlp,
    critic: Mlp,
    vars: Vec<Var>,
    obs: Tensor,
    mirrored: Tensor,
}

fn dims(hidden: &[usize], out: usize) -> Vec<usize> {
    std::iter::once(OBS).chain(hidden.iter().copied()).chain(std::iter::once(out)).collect()
}

/// Nominal FLOPs per sample for the whole update: per epoch 3 forward passes (2 actor, 1 critic) at 2 FLOP per
/// multiply-add, and their backward at twice that; 16.76 M for the paper's networks (the notes' "≈ 16.8 M").
fn flop_per_sample(hidden: &[usize]) -> f64 {
    let macs = |d: &[usize]| d.windows(2).map(|w| w[0] * w[1]).sum::<usize>() as f64;
    EPOCHS as f64 * 6.0 * (2.0 * macs(&dims(hidden, ACT)) + macs(&dims(hidden, 1)))
}

fn setup(seed: u64, hidden: &[usize]) -> Result<Setup> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let actor = Mlp::new(&dims(hidden, ACT), &mut rng)?;
    let critic = Mlp::new(&dims(hidden, 1), &mut rng)?;
    let mut vars = actor.vars();
    vars.extend(critic.vars());
    let obs = random(SAMPLES, OBS, &mut rng)?;
    let mirrored = random(SAMPLES, OBS, &mut rng)?;
    Ok(Setup { actor, critic, vars, obs, mirrored })
}

/// One whole update (5 epochs × 4 minibatches); returns (seconds, last loss).
fn update(s: &Setup, v: Variant, lr: f64) -> Result<(f64, f32)> {
    let t = Instant::now();
    let mut last = 0.0;
    for _ in 0..EPOCHS {
        for i in 0..SAMPLES / MINIBATCH {
            let x = s.obs.narrow(0, i * MINIBATCH, MINIBATCH)?;
            let xm = s.mirrored.narrow(0, i * MINIBATCH, MINIBATCH)?;
            let mu = v.forward(&s.actor, &x)?;
            let mu_m = v.forward(&s.actor, &xm)?;
            let value = v.forward(&s.critic, &x)?;
            let loss = ((mu.sqr()?.mean_all()? + mu_m.sqr()?.mean_all()?)? + value.sqr()?.mean_all()?)?;
            let grads = loss.backward()?;
            for var in &s.vars {
                let g = grads.get(var).expect("every var has a gradient");
                var.set(&(var.as_tensor() - (g * lr)?)?)?;
            }
            last = loss.to_scalar::<f32>()?;
        }
    }
    Ok((t.elapsed().as_secs_f64(), last))
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let threads: usize = arg("--threads").map(|s| s.parse()).transpose()?.unwrap_or(2);
    let repeats: usize = arg("--repeats").map(|s| s.parse()).transpose()?.unwrap_or(3);
    let variants: Vec<Variant> = arg("--variants")
        .unwrap_or_else(|| "ours,plain".into())
        .split(',')
        .map(|v| match v {
            "plain" => Variant::Plain,
            "layerwise" => Variant::Layerwise,
            "ours" => Variant::Ours,
            other => panic!("unknown variant {other}"),
        })
        .collect();
    let hidden: Vec<usize> = arg("--hidden")
        .unwrap_or_else(|| "512,256,128".into())
        .split(',')
        .map(|s| s.parse())
        .collect::<std::result::Result<_, _>>()?;
    let flops = flop_per_sample(&hidden);
    nn::init_threads(threads)?;
    println!(
        "threads {threads} (rayon {}), repeats {repeats}, hidden {hidden:?}, {:.2} MFLOP per sample",
        rayon::current_num_threads(),
        flops / 1e6
    );

    // Same initial weights for every variant: each gets its own copy of the seeded setup.
    let setups: Vec<Setup> = variants.iter().map(|_| setup(1, &hidden)).collect::<Result<_>>()?;
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); variants.len()];
    for (s, &v) in setups.iter().zip(&variants) {
        let (t, loss) = update(s, v, 1e-3)?; // warm-up
        println!("warm-up {:<22} {t:.3} s  loss {loss:.6}", v.name());
    }
    for _ in 0..repeats {
        for (i, (s, &v)) in setups.iter().zip(&variants).enumerate() {
            let (t, _) = update(s, v, 1e-3)?;
            times[i].push(t);
            println!(
                "  {:<22} {t:.3} s  {:7.0} samples/s  {:6.1} GFLOP/s",
                v.name(),
                SAMPLES as f64 / t,
                SAMPLES as f64 * flops / t / 1e9
            );
        }
    }
    for (i, &v) in variants.iter().enumerate() {
        let mut t = times[i].clone();
        t.sort_by(f64::total_cmp);
        let (best, med) = (t[0], t[t.len() / 2]);
        println!(
            "RESULT threads={threads} {:<22} best {:7.0} samples/s {:6.1} GFLOP/s | median {:7.0} samples/s",
            v.name(),
            SAMPLES as f64 / best,
            SAMPLES as f64 * flops / best / 1e9,
            SAMPLES as f64 / med
        );
    }

    if let (Some(o), Some(p)) =
        (variants.iter().position(|&v| v == Variant::Ours), variants.iter().position(|&v| v == Variant::Plain))
    {
        let best = |i: usize| times[i].iter().copied().fold(f64::INFINITY, f64::min);
        println!("ratio ours / candle-nn (best update time): {:.2}×", best(p) / best(o));
    }
    Ok(())
}
