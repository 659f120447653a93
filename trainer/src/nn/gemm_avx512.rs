//! The AVX-512 kernel of [`super`]: a 6×32 register tile (two packed 16-column panels side by side, one 16-lane
//! vector each), chosen at run time where the CPU has AVX-512F. Every element of `C` is the same FMA chain in `k`
//! order as in the AVX2 kernel, and the ELU epilogue the same operations in the same order, so both kernels give
//! bit-identical results: a run does not change with the CPU that trains it. What the wider tile saves is
//! instructions per FLOP (one broadcast feeds 32 columns), which pays on CPUs with two 512-bit FMA units.

use super::kernels::{self, Activation};
use super::{MR, NR};
use std::arch::x86_64::*;

/// Columns of the wide tile: two panels.
pub(super) const NR2: usize = 2 * NR;

/// `true` when the CPU has AVX-512F (checked once; `is_x86_feature_detected!` caches it).
pub(super) fn available() -> bool {
    std::arch::is_x86_feature_detected!("avx512f")
}

/// ELU on 16 lanes: the operations of `elu8` in the AVX2 kernel (and of [`kernels::elu`]), in the same order.
///
/// # Safety
/// The CPU must have AVX-512F (callers are `target_feature(enable = "avx512f")` functions).
#[inline(always)]
unsafe fn elu16(z: __m512) -> __m512 {
    let zero = _mm512_setzero_ps();
    let zc = _mm512_max_ps(_mm512_min_ps(z, zero), _mm512_set1_ps(-87.0));
    let magic = _mm512_set1_ps(kernels::ROUND_MAGIC);
    let t = _mm512_fmadd_ps(zc, _mm512_set1_ps(kernels::LOG2E), magic);
    let n = _mm512_sub_ps(t, magic);
    let r = _mm512_fnmadd_ps(n, _mm512_set1_ps(kernels::LN2_HI), zc);
    let r = _mm512_fnmadd_ps(n, _mm512_set1_ps(kernels::LN2_LO), r);
    let mut p = _mm512_set1_ps(1.0 / 5040.0);
    p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(1.0 / 720.0));
    p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(1.0 / 120.0));
    p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(1.0 / 24.0));
    p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(1.0 / 6.0));
    p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(0.5));
    let em1 = _mm512_fmadd_ps(p, _mm512_mul_ps(r, r), r);
    let two_n =
        _mm512_castsi512_ps(_mm512_slli_epi32::<23>(_mm512_add_epi32(_mm512_castps_si512(t), _mm512_set1_epi32(127))));
    let e = _mm512_fmadd_ps(two_n, em1, _mm512_sub_ps(two_n, _mm512_set1_ps(1.0)));
    let pos = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(z, zero);
    _mm512_mask_blend_ps(pos, e, z)
}

/// The 6×32 kernel: `C[0..mr, 0..nr] (+)= A·B` over `kc`, with `A(ii, p)` at `a + ii·ars + p·acs` (rows past `mr`
/// read row `mr − 1`, results discarded) and `B` two packed `kc × 16` panels at `b0` and `b1`; then, when `bias`
/// is given (the last k-block), `act(C + bias)` on the accumulators.
///
/// # Safety
/// AVX-512F present; `a` readable over `mr × kc`, both panels over `kc × 16` (64-byte aligned), `c` writable over
/// `mr × nr` with row stride `ldc`, `nr ≤ 32`.
#[target_feature(enable = "avx512f")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn kernel(
    kc: usize,
    a: *const f32,
    ars: isize,
    acs: isize,
    b0: *const f32,
    b1: *const f32,
    c: *mut f32,
    ldc: usize,
    mr: usize,
    nr: usize,
    accumulate: bool,
    epi: Option<(&[f32; NR2], Activation)>,
) {
    let z = _mm512_setzero_ps();
    let mut acc = [[z; 2]; MR];
    let row = |ii: usize| a.offset(ii.min(mr - 1) as isize * ars);
    let (mut p0, mut p1, mut p2, mut p3, mut p4, mut p5) = (row(0), row(1), row(2), row(3), row(4), row(5));
    let (mut q0, mut q1) = (b0, b1);
    for _ in 0..kc {
        let v0 = _mm512_load_ps(q0);
        let v1 = _mm512_load_ps(q1);
        let a0 = _mm512_set1_ps(*p0);
        acc[0][0] = _mm512_fmadd_ps(a0, v0, acc[0][0]);
        acc[0][1] = _mm512_fmadd_ps(a0, v1, acc[0][1]);
        let a1 = _mm512_set1_ps(*p1);
        acc[1][0] = _mm512_fmadd_ps(a1, v0, acc[1][0]);
        acc[1][1] = _mm512_fmadd_ps(a1, v1, acc[1][1]);
        let a2 = _mm512_set1_ps(*p2);
        acc[2][0] = _mm512_fmadd_ps(a2, v0, acc[2][0]);
        acc[2][1] = _mm512_fmadd_ps(a2, v1, acc[2][1]);
        let a3 = _mm512_set1_ps(*p3);
        acc[3][0] = _mm512_fmadd_ps(a3, v0, acc[3][0]);
        acc[3][1] = _mm512_fmadd_ps(a3, v1, acc[3][1]);
        let a4 = _mm512_set1_ps(*p4);
        acc[4][0] = _mm512_fmadd_ps(a4, v0, acc[4][0]);
        acc[4][1] = _mm512_fmadd_ps(a4, v1, acc[4][1]);
        let a5 = _mm512_set1_ps(*p5);
        acc[5][0] = _mm512_fmadd_ps(a5, v0, acc[5][0]);
        acc[5][1] = _mm512_fmadd_ps(a5, v1, acc[5][1]);
        p0 = p0.offset(acs);
        p1 = p1.offset(acs);
        p2 = p2.offset(acs);
        p3 = p3.offset(acs);
        p4 = p4.offset(acs);
        p5 = p5.offset(acs);
        q0 = q0.add(NR);
        q1 = q1.add(NR);
    }
    // A partial tile (fewer rows or columns) goes through a full tile on the stack, as in the AVX2 kernel.
    let full = mr == MR && nr == NR2;
    let mut tile = [0.0f32; MR * NR2];
    let (dst, ld) = if full { (c, ldc) } else { (tile.as_mut_ptr(), NR2) };
    if accumulate {
        if !full {
            for i in 0..mr {
                std::ptr::copy_nonoverlapping(c.add(i * ldc), tile.as_mut_ptr().add(i * NR2), nr);
            }
        }
        for (i, r) in acc.iter_mut().enumerate() {
            let cp = dst.add(i * ld);
            r[0] = _mm512_add_ps(_mm512_loadu_ps(cp), r[0]);
            r[1] = _mm512_add_ps(_mm512_loadu_ps(cp.add(NR)), r[1]);
        }
    }
    if let Some((bias, act)) = epi {
        let bv0 = _mm512_loadu_ps(bias.as_ptr());
        let bv1 = _mm512_loadu_ps(bias.as_ptr().add(NR));
        for r in acc.iter_mut() {
            r[0] = _mm512_add_ps(r[0], bv0);
            r[1] = _mm512_add_ps(r[1], bv1);
            if act == Activation::Elu {
                r[0] = elu16(r[0]);
                r[1] = elu16(r[1]);
            }
        }
    }
    for (i, r) in acc.iter().enumerate() {
        let cp = dst.add(i * ld);
        _mm512_storeu_ps(cp, r[0]);
        _mm512_storeu_ps(cp.add(NR), r[1]);
    }
    if !full {
        for i in 0..mr {
            std::ptr::copy_nonoverlapping(tile.as_ptr().add(i * NR2), c.add(i * ldc), nr);
        }
    }
}
