use super::*;
use candle_core::{Device, Tensor, Var};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// A `[r, c]` tensor of U(-s, s) values from a seeded RNG.
fn rand_tensor(r: usize, c: usize, s: f32, seed: u64) -> Tensor {
    let mut g = rng(seed);
    let v: Vec<f32> = (0..r * c).map(|_| g.random_range(-s..s)).collect();
    Tensor::from_vec(v, (r, c), &Device::Cpu).unwrap()
}

/// Normwise relative error `max|a − b| / max|b|`.
fn rel_err(a: &Tensor, b: &Tensor) -> f32 {
    assert_eq!(a.dims(), b.dims());
    let a = a.flatten_all().unwrap().to_vec1::<f32>().unwrap();
    let b = b.flatten_all().unwrap().to_vec1::<f32>().unwrap();
    let num = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    let den = b.iter().map(|y| y.abs()).fold(0.0f32, f32::max).max(1e-30);
    num / den
}

fn bits(t: &Tensor) -> Vec<u32> {
    t.flatten_all().unwrap().to_vec1::<f32>().unwrap().iter().map(|v| v.to_bits()).collect()
}

/// Forward and gradients (x, W, b) of `sum(linear(x) ⊙ r)` for ours and the plain-candle reference.
fn check_linear(rows: usize, din: usize, dout: usize, act: Activation, seed: u64) {
    let layer = Linear::new(din, dout, &mut rng(seed)).unwrap();
    // Inputs of scale ~2 so that plenty of pre-activations are negative (ELU's exp branch).
    let x = Var::from_tensor(&rand_tensor(rows, din, 2.0, seed + 1)).unwrap();
    let r = rand_tensor(rows, dout, 1.0, seed + 2);
    let ours = linear(x.as_tensor(), &layer, act).unwrap();
    let reference = linear_reference(x.as_tensor(), &layer, act).unwrap();
    let e = rel_err(&ours, &reference);
    assert!(e < 1e-5, "forward {rows}x{din}->{dout} {act:?}: rel err {e}");

    let g_ours = (&ours * &r).unwrap().sum_all().unwrap().backward().unwrap();
    let g_ref = (&reference * &r).unwrap().sum_all().unwrap().backward().unwrap();
    for (name, v) in [("x", x.as_tensor()), ("W", layer.weight.as_tensor()), ("b", layer.bias.as_tensor())] {
        let a = g_ours.get(v).unwrap_or_else(|| panic!("no gradient for {name}"));
        let b = g_ref.get(v).unwrap();
        let e = rel_err(a, b);
        assert!(e < 1e-4, "grad {name} {rows}x{din}->{dout} {act:?}: rel err {e}");
    }
}

#[test]
fn linear_matches_candle_odd_shapes() {
    for act in [Activation::Elu, Activation::Identity] {
        check_linear(7, 5, 3, act, 10);
        check_linear(1, 1, 1, act, 11);
        check_linear(13, 17, 9, act, 12);
        check_linear(769, 33, 130, act, 13); // crosses the row and column block sizes
    }
}

#[test]
fn linear_matches_candle_real_shapes() {
    for (din, dout, act) in [
        (42, 512, Activation::Elu),
        (512, 256, Activation::Elu),
        (256, 128, Activation::Elu),
        (128, 10, Activation::Identity),
        (128, 1, Activation::Identity),
    ] {
        check_linear(6144, din, dout, act, 20 + din as u64);
    }
}

#[test]
fn linear_accepts_strided_input_and_gradient() {
    // x given transposed (column-major view) and the loss reading y through a transpose and a broadcast.
    let layer = Linear::new(6, 4, &mut rng(3)).unwrap();
    let xt = Var::from_tensor(&rand_tensor(6, 9, 2.0, 4)).unwrap();
    let x = xt.as_tensor().t().unwrap();
    let ours = linear(&x, &layer, Activation::Elu).unwrap();
    let reference = linear_reference(&x, &layer, Activation::Elu).unwrap();
    assert!(rel_err(&ours, &reference) < 1e-5);
    let loss = |y: &Tensor| y.t().unwrap().sum_all().unwrap();
    let g1 = loss(&ours).backward().unwrap();
    let g2 = loss(&reference).backward().unwrap();
    for v in [xt.as_tensor(), layer.weight.as_tensor(), layer.bias.as_tensor()] {
        assert!(rel_err(g1.get(v).unwrap(), g2.get(v).unwrap()) < 1e-4);
    }
}

#[test]
fn input_without_grad_gets_none() {
    let layer = Linear::new(5, 3, &mut rng(5)).unwrap();
    let x = rand_tensor(4, 5, 1.0, 6);
    let g = linear(&x, &layer, Activation::Elu).unwrap().sum_all().unwrap().backward().unwrap();
    assert!(g.get(&x).is_none());
    assert!(g.get(layer.weight.as_tensor()).is_some());
}

/// Ours (chain and layer-wise) against the reference: forward and every gradient, for a loss that uses the output
/// twice and mixes two forward calls of the same network (as the symmetry loss does).
fn check_mlp(dims: &[usize], rows: usize, seed: u64) {
    let mlp = Mlp::new(dims, &mut rng(seed)).unwrap();
    let x = Var::from_tensor(&rand_tensor(rows, dims[0], 2.0, seed + 1)).unwrap();
    let x2 = rand_tensor(rows, dims[0], 2.0, seed + 2);
    let out = *dims.last().unwrap();
    let r = rand_tensor(rows, out, 1.0, seed + 3);
    let loss = |f: &dyn Fn(&Tensor) -> Tensor| -> (Tensor, Tensor) {
        let y = f(x.as_tensor());
        let y2 = f(&x2);
        let l = ((&y * &r).unwrap().sum_all().unwrap() + y.sqr().unwrap().sum_all().unwrap()).unwrap();
        let l = (l + (&y2 - &y).unwrap().sqr().unwrap().sum_all().unwrap()).unwrap();
        (y, l)
    };
    let (y_ref, l_ref) = loss(&|t| mlp.forward_reference(t).unwrap());
    let g_ref = l_ref.backward().unwrap();
    let mut params = vec![x.as_tensor().clone()];
    params.extend(mlp.vars().iter().map(|v| v.as_tensor().clone()));
    for (name, fwd) in [
        ("chain", &(|t: &Tensor| mlp.forward(t).unwrap()) as &dyn Fn(&Tensor) -> Tensor),
        ("layerwise", &|t: &Tensor| mlp.forward_layerwise(t).unwrap()),
    ] {
        let (y, l) = loss(fwd);
        let e = rel_err(&y, &y_ref);
        assert!(e < 1e-5, "{name} {dims:?} forward rel err {e}");
        let g = l.backward().unwrap();
        for (i, p) in params.iter().enumerate() {
            let e = rel_err(g.get(p).unwrap(), g_ref.get(p).unwrap());
            assert!(e < 1e-4, "{name} {dims:?}: gradient of parameter {i}: rel err {e}");
        }
    }
}

#[test]
fn mlp_matches_candle() {
    check_mlp(&[5, 7, 3], 11, 30);
    check_mlp(&[3, 4, 6, 5, 2], 9, 31);
    check_mlp(&[42, 512, 256, 128, 10], 6144, 32);
    check_mlp(&[42, 512, 256, 128, 1], 1000, 33);
}

#[test]
fn mlp_backward_twice_and_identity_hidden() {
    let mut mlp = Mlp::new(&[4, 8, 3], &mut rng(40)).unwrap();
    mlp.hidden_activation = Activation::Identity;
    let x = rand_tensor(6, 4, 1.0, 41);
    let l = mlp.forward(&x).unwrap().sqr().unwrap().sum_all().unwrap();
    let l_ref = mlp.forward_reference(&x).unwrap().sqr().unwrap().sum_all().unwrap();
    let g_ref = l_ref.backward().unwrap();
    let g1 = l.backward().unwrap();
    let g2 = l.backward().unwrap();
    for v in mlp.vars() {
        assert!(rel_err(g1.get(&v).unwrap(), g_ref.get(&v).unwrap()) < 1e-4);
        assert_eq!(bits(g1.get(&v).unwrap()), bits(g2.get(&v).unwrap()));
    }
}

#[test]
fn mlp_strided_input_and_broadcast_gradient() {
    // Input given as a transposed view, loss = plain sum (candle hands the output a broadcast gradient).
    let mlp = Mlp::new(&[6, 9, 4], &mut rng(45)).unwrap();
    let xt = Var::from_tensor(&rand_tensor(6, 11, 2.0, 46)).unwrap();
    let x = xt.as_tensor().t().unwrap();
    let g = mlp.forward(&x).unwrap().sum_all().unwrap().backward().unwrap();
    let g_ref = mlp.forward_reference(&x).unwrap().sum_all().unwrap().backward().unwrap();
    assert!(rel_err(&mlp.forward(&x).unwrap(), &mlp.forward_reference(&x).unwrap()) < 1e-5);
    let mut params = vec![xt.as_tensor().clone()];
    params.extend(mlp.vars().iter().map(|v| v.as_tensor().clone()));
    for p in &params {
        assert!(rel_err(g.get(p).unwrap(), g_ref.get(p).unwrap()) < 1e-4);
    }
}

#[test]
fn empty_batch() {
    let mlp = Mlp::new(&[5, 7, 3], &mut rng(47)).unwrap();
    let x = Tensor::zeros((0, 5), candle_core::DType::F32, &Device::Cpu).unwrap();
    let y = mlp.forward(&x).unwrap();
    assert_eq!(y.dims(), &[0, 3]);
    let g = y.sum_all().unwrap().backward().unwrap();
    for v in mlp.vars() {
        assert_eq!(g.get(&v).unwrap().abs().unwrap().sum_all().unwrap().to_scalar::<f32>().unwrap(), 0.0);
    }
    let mut out = vec![1.0];
    mlp.forward_inference(&[], 0, &mut out, &mut MlpScratch::default());
    assert!(out.is_empty());
}

#[test]
fn finite_differences() {
    // Loss = Σ r ⊙ mlp(x) + ½ Σ mlp(x)², in f32; central differences with step h, compared in f64.
    let mlp = Mlp::new(&[3, 6, 5, 2], &mut rng(50)).unwrap();
    let x = rand_tensor(4, 3, 1.5, 51);
    let r = rand_tensor(4, 2, 1.0, 52);
    let loss = |m: &Mlp| -> Tensor {
        let y = m.forward(&x).unwrap();
        ((&y * &r).unwrap().sum_all().unwrap() + (y.sqr().unwrap().sum_all().unwrap() * 0.5).unwrap()).unwrap()
    };
    let grads = loss(&mlp).backward().unwrap();
    let h = 1e-2f32;
    let mut worst = 0.0f64;
    for v in mlp.vars() {
        let g = grads.get(&v).unwrap().flatten_all().unwrap().to_vec1::<f32>().unwrap();
        let base = v.as_tensor().flatten_all().unwrap().to_vec1::<f32>().unwrap();
        for i in 0..base.len() {
            let eval = |d: f32| -> f64 {
                let mut p = base.clone();
                p[i] += d;
                v.set(&Tensor::from_vec(p, v.shape(), &Device::Cpu).unwrap()).unwrap();
                loss(&mlp).to_scalar::<f32>().unwrap() as f64
            };
            let fd = (eval(h) - eval(-h)) / (2.0 * h as f64);
            v.set(&Tensor::from_vec(base.clone(), v.shape(), &Device::Cpu).unwrap()).unwrap();
            let err = (fd - g[i] as f64).abs() / (g[i].abs() as f64).max(1e-1);
            worst = worst.max(err);
        }
    }
    eprintln!("finite differences: worst relative error {worst:.2e}");
    assert!(worst < 1e-3, "finite-difference mismatch {worst}");
}

#[test]
fn forward_inference_equals_forward() {
    let mlp = Mlp::new(&[42, 512, 256, 128, 10], &mut rng(60)).unwrap();
    let mut scratch = MlpScratch::default();
    let mut out = Vec::new();
    for rows in [4096, 64, 1, 1000] {
        let x = rand_tensor(rows, 42, 2.0, 61 + rows as u64);
        let y = mlp.forward(&x).unwrap();
        let xv = x.flatten_all().unwrap().to_vec1::<f32>().unwrap();
        mlp.forward_inference(&xv, rows, &mut out, &mut scratch);
        assert_eq!(out.len(), rows * 10);
        let yb = bits(&y);
        let ob: Vec<u32> = out.iter().map(|v| v.to_bits()).collect();
        assert_eq!(yb, ob, "rows {rows}");
    }
}

#[test]
fn same_seed_same_weights() {
    let a = Mlp::new(&[42, 512, 256, 128, 10], &mut rng(7)).unwrap();
    let b = Mlp::new(&[42, 512, 256, 128, 10], &mut rng(7)).unwrap();
    let c = Mlp::new(&[42, 512, 256, 128, 10], &mut rng(8)).unwrap();
    for ((va, vb), vc) in a.vars().iter().zip(b.vars()).zip(c.vars()) {
        assert_eq!(bits(va.as_tensor()), bits(vb.as_tensor()));
        assert_ne!(bits(va.as_tensor()), bits(vc.as_tensor()));
    }
    // PyTorch's bound: every weight of the first layer within 1/√42.
    let w = a.layers[0].weight.as_tensor().abs().unwrap().max_all().unwrap().to_scalar::<f32>().unwrap();
    assert!(w <= 1.0 / 42f32.sqrt() && w > 0.9 / 42f32.sqrt());
}

/// Forward output and every gradient of a symmetry-style loss, computed inside a rayon pool of `threads`.
fn run_in_pool(threads: usize, mlp: &Mlp, x: &Tensor, xm: &Tensor) -> Vec<Vec<u32>> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let y = mlp.forward(x).unwrap();
        let ym = mlp.forward(xm).unwrap();
        let l = (y.sqr().unwrap().sum_all().unwrap() + (&ym - &y).unwrap().sqr().unwrap().sum_all().unwrap()).unwrap();
        let g = l.backward().unwrap();
        let mut out = vec![bits(&y), bits(&ym)];
        out.extend(mlp.vars().iter().map(|v| bits(g.get(v).unwrap())));
        let mut inf = Vec::new();
        mlp.forward_inference(
            &x.flatten_all().unwrap().to_vec1::<f32>().unwrap(),
            x.dim(0).unwrap(),
            &mut inf,
            &mut MlpScratch::default(),
        );
        out.push(inf.iter().map(|v| v.to_bits()).collect());
        out
    })
}

#[test]
fn bit_identical_across_thread_counts() {
    let mlp = Mlp::new(&[42, 512, 256, 128, 10], &mut rng(70)).unwrap();
    let x = rand_tensor(6144, 42, 2.0, 71);
    let xm = rand_tensor(6144, 42, 2.0, 72);
    let one = run_in_pool(1, &mlp, &x, &xm);
    let two = run_in_pool(2, &mlp, &x, &xm);
    let three = run_in_pool(3, &mlp, &x, &xm);
    assert!(one == two, "1 vs 2 threads differ");
    assert!(one == three, "1 vs 3 threads differ");
    assert_eq!(one, run_in_pool(2, &mlp, &x, &xm), "2 threads not deterministic");
}

#[test]
fn gemm_parallel_mode_is_thread_count_invariant() {
    // The gemm crate (candle's matmul) in its rayon mode, on the weight-gradient shape (reduction over 6144).
    let (m, n, k) = (256, 512, 6144);
    let a: Vec<f32> = rand_tensor(k, m, 1.0, 80).flatten_all().unwrap().to_vec1().unwrap();
    let b: Vec<f32> = rand_tensor(k, n, 1.0, 81).flatten_all().unwrap().to_vec1().unwrap();
    let run = |par: ::gemm::Parallelism| -> Vec<u32> {
        let mut c = vec![0.0f32; m * n];
        // SAFETY: the buffers hold m×k (column-major lhs), k×n and m×n elements.
        unsafe {
            ::gemm::gemm(
                m,
                n,
                k,
                c.as_mut_ptr(),
                1,
                n as isize,
                false,
                a.as_ptr(),
                m as isize,
                1,
                b.as_ptr(),
                1,
                n as isize,
                0.0,
                1.0,
                false,
                false,
                false,
                par,
            )
        };
        c.iter().map(|v| v.to_bits()).collect()
    };
    let one = run(::gemm::Parallelism::None);
    for t in [2, 3] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(t).build().unwrap();
        assert!(one == pool.install(|| run(::gemm::Parallelism::Rayon(t))), "gemm with {t} threads differs");
    }
}

/// Timing of the layer primitives on the paper's shapes (single thread). Not a test:
/// `cargo test --release -p trainer nn::tests::bench_layer_ops -- --ignored --nocapture` (`NN_GEMM=crate` for the
/// `gemm` crate).
#[test]
#[ignore]
fn bench_layer_ops() {
    use super::gemm::{MatRef, PackedB};
    use std::time::Instant;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let m = 6144;
    let best = |f: &mut dyn FnMut()| -> f64 {
        let mut b = f64::MAX;
        for _ in 0..30 {
            let t = Instant::now();
            f();
            b = b.min(t.elapsed().as_secs_f64());
        }
        b
    };
    pool.install(|| {
        let mut total = 0.0;
        for (k, n) in [(42usize, 512usize), (512, 256), (256, 128), (128, 10)] {
            let x: Vec<f32> = rand_tensor(m, k, 2.0, 1).flatten_all().unwrap().to_vec1().unwrap();
            let w: Vec<f32> = rand_tensor(n, k, 0.1, 2).flatten_all().unwrap().to_vec1().unwrap();
            let b = vec![0.01f32; n];
            let mut y = vec![0.0f32; m * n];
            let mut pb = PackedB::default();
            let flops = 2.0 * (m * n * k) as f64;
            let xv = MatRef::row_major(&x, k);
            let tf = best(&mut || layer::forward(xv, m, k, &w, &b, n, Activation::Elu, &mut y, &mut pb));
            let dz = y.clone();
            let yprev: Vec<f32> = rand_tensor(m, k, 2.0, 3).flatten_all().unwrap().to_vec1().unwrap();
            let ti = best(&mut || {
                std::hint::black_box(layer::input_grad(&dz, &w, m, n, k, Some((&yprev, Activation::Elu))));
            });
            let tw = best(&mut || {
                std::hint::black_box(layer::weight_grad(&dz, xv, m, n, k));
            });
            total += tf * 3.0 + ti * 3.0 + tw * 3.0;
            println!(
                "{k:>3}->{n:<3} forward {:6.2} ms {:5.1} GF/s | input_grad {:6.2} ms {:5.1} GF/s | weight_grad {:6.2} ms {:5.1} GF/s",
                tf * 1e3, flops / tf / 1e9, ti * 1e3, flops / ti / 1e9, tw * 1e3, flops / tw / 1e9
            );
        }
        println!("3 x (fwd + dX + dW) over the layers: {:.1} ms", total * 1e3);
    });
}

#[test]
fn an_mlp_composes_with_candle_nn() {
    // A candle user stacks our network with candle-nn layers through the `Module` trait.
    use candle_core::Module;
    let mlp = Mlp::new(&[6, 16, 3], &mut rng(7)).unwrap();
    let x = rand_tensor(5, 6, 1.0, 8);
    let model = candle_nn::seq().add(mlp.clone()).add_fn(|t| t.tanh());
    let y = model.forward(&x).unwrap();
    let expected = mlp.forward_reference(&x).unwrap().tanh().unwrap();
    assert!(rel_err(&y, &expected) < 1e-6);
}
