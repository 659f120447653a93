//! Forward and backward of one dense layer on raw f32 slices: the compute behind the candle custom ops.
//!
//! Parallelism and determinism. Wherever the blocking could change the arithmetic, work is split into blocks whose
//! size does not depend on the thread count, and a reduction is never split across threads:
//! * products with the batch as the row dimension (forward `X·Wᵀ`, backward `dZ·W`) are cut into blocks of
//!   rows; each block is one single-threaded product (with bias + ELU fused in its epilogue in the forward,
//!   followed by ELU' and the bias-gradient partial sums of the previous layer in the backward). In the backward
//!   the blocks are [`ROW_BLOCK`] rows, since the bias-gradient partial sums follow them; in the forward, where
//!   with our kernel each row's result is independent of the blocking, they are sized to the thread count;
//! * the weight gradient `dZᵀ·X` (a reduction over the batch) is cut into fixed chunks of [`WG_CHUNK`] batch
//!   rows, one single-threaded product each, and the chunk results are added in chunk order;
//! * bias gradients are summed per row block (rows in order), then the block partials are added in block order.
//!
//! Blocks are handed to the rayon pool the caller runs in (the global pool unless inside `install`); whichever
//! thread runs a block does the same arithmetic in the same order, so results are bit-identical for any thread
//! count. The products' own summation order depends only on `k` (see [`super::gemm`]), so the forward of a row
//! does not depend on the batch it is in either.

use super::gemm::{self, Epilogue, MatRef, PackedB};
use super::kernels;
use super::kernels::Activation;
use rayon::prelude::*;

/// Rows per block in the batch-parallel products (a multiple of [`gemm::MR`]). Also the granularity of the
/// bias-gradient partial sums.
pub(crate) const ROW_BLOCK: usize = 768;
/// Rows (batch samples) per chunk of the weight-gradient reduction.
pub(crate) const WG_CHUNK: usize = 1536;

#[derive(Clone, Copy)]
struct MutPtr(*mut f32);
// SAFETY: used only to hand disjoint output blocks to rayon tasks.
unsafe impl Send for MutPtr {}
unsafe impl Sync for MutPtr {}

impl MutPtr {
    /// The pointer (a method, so that closures capture the `Sync` wrapper rather than the raw field).
    fn get(self) -> *mut f32 {
        self.0
    }
}

/// Runs `f(block)` for `block in 0..n_blocks` on the current rayon pool (inline when it has one thread).
pub(crate) fn for_each_block(n_blocks: usize, f: impl Fn(usize) + Sync + Send) {
    if n_blocks <= 1 || rayon::current_num_threads() <= 1 {
        (0..n_blocks).for_each(f);
    } else {
        (0..n_blocks).into_par_iter().with_max_len(1).for_each(f);
    }
}

/// A vector of `len` floats that the caller will overwrite entirely.
fn uninit_vec(len: usize) -> Vec<f32> {
    let mut v = Vec::with_capacity(len);
    // SAFETY: f32 has no invalid bit patterns; every caller writes all `len` elements before reading any.
    #[allow(clippy::uninit_vec)]
    unsafe {
        v.set_len(len)
    };
    v
}

/// Forward of one layer: `y[m×n] = act(x[m×k] · wᵀ + b)`, with `w` row-major `[n, k]` and `y.len() == m·n`.
/// `packed` receives the packed weights (a reusable buffer).
#[allow(clippy::too_many_arguments)]
pub(crate) fn forward(
    x: MatRef,
    m: usize,
    k: usize,
    w: &[f32],
    b: &[f32],
    n: usize,
    act: Activation,
    y: &mut [f32],
    packed: &mut PackedB,
) {
    assert_eq!(w.len(), n * k);
    assert_eq!(b.len(), n);
    assert_eq!(y.len(), m * n);
    // SAFETY: `w` holds n×k floats and outlives `packed`'s use below.
    unsafe { packed.pack(MatRef::row_major(w, k).t(), k, n) };
    let packed = &*packed;
    let yp = MutPtr(y.as_mut_ptr());
    // With our kernel a row's result does not depend on the block it is computed in, so the forward may size its
    // blocks to the pool: about 4 per thread (balance), between 96 and ROW_BLOCK rows (cache). The `gemm` crate
    // switches kernels (and summation order) for very small products, so its path keeps fixed blocks.
    let block = if gemm::own_kernel() {
        let threads = rayon::current_num_threads().max(1);
        m.div_ceil(4 * threads).next_multiple_of(gemm::MR).clamp(96, ROW_BLOCK)
    } else {
        ROW_BLOCK
    };
    for_each_block(m.div_ceil(block), |blk| {
        let r0 = blk * block;
        let rows = block.min(m - r0);
        // SAFETY: blocks are disjoint row ranges of `y`; `x` has m rows of k.
        unsafe {
            gemm::matmul_packed(
                rows,
                x.rows_from(r0),
                packed,
                yp.get().add(r0 * n),
                n,
                false,
                Epilogue::BiasAct(b, act),
            )
        };
    });
}

/// Sums per-row-block partials (laid out block after block, `n` each) in block order.
fn reduce_partials(partials: &[f32], n: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; n];
    for p in partials.chunks_exact(n) {
        kernels::add_assign(&mut out, p);
    }
    out
}

/// Gradient with respect to the pre-activation of the *last* layer of a chain (or of a single layer):
/// `dz = dy ⊙ act'(y)`, plus the bias gradient `db = Σ_rows dz`. `dy` is a strided `[m, n]` view with
/// non-negative strides (candle's layouts).
pub(crate) fn output_grad(dy: MatRef, y: &[f32], m: usize, n: usize, act: Activation) -> (Vec<f32>, Vec<f32>) {
    assert!(dy.rs >= 0 && dy.cs >= 0, "negative strides");
    let mut dz = uninit_vec(m * n);
    let n_blocks = m.div_ceil(ROW_BLOCK);
    let mut partials = vec![0.0f32; n_blocks * n];
    let dzp = MutPtr(dz.as_mut_ptr());
    let pp = MutPtr(partials.as_mut_ptr());
    let (rs, cs) = (dy.rs as usize, dy.cs as usize);
    for_each_block(n_blocks, |blk| {
        let r0 = blk * ROW_BLOCK;
        let rows = ROW_BLOCK.min(m - r0);
        // SAFETY: disjoint row ranges of `dz` and disjoint partial slots; the `dy` view covers m×n elements with
        // non-negative strides, so the block is the slice from its first element.
        unsafe {
            let dzb = std::slice::from_raw_parts_mut(dzp.get().add(r0 * n), rows * n);
            let part = std::slice::from_raw_parts_mut(pp.get().add(blk * n), n);
            let yb = &y[r0 * n..(r0 + rows) * n];
            let len = if rows == 0 || n == 0 { 0 } else { (rows - 1) * rs + (n - 1) * cs + 1 };
            let dyb = std::slice::from_raw_parts(dy.rows_from(r0).ptr, len);
            kernels::act_backward_rows(dyb, rs, cs, yb, dzb, n, act, part);
        }
    });
    let db = reduce_partials(&partials, n);
    (dz, db)
}

/// Padding overhead of a `rows × cols` product on the `MR × NR` register tile.
fn tile_waste(rows: usize, cols: usize) -> f64 {
    (rows.div_ceil(gemm::MR) * gemm::MR * cols.div_ceil(gemm::NR) * gemm::NR) as f64 / (rows * cols).max(1) as f64
}

/// `dw[n×k] = dzᵀ · x`: dz row-major `[m, n]`, x a strided `[m, k]` view. The batch is cut into chunks of
/// [`WG_CHUNK`] rows; each chunk's product is one single-threaded product (chunks run in parallel), and the chunk
/// results are then added in chunk order. The chunking depends only on `m`.
///
/// When the transposed product `dwᵀ = xᵀ · dz` fits the register tile better (the first layer: 42 inputs pad to
/// 48 columns, but are exactly 7 tiles of 6 rows), that one is computed and transposed at the end (`n·k`
/// elements, negligible next to the product). The choice depends only on the shape.
pub(crate) fn weight_grad(dz: &[f32], x: MatRef, m: usize, n: usize, k: usize) -> Vec<f32> {
    let n_chunks = m.div_ceil(WG_CHUNK).max(1);
    let size = n * k;
    let transposed = tile_waste(k, n) < tile_waste(n, k);
    // The product's operands and shape: C[rows × cols] = A · B.
    let dzv = MatRef::row_major(dz, n);
    let (rows, cols, a, b) = if transposed { (k, n, x.t(), dzv) } else { (n, k, dzv.t(), x) };
    // Chunk 0 writes straight into the result buffer, chunks 1.. into partial buffers.
    let mut acc = uninit_vec(size);
    let mut partials = uninit_vec(size * (n_chunks - 1));
    let accp = MutPtr(acc.as_mut_ptr());
    let pp = MutPtr(partials.as_mut_ptr());
    for_each_block(n_chunks, |c| {
        let r0 = c * WG_CHUNK;
        let len = WG_CHUNK.min(m - r0);
        let dst = if c == 0 { accp.get() } else { pp.get().wrapping_add((c - 1) * size) };
        // SAFETY: each chunk writes its own rows×cols buffer; the views cover batch rows r0..r0+len.
        unsafe { gemm::matmul(rows, cols, len, a.cols_from(r0), b.rows_from(r0), dst, cols, false, Epilogue::None) };
    });
    if n_chunks > 1 {
        // Fixed-order sum, parallel over element ranges (element-wise, so thread-count invariant).
        let span = 16 * 1024;
        let accp = MutPtr(acc.as_mut_ptr());
        for_each_block(size.div_ceil(span), |blk| {
            let lo = blk * span;
            let hi = size.min(lo + span);
            // SAFETY: disjoint element ranges of acc.
            let dst = unsafe { std::slice::from_raw_parts_mut(accp.get().add(lo), hi - lo) };
            for p in partials.chunks_exact(size) {
                kernels::add_assign(dst, &p[lo..hi]);
            }
        });
    }
    if !transposed {
        return acc;
    }
    let mut dw = uninit_vec(size);
    for i in 0..k {
        for j in 0..n {
            dw[j * k + i] = acc[i * n + j];
        }
    }
    dw
}

/// `dx[m×k] = dz[m×n] · w[n×k]`, and when `prev` is given (the previous layer's stored output `y_prev` and
/// activation), the epilogue turns `dx` into that layer's pre-activation gradient `dx ⊙ act'(y_prev)` and also
/// returns its bias gradient.
pub(crate) fn input_grad(
    dz: &[f32],
    w: &[f32],
    m: usize,
    n: usize,
    k: usize,
    prev: Option<(&[f32], Activation)>,
) -> (Vec<f32>, Option<Vec<f32>>) {
    assert_eq!(w.len(), n * k);
    let mut dx = uninit_vec(m * k);
    let n_blocks = m.div_ceil(ROW_BLOCK);
    let mut partials = vec![0.0f32; if prev.is_some() { n_blocks * k } else { 0 }];
    let dxp = MutPtr(dx.as_mut_ptr());
    let pp = MutPtr(partials.as_mut_ptr());
    let lhs = MatRef::row_major(dz, n);
    let mut packed = PackedB::default();
    // SAFETY: `w` holds n×k floats and outlives `packed`.
    unsafe { packed.pack(MatRef::row_major(w, k), n, k) };
    let packed = &packed;
    for_each_block(n_blocks, |blk| {
        let r0 = blk * ROW_BLOCK;
        let rows = ROW_BLOCK.min(m - r0);
        // SAFETY: disjoint row ranges of dx (m·k floats) and disjoint partial slots; y_prev is m×k.
        unsafe {
            let dxb = dxp.get().add(r0 * k);
            gemm::matmul_packed(rows, lhs.rows_from(r0), packed, dxb, k, false, Epilogue::None);
            if let Some((y_prev, act)) = prev {
                // A separate pass over the block (still in L2/L3): as fast as doing it in the kernel's epilogue
                // (measured), and simpler.
                let g = std::slice::from_raw_parts_mut(dxb, rows * k);
                let part = std::slice::from_raw_parts_mut(pp.get().add(blk * k), k);
                kernels::act_backward_inplace_rows(g, &y_prev[r0 * k..(r0 + rows) * k], k, act, part);
            }
        }
    });
    let db = prev.map(|_| reduce_partials(&partials, k));
    (dx, db)
}
