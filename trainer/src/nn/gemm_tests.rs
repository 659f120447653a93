//! The GEMM kernel against a naive f64 product, on shapes that exercise every edge path.
use super::*;
use std::cell::Cell;

thread_local! {
    /// Makes [`wide_kernel`] answer `false` on this thread: the AVX2 kernel alone, to compare against.
    pub(crate) static FORCE_AVX2: Cell<bool> = const { Cell::new(false) };
}

fn naive(m: usize, n: usize, k: usize, a: MatRef, b: MatRef) -> Vec<f64> {
    let mut c = vec![0.0f64; m * n];
    for i in 0..m {
        for j in 0..n {
            for p in 0..k {
                // SAFETY: i < m, p < k, j < n: inside both matrices.
                c[i * n + j] += unsafe { a.at(i, p) as f64 * b.at(p, j) as f64 };
            }
        }
    }
    c
}

#[test]
fn matches_naive_for_all_layouts_and_edges() {
    for &(m, n, k) in &[(1, 1, 1), (7, 5, 3), (13, 17, 300), (130, 33, 513), (6, 16, 256), (121, 48, 42)] {
        let av: Vec<f32> = (0..m * k).map(|i| ((i * 37 % 101) as f32 - 50.0) / 50.0).collect();
        let bv: Vec<f32> = (0..k * n).map(|i| ((i * 53 % 97) as f32 - 48.0) / 48.0).collect();
        let cv: Vec<f32> = (0..m * n).map(|i| ((i * 11 % 13) as f32 - 6.0) / 6.0).collect();
        for (at, bt) in [(false, false), (true, false), (false, true), (true, true)] {
            let a = if at { MatRef { ptr: av.as_ptr(), rs: 1, cs: m as isize } } else { MatRef::row_major(&av, k) };
            let b = if bt { MatRef { ptr: bv.as_ptr(), rs: 1, cs: k as isize } } else { MatRef::row_major(&bv, n) };
            let want = naive(m, n, k, a, b);
            for accumulate in [false, true] {
                // Written into a wider C (ldc = n + 3) to check the row stride and that nothing spills.
                let ldc = n + 3;
                let mut c = vec![7.0f32; m * ldc];
                for i in 0..m {
                    c[i * ldc..i * ldc + n].copy_from_slice(&cv[i * n..(i + 1) * n]);
                }
                // SAFETY: a, b and c were allocated with the shapes and strides passed; c overlaps neither input.
                unsafe { matmul(m, n, k, a, b, c.as_mut_ptr(), ldc, accumulate, Epilogue::None) };
                for i in 0..m {
                    for j in 0..n {
                        let w = want[i * n + j] + if accumulate { cv[i * n + j] as f64 } else { 0.0 };
                        let got = c[i * ldc + j] as f64;
                        assert!((got - w).abs() <= 1e-5 * (1.0 + w.abs()) * (k as f64).sqrt(), "{m}x{n}x{k} {at} {bt}");
                    }
                    assert!(c[i * ldc + n..i * ldc + ldc].iter().all(|&v| v == 7.0));
                }
            }
        }
    }
}

#[test]
fn epilogue_matches_separate_pass() {
    let (m, n, k) = (25, 37, 70);
    let av: Vec<f32> = (0..m * k).map(|i| ((i * 37 % 101) as f32 - 50.0) / 20.0).collect();
    let bv: Vec<f32> = (0..k * n).map(|i| ((i * 53 % 97) as f32 - 48.0) / 48.0).collect();
    let bias: Vec<f32> = (0..n).map(|j| (j as f32 - 18.0) / 9.0).collect();
    let (a, b) = (MatRef::row_major(&av, k), MatRef::row_major(&bv, n));
    for act in [Activation::Elu, Activation::Identity] {
        let mut fused = vec![0.0f32; m * n];
        let mut plain = vec![0.0f32; m * n];
        // SAFETY: buffers allocated with the shapes and strides passed; outputs overlap no input.
        unsafe {
            matmul(m, n, k, a, b, fused.as_mut_ptr(), n, false, Epilogue::BiasAct(&bias, act));
            matmul(m, n, k, a, b, plain.as_mut_ptr(), n, false, Epilogue::None);
        }
        kernels::bias_act_rows(&mut plain, n, &bias, act);
        let fb: Vec<u32> = fused.iter().map(|v| v.to_bits()).collect();
        let pb: Vec<u32> = plain.iter().map(|v| v.to_bits()).collect();
        assert_eq!(fb, pb, "{act:?}");
    }
}

#[test]
fn the_avx512_kernel_gives_the_avx2_kernels_bits() {
    if !wide_kernel() {
        eprintln!("skipped: this CPU has no AVX-512F (or NN_GEMM chose another kernel)");
        return;
    }
    // Odd and even panel counts (n = 10, 33, 64, 150), partial row tiles, two k-blocks (k = 600), both layouts.
    for &(m, n, k) in &[(7, 10, 42), (13, 33, 300), (130, 64, 600), (61, 150, 128), (6, 32, 5)] {
        let av: Vec<f32> = (0..m * k).map(|i| ((i * 37 % 101) as f32 - 50.0) / 30.0).collect();
        let bv: Vec<f32> = (0..k * n).map(|i| ((i * 53 % 97) as f32 - 48.0) / 48.0).collect();
        let bias: Vec<f32> = (0..n).map(|j| (j as f32 - 18.0) / 9.0).collect();
        for at in [false, true] {
            let a = if at { MatRef { ptr: av.as_ptr(), rs: 1, cs: m as isize } } else { MatRef::row_major(&av, k) };
            let b = MatRef::row_major(&bv, n);
            for epi in [Epilogue::None, Epilogue::BiasAct(&bias, Activation::Elu)] {
                for accumulate in [false, true] {
                    let product = |avx2_only: bool| {
                        FORCE_AVX2.with(|f| f.set(avx2_only));
                        let mut c: Vec<f32> = (0..m * n).map(|i| ((i * 11 % 13) as f32 - 6.0) / 6.0).collect();
                        // SAFETY: a, b and c allocated with the shapes and strides passed; c overlaps no input.
                        unsafe { matmul(m, n, k, a, b, c.as_mut_ptr(), n, accumulate, epi) };
                        FORCE_AVX2.with(|f| f.set(false));
                        c.iter().map(|v| v.to_bits()).collect::<Vec<u32>>()
                    };
                    assert_eq!(product(false), product(true), "{m}x{n}x{k} at={at} accumulate={accumulate}");
                }
            }
        }
    }
}
