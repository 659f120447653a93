//! Forward and backward of one dense layer on raw f32 slices: the compute behind the candle custom ops.
//!
//! Parallelism and determinism. Work is split into *fixed* blocks whose size never depends on the thread count,
//! and a reduction is never split across threads:
//! * products with the batch as the row dimension (forward `X·Wᵀ`, backward `dZ·W`) are cut into blocks of
//!   [`ROW_BLOCK`] rows; each block is one single-threaded `gemm` call followed by its element-wise epilogue
//!   (bias + ELU, or ELU' + bias-gradient partial sums) while the block is still in cache;
//! * the weight gradient `dZᵀ·X` (a reduction over the batch) is cut into fixed chunks of [`WG_CHUNK`] batch
//!   rows, one single-threaded product each, and the chunk results are added in chunk order;
//! * bias gradients are summed per row block (rows in order), then the block partials are added in block order.
//!
//! Blocks are handed to the rayon global pool; whichever thread runs a block, it does the same arithmetic in the
//! same order, so results are bit-identical for 1, 2, … threads.

use super::kernels;
use super::Activation;
use rayon::prelude::*;

/// Rows per block in the batch-parallel products. Also the granularity of the bias-gradient partial sums.
pub(crate) const ROW_BLOCK: usize = 768;
/// Rows (batch samples) per chunk of the weight-gradient reduction.
pub(crate) const WG_CHUNK: usize = 1536;

/// A read-only strided matrix view: element `(i, j)` is at `ptr + i·rs + j·cs`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MatRef {
    pub ptr: *const f32,
    pub rs: isize,
    pub cs: isize,
}
// SAFETY: a MatRef is only built from slices that outlive the parallel section that reads them, and is read-only.
unsafe impl Send for MatRef {}
unsafe impl Sync for MatRef {}

impl MatRef {
    pub fn row_major(data: &[f32], cols: usize) -> Self {
        MatRef { ptr: data.as_ptr(), rs: cols as isize, cs: 1 }
    }
    /// The view starting at row `r`.
    fn rows_from(self, r: usize) -> Self {
        MatRef { ptr: self.ptr.wrapping_offset(r as isize * self.rs), ..self }
    }
    /// The view starting at column `c`.
    fn cols_from(self, c: usize) -> Self {
        MatRef { ptr: self.ptr.wrapping_offset(c as isize * self.cs), ..self }
    }
    /// The transposed view.
    fn t(self) -> Self {
        MatRef { ptr: self.ptr, rs: self.cs, cs: self.rs }
    }
}

#[derive(Clone, Copy)]
struct MutPtr(*mut f32);
// SAFETY: used only to hand disjoint output blocks to rayon tasks.
unsafe impl Send for MutPtr {}
unsafe impl Sync for MutPtr {}

/// `dst[m×n] (row stride ld) = lhs[m×k] · rhs[k×n]`, single-threaded.
///
/// # Safety
/// The views must cover `m×k` and `k×n` valid elements and `dst` `m` rows of `n` valid elements.
#[inline]
unsafe fn gemm_st(m: usize, n: usize, k: usize, dst: *mut f32, ld: usize, lhs: MatRef, rhs: MatRef) {
    if m == 0 || n == 0 {
        return;
    }
    if k == 0 {
        for i in 0..m {
            std::ptr::write_bytes(dst.add(i * ld), 0, n);
        }
        return;
    }
    gemm::gemm(
        m,
        n,
        k,
        dst,
        1,
        ld as isize,
        false,
        lhs.ptr,
        lhs.cs,
        lhs.rs,
        rhs.ptr,
        rhs.cs,
        rhs.rs,
        0.0,
        1.0,
        false,
        false,
        false,
        gemm::Parallelism::None,
    );
}

/// Runs `f(block)` for `block in 0..n_blocks` on the rayon global pool (inline when it has one thread).
pub(crate) fn for_each_block(n_blocks: usize, f: impl Fn(usize) + Sync + Send) {
    if n_blocks <= 1 || rayon::current_num_threads() <= 1 {
        (0..n_blocks).for_each(f);
    } else {
        (0..n_blocks).into_par_iter().with_max_len(1).for_each(f);
    }
}

/// Forward of one layer: `y[m×n] = act(x[m×k] · wᵀ + b)`, with `w` row-major `[n, k]`. `y.len() == m·n`.
pub(crate) fn forward(x: MatRef, m: usize, k: usize, w: &[f32], b: &[f32], n: usize, act: Activation, y: &mut [f32]) {
    assert_eq!(w.len(), n * k);
    assert_eq!(b.len(), n);
    assert_eq!(y.len(), m * n);
    let wt = MatRef::row_major(w, k).t();
    let yp = MutPtr(y.as_mut_ptr());
    let n_blocks = m.div_ceil(ROW_BLOCK);
    for_each_block(n_blocks, |blk| {
        let yp = yp;
        let r0 = blk * ROW_BLOCK;
        let rows = ROW_BLOCK.min(m - r0);
        // SAFETY: blocks are disjoint row ranges of `y`; `x` has m rows.
        unsafe {
            let yb = yp.0.add(r0 * n);
            gemm_st(rows, n, k, yb, n, x.rows_from(r0), wt);
            kernels::bias_act_rows(std::slice::from_raw_parts_mut(yb, rows * n), n, b, act);
        }
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
/// `dz = dy ⊙ act'(y)`, plus the bias gradient `db = Σ_rows dz`. `dy` is a strided `[m, n]` view.
pub(crate) fn output_grad(dy: MatRef, y: &[f32], m: usize, n: usize, act: Activation) -> (Vec<f32>, Vec<f32>) {
    let mut dz = Vec::<f32>::with_capacity(m * n);
    let n_blocks = m.div_ceil(ROW_BLOCK);
    let mut partials = vec![0.0f32; n_blocks * n];
    let dzp = MutPtr(dz.as_mut_ptr());
    let pp = MutPtr(partials.as_mut_ptr());
    assert!(dy.rs >= 0 && dy.cs >= 0, "negative strides");
    let (rs, cs) = (dy.rs as usize, dy.cs as usize);
    for_each_block(n_blocks, |blk| {
        let (dzp, pp, dy) = (dzp, pp, dy);
        let r0 = blk * ROW_BLOCK;
        let rows = ROW_BLOCK.min(m - r0);
        // SAFETY: disjoint row ranges of `dz` and disjoint partial slots; `dz` has capacity m·n; the `dy` view
        // covers m×n elements with non-negative strides, so the block is the slice from its first element.
        unsafe {
            let dzb = std::slice::from_raw_parts_mut(dzp.0.add(r0 * n), rows * n);
            let part = std::slice::from_raw_parts_mut(pp.0.add(blk * n), n);
            let yb = &y[r0 * n..(r0 + rows) * n];
            let len = if rows == 0 || n == 0 { 0 } else { (rows - 1) * rs + (n - 1) * cs + 1 };
            let dyb = std::slice::from_raw_parts(dy.ptr.add(r0 * rs), len);
            kernels::act_backward_rows(dyb, rs, cs, yb, dzb, n, act, part);
        }
    });
    // SAFETY: every element of dz was written by exactly one block.
    unsafe { dz.set_len(m * n) };
    let db = reduce_partials(&partials, n);
    (dz, db)
}

/// `dw[n×k] = dzᵀ · x`: dz row-major `[m, n]`, x a strided `[m, k]` view. The batch is cut into chunks of
/// [`WG_CHUNK`] rows; each chunk's product `dz_cᵀ · x_c` is one single-threaded gemm (chunks run in parallel), and
/// the chunk results are then added in chunk order. The chunking depends only on `m`, never on the thread count.
pub(crate) fn weight_grad(dz: &[f32], x: MatRef, m: usize, n: usize, k: usize) -> Vec<f32> {
    let n_chunks = m.div_ceil(WG_CHUNK).max(1);
    let size = n * k;
    // Chunk 0 writes straight into the result, chunks 1.. into partial buffers.
    let mut dw = Vec::<f32>::with_capacity(size);
    let mut partials = Vec::<f32>::with_capacity(size * (n_chunks - 1));
    let dwp = MutPtr(dw.as_mut_ptr());
    let pp = MutPtr(partials.as_mut_ptr());
    let dzt = MatRef::row_major(dz, n).t();
    for_each_block(n_chunks, |c| {
        let (dwp, pp) = (dwp, pp);
        let r0 = c * WG_CHUNK;
        let rows = WG_CHUNK.min(m - r0);
        let dst = if c == 0 { dwp.0 } else { pp.0.wrapping_add((c - 1) * size) };
        // SAFETY: each chunk writes its own n×k buffer; the views cover rows r0..r0+rows.
        unsafe { gemm_st(n, k, rows, dst, k, dzt.cols_from(r0), x.rows_from(r0)) };
    });
    // SAFETY: every buffer was fully written by its chunk.
    unsafe {
        dw.set_len(size);
        partials.set_len(size * (n_chunks - 1));
    }
    if n_chunks > 1 {
        // Fixed-order sum, parallel over element ranges (element-wise, so thread-count invariant).
        let span = 16 * 1024;
        let dwp = MutPtr(dw.as_mut_ptr());
        for_each_block(size.div_ceil(span), |b| {
            let dwp = dwp;
            let lo = b * span;
            let hi = size.min(lo + span);
            // SAFETY: disjoint element ranges of dw.
            let acc = unsafe { std::slice::from_raw_parts_mut(dwp.0.add(lo), hi - lo) };
            for p in partials.chunks_exact(size) {
                kernels::add_assign(acc, &p[lo..hi]);
            }
        });
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
    let mut dx = Vec::<f32>::with_capacity(m * k);
    let n_blocks = m.div_ceil(ROW_BLOCK);
    let mut partials = vec![0.0f32; if prev.is_some() { n_blocks * k } else { 0 }];
    let dxp = MutPtr(dx.as_mut_ptr());
    let pp = MutPtr(partials.as_mut_ptr());
    let lhs = MatRef::row_major(dz, n);
    let rhs = MatRef::row_major(w, k);
    for_each_block(n_blocks, |blk| {
        let (dxp, pp) = (dxp, pp);
        let r0 = blk * ROW_BLOCK;
        let rows = ROW_BLOCK.min(m - r0);
        // SAFETY: disjoint row ranges of dx (capacity m·k) and disjoint partial slots.
        unsafe {
            let dxb = dxp.0.add(r0 * k);
            gemm_st(rows, k, n, dxb, k, lhs.rows_from(r0), rhs);
            if let Some((y_prev, act)) = prev {
                let g = std::slice::from_raw_parts_mut(dxb, rows * k);
                let part = std::slice::from_raw_parts_mut(pp.0.add(blk * k), k);
                kernels::act_backward_inplace_rows(g, &y_prev[r0 * k..(r0 + rows) * k], k, act, part);
            }
        }
    });
    // SAFETY: all rows written.
    unsafe { dx.set_len(m * k) };
    let db = prev.map(|_| reduce_partials(&partials, k));
    (dx, db)
}
