//! The policy and value networks: dense layers with fast CPU kernels inside Candle's autograd.
//!
//! The paper's networks are MLPs, actor 42→512→256→128→10 and critic 42→512→256→128→1, ELU on the hidden layers
//! and a linear output. Everything here is differentiable through candle's `Tensor::backward` with respect to the
//! input and every [`Linear`]'s `Var`s, so the PPO losses on top stay ordinary candle tensor code.
//!
//! * [`linear`]: one fused layer `y = act(x·Wᵀ + b)` as a candle custom op. Forward: a blocked product whose
//!   epilogue adds the bias and applies ELU on the accumulators before they are stored. Backward: ELU' from the
//!   stored output (ELU'(z) = y + 1 for z ≤ 0), the bias gradient as per-block column sums, `dX = dZ·W` and
//!   `dW = dZᵀ·X` read straight from the row-major buffers (no transposed copies), `dX` skipped when the input
//!   does not need a gradient.
//! * [`Mlp::forward`]: the same layers chained so that the hidden activations stay out of candle's gradient
//!   bookkeeping (candle adds every gradient into a fresh zero tensor; for 6144×896 floats of hidden activations
//!   per pass that costs more than the element-wise work itself). Also fuses each layer's ELU' and bias-gradient
//!   sums into the backward product of the next layer. ~10 % faster than chaining [`linear`] on the paper's update.
//!   See `ops.rs`.
//! * [`Mlp::forward_inference`]: the rollout path on plain slices, no autograd, no allocation of its own once
//!   warmed up (with 2+ threads, rayon's job queue allocates a small block every ~60 parallel sections).
//!
//! Products run on an AVX2/FMA 6×16 register-tile kernel with packed weights (`gemm.rs`), the `gemm` crate
//! (candle's matmul) on CPUs without AVX2/FMA or when `NN_GEMM=crate` is set (a diagnostic switch for A/B timing).
//! ELU uses a vectorised `expm1` (a few ulp; more accurate near 0 than candle's `exp(x) − 1`).
//!
//! # Threads
//! Three things decide how many threads run tensor code in this process:
//! * the rayon pool the caller runs in (the global pool unless inside `ThreadPool::install`), which runs this
//!   module's kernels, and also `gemm`'s parallel mode that candle's own matmul uses: candle 0.11 passes
//!   `gemm::Parallelism::Rayon(n)`, with `n` read from `RAYON_NUM_THREADS` (else the number of physical cores) at
//!   every call, and gemm runs it on the current rayon pool;
//! * candle's element-wise ops, which split tensors of ≥ 64 Ki elements over candle's private "barrier pool",
//!   sized once, at its first use, from `CANDLE_NUM_THREADS`, else `RAYON_NUM_THREADS`, else the physical cores;
//! * the rayon global pool's size: `RAYON_NUM_THREADS` or `ThreadPoolBuilder::build_global`, fixed when the pool
//!   is first used.
//!
//! [`init_threads`] makes all of them follow one number: it sets both environment variables and builds the rayon
//! global pool. Call it once, first thing in `main` (before any candle op, any rayon use, and any other thread).
//!
//! # Determinism
//! Results are bit-identical for any thread count (checked by the tests for 1, 2 and 3 threads). Every parallel
//! loop here splits its work into blocks whose size does not depend on the thread count wherever the blocking
//! could change the arithmetic, and no reduction is ever split across threads: the weight gradient (a sum over
//! the batch) is computed in fixed chunks of 1536 rows whose results are added in chunk order, the bias gradient
//! in fixed blocks of 768 rows likewise, and every product sums over `k` in the same order whatever block of the
//! output it computes (see `layer.rs` and `gemm.rs`). The `gemm` crate's own parallel mode (candle's matmul, if
//! the trainer uses it elsewhere) only splits output tiles, so its results do not depend on the thread count
//! either (also tested).
//!
//! # Speed (paper's update shape; `benches/ppo_update.rs` vs `trainer/examples/torch_reference.py`)
//! On the 2-vCPU AMD EPYC (Zen 3, AVX2) this was written on: ~4.7 k samples/s at 1 thread (torch 2.15:
//! ~3.8 k; straightforward candle: ~1.8 k). At 2 threads the machine's two vCPUs sometimes share one physical
//! core: see `benches/ppo_update.rs` for how to read 2-thread numbers.

mod gemm;
mod kernels;
mod layer;
mod ops;
#[cfg(test)]
mod tests;

pub use kernels::Activation;

use candle_core::{bail, DType, Device, Result, Storage, Tensor, Var};
use rand::RngExt;
use std::sync::Arc;

/// A dense layer's parameters.
#[derive(Clone, Debug)]
pub struct Linear {
    /// `[out, in]`, f32, CPU.
    pub weight: Var,
    /// `[out]`.
    pub bias: Var,
}

impl Linear {
    /// PyTorch's default `nn.Linear` init: weight and bias ~ U(−1/√in, 1/√in), weight drawn first, row by row.
    pub fn new(in_dim: usize, out_dim: usize, rng: &mut impl rand::Rng) -> Result<Linear> {
        let bound = 1.0 / (in_dim as f64).sqrt();
        let mut draw = |n: usize| -> Vec<f32> { (0..n).map(|_| rng.random_range(-bound..bound) as f32).collect() };
        let w = draw(out_dim * in_dim);
        let b = draw(out_dim);
        Ok(Linear {
            weight: Var::from_vec(w, (out_dim, in_dim), &Device::Cpu)?,
            bias: Var::from_vec(b, out_dim, &Device::Cpu)?,
        })
    }

    pub fn in_dim(&self) -> usize {
        self.weight.dims()[1]
    }

    pub fn out_dim(&self) -> usize {
        self.weight.dims()[0]
    }
}

fn is_cpu_f32(t: &Tensor) -> bool {
    matches!(t.device(), Device::Cpu) && t.dtype() == DType::F32
}

/// `y = act(x · Wᵀ + b)` for `x` of shape `[rows, in]`, differentiable with respect to `x`, `W` and `b` through
/// candle's autograd. On CPU/f32 this is one fused custom op; elsewhere it falls back to [`linear_reference`].
pub fn linear(x: &Tensor, layer: &Linear, act: Activation) -> Result<Tensor> {
    let (w, b) = (layer.weight.as_tensor(), layer.bias.as_tensor());
    if !(is_cpu_f32(x) && is_cpu_f32(w) && is_cpu_f32(b)) {
        return linear_reference(x, layer, act);
    }
    if x.rank() != 2 {
        bail!("nn::linear: input must be [rows, features], got {:?}", x.dims());
    }
    x.apply_op3_arc(w, b, Arc::new(Box::new(ops::LinearOp { act })))
}

/// The same layer as candle-nn's `Linear` and candle's `elu`: the reference for tests and benchmarks, and the
/// fallback off the CPU.
pub fn linear_reference(x: &Tensor, layer: &Linear, act: Activation) -> Result<Tensor> {
    use candle_core::Module;
    let z =
        candle_nn::Linear::new(layer.weight.as_tensor().clone(), Some(layer.bias.as_tensor().clone())).forward(x)?;
    match act {
        Activation::Elu => z.elu(1.0),
        Activation::Identity => Ok(z),
    }
}

/// An MLP's layer sizes: `[input, hidden…, output]`.
pub fn layer_dims(input: usize, hidden: &[usize], output: usize) -> Vec<usize> {
    std::iter::once(input).chain(hidden.iter().copied()).chain(std::iter::once(output)).collect()
}

/// A multi-layer perceptron: `hidden_activation` after every layer but the last, which is linear.
#[derive(Clone, Debug)]
pub struct Mlp {
    pub layers: Vec<Linear>,
    pub hidden_activation: Activation,
}

/// Reusable buffers for [`Mlp::forward_inference`].
#[derive(Default, Debug, Clone)]
pub struct MlpScratch {
    a: Vec<f32>,
    b: Vec<f32>,
    packed: gemm::PackedB,
}

impl Mlp {
    /// `dims = [in, hidden…, out]`; PyTorch's default `nn.Linear` init, layer by layer (weight, then bias), drawn
    /// from the caller's seeded RNG. Hidden activation: ELU.
    pub fn new(dims: &[usize], rng: &mut impl rand::Rng) -> Result<Mlp> {
        if dims.len() < 2 {
            bail!("nn::Mlp::new: need at least input and output sizes, got {dims:?}");
        }
        let layers = dims.windows(2).map(|d| Linear::new(d[0], d[1], rng)).collect::<Result<Vec<_>>>()?;
        Ok(Mlp { layers, hidden_activation: Activation::Elu })
    }

    fn activation(&self, l: usize) -> Activation {
        if l + 1 == self.layers.len() {
            Activation::Identity
        } else {
            self.hidden_activation
        }
    }

    pub fn in_dim(&self) -> usize {
        self.layers[0].in_dim()
    }

    pub fn out_dim(&self) -> usize {
        self.last_layer().out_dim()
    }

    /// Differentiable forward of `x: [rows, in]` → `[rows, out]`.
    pub fn forward(&self, x: &Tensor) -> Result<Tensor> {
        let all_cpu_f32 = is_cpu_f32(x)
            && self.layers.iter().all(|l| is_cpu_f32(l.weight.as_tensor()) && is_cpu_f32(l.bias.as_tensor()));
        if !all_cpu_f32 {
            return self.forward_reference(x);
        }
        let (rows, _) = x.dims2()?;
        let n = self.layers.len();
        let ctx = ops::ChainCtx::new(rows, n, self.hidden_activation);
        let mut h = x.clone();
        for (l, layer) in self.layers.iter().enumerate() {
            let op = ops::ChainOp { ctx: ctx.clone(), l, n_layers: n };
            h = h.apply_op3_arc(layer.weight.as_tensor(), layer.bias.as_tensor(), Arc::new(Box::new(op)))?;
        }
        Ok(h)
    }

    /// The same network through one [`linear`] op per layer (every hidden activation a real graph tensor).
    pub fn forward_layerwise(&self, x: &Tensor) -> Result<Tensor> {
        let mut h = x.clone();
        for (l, layer) in self.layers.iter().enumerate() {
            h = linear(&h, layer, self.activation(l))?;
        }
        Ok(h)
    }

    /// The same network with plain candle ops ([`linear_reference`]).
    pub fn forward_reference(&self, x: &Tensor) -> Result<Tensor> {
        let mut h = x.clone();
        for (l, layer) in self.layers.iter().enumerate() {
            h = linear_reference(&h, layer, self.activation(l))?;
        }
        Ok(h)
    }

    /// The parameters, `[w0, b0, w1, b1, …]`.
    pub fn vars(&self) -> Vec<Var> {
        self.layers.iter().flat_map(|l| [l.weight.clone(), l.bias.clone()]).collect()
    }

    pub fn last_layer(&self) -> &Linear {
        self.layers.last().expect("an Mlp has at least one layer")
    }

    /// Inference without autograd: `x` holds `rows` row-major observations; `out` is resized to `rows × out`.
    /// Buffers in `scratch` and `out` only ever grow, so once warmed up to the largest batch a call allocates
    /// nothing of its own. Same arithmetic as [`Mlp::forward`]: bit-identical results (on CPUs with AVX2/FMA; with
    /// the `gemm` crate's products, equal up to rounding).
    ///
    /// # Panics
    /// If `x.len() != rows × in`, or the parameters are not contiguous f32 CPU tensors.
    pub fn forward_inference(&self, x: &[f32], rows: usize, out: &mut Vec<f32>, scratch: &mut MlpScratch) {
        let n_layers = self.layers.len();
        assert_eq!(x.len(), rows * self.in_dim(), "nn::Mlp::forward_inference: input size");
        let MlpScratch { a, b, packed } = scratch;
        let mut k = self.in_dim();
        for (l, layer) in self.layers.iter().enumerate() {
            let n = layer.out_dim();
            let act = self.activation(l);
            let (ws, wl) = layer.weight.storage_and_layout();
            let (bs, bl) = layer.bias.storage_and_layout();
            let w = param_slice(&ws, wl);
            let bias = param_slice(&bs, bl);
            let last = l + 1 == n_layers;
            // Input: x for the first layer, else the buffer the previous layer wrote (a for even l, b for odd).
            let (src, dst): (&[f32], &mut Vec<f32>) = match (l == 0, l % 2 == 0) {
                (true, _) => (x, if last { &mut *out } else { &mut *a }),
                (false, false) => (&a[..rows * k], if last { &mut *out } else { &mut *b }),
                (false, true) => (&b[..rows * k], if last { &mut *out } else { &mut *a }),
            };
            if last {
                dst.clear();
                dst.resize(rows * n, 0.0);
            } else if dst.len() < rows * n {
                dst.resize(rows * n, 0.0);
            }
            layer::forward(gemm::MatRef::row_major(src, k), rows, k, w, bias, n, act, &mut dst[..rows * n], packed);
            k = n;
        }
    }
}

fn param_slice<'a>(s: &'a Storage, l: &candle_core::Layout) -> &'a [f32] {
    let Storage::Cpu(c) = s else { panic!("nn: parameters must be on the CPU") };
    ops::slice_of(c, l, "parameter").expect("nn: parameters must be contiguous f32")
}

/// candle's layer trait, so an `Mlp` composes with candle-nn (`candle_nn::seq().add(mlp)…`).
impl candle_core::Module for Mlp {
    fn forward(&self, xs: &Tensor) -> candle_core::Result<Tensor> {
        Mlp::forward(self, xs)
    }
}

/// The matrix-product kernel this process uses: `"AVX-512"` (12×32 tiles), `"AVX2"` (6×16 tiles) or `"gemm crate"`
/// (CPUs without AVX2/FMA). `NN_GEMM=avx2` or `NN_GEMM=crate` in the environment picks a narrower one, for A/B
/// timing; the AVX-512 and AVX2 kernels give bit-identical results.
pub fn gemm_kernel() -> &'static str {
    if !gemm::own_kernel() {
        "gemm crate"
    } else if gemm::wide_kernel() {
        "AVX-512"
    } else {
        "AVX2"
    }
}

/// Threads to use: `n`, or every core for 0.
pub fn resolve_threads(n: usize) -> usize {
    if n == 0 {
        std::thread::available_parallelism().map_or(1, |p| p.get())
    } else {
        n
    }
}

/// Makes this module's kernels, candle (matmul and element-wise ops) and gemm all use `n` threads; see the
/// module docs. Call once, first thing in `main`, before any candle op or rayon use and before spawning threads.
/// Fails if the rayon global pool already exists with a different size. Also calls [`keep_freed_memory`].
pub fn init_threads(n: usize) -> Result<()> {
    let n = n.max(1);
    // Environment writes are only sound while no other thread reads the environment: hence "first thing".
    std::env::set_var("RAYON_NUM_THREADS", n.to_string());
    std::env::set_var("CANDLE_NUM_THREADS", n.to_string());
    keep_freed_memory();
    match rayon::ThreadPoolBuilder::new().num_threads(n).build_global() {
        Ok(()) => Ok(()),
        Err(_) if rayon::current_num_threads() == n => Ok(()),
        Err(e) => {
            bail!("nn::init_threads({n}): rayon global pool already has {} threads: {e}", rayon::current_num_threads())
        }
    }
}

/// Runs `f` on a worker of rayon's global pool while the caller waits, and returns its result. Called from a
/// thread outside the pool (the main thread), each parallel region of `f` then starts on a worker that is already
/// running, instead of waking one to take the job and then a second to share it: with the hundreds of short
/// regions of a PPO update that hand-over was most of the 2-thread update's lost time. The arithmetic and its
/// order are unchanged. Inline when already on a worker or with a one-thread pool.
pub fn on_worker<R>(f: impl FnOnce() -> R) -> R {
    /// Moves `f` and its result between the caller and the worker.
    struct Carried<T>(T);
    // SAFETY: the caller is blocked inside `rayon::join` until the worker has finished with the value, and the
    // join's latch orders the worker's accesses after the caller's and before its return: the value (even an
    // `Rc` or a `!Send` tensor handle inside `f`) is never used by two threads at once.
    unsafe impl<T> Send for Carried<T> {}
    impl<T> Carried<T> {
        fn into_inner(self) -> T {
            self.0
        }
    }
    if rayon::current_thread_index().is_some() || rayon::current_num_threads() <= 1 {
        return f();
    }
    let job = Carried(f);
    rayon::join(move || Carried(job.into_inner()()), || ()).0.into_inner()
}

/// Tells glibc's malloc to serve large blocks from the heap and to keep freed memory instead of returning it to
/// the kernel. Every minibatch allocates and frees the same few hundred MB of tensors; with glibc's defaults
/// those blocks are fresh `mmap`s or a re-grown heap each time, and first-touch page faults plus kernel page
/// zeroing cost ~8 % of the update. With this, the process keeps its peak heap (a few hundred MB for the paper's
/// networks) and reuses it. No-op off glibc.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        extern "C" {
            fn mallopt(param: i32, value: i32) -> i32;
        }
        const M_TRIM_THRESHOLD: i32 = -1;
        const M_MMAP_THRESHOLD: i32 = -3;
        // SAFETY: mallopt only adjusts allocator parameters; it is thread-safe in glibc.
        unsafe {
            mallopt(M_MMAP_THRESHOLD, 1 << 30);
            mallopt(M_TRIM_THRESHOLD, i32::MAX);
        }
    }
}
