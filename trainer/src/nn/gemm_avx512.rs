//! The AVX-512 kernel of [`super`]: 32 columns (two packed 16-column panels side by side, one 16-lane vector each)
//! by 12 rows (6 for the last rows of a block), chosen at run time where the CPU has AVX-512F. Every element of `C`
//! is the same FMA chain in `k` order as in the AVX2 kernel, and the ELU epilogue the same operations in the same
//! order, so both kernels give bit-identical results: a run does not change with the CPU that trains it. What the
//! wider tile saves is instructions per FLOP (one broadcast feeds 32 columns), which pays on CPUs with two 512-bit
//! FMA units.

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

/// Rows of the tall tile: two row panels of [`MR`] (24 of the 32 vector registers hold its accumulators).
pub(super) const MR2: usize = 2 * MR;

/// Where a kernel reads `A`: row `ii` of the tile at `base(ii / MR) + ii % MR · rs + p · cs` for `p` in `0..kc`,
/// the two bases being the tile's two row panels (in place: `MR` rows apart; packed: one packed panel each).
#[derive(Clone, Copy)]
pub(super) struct ATile {
    pub lo: *const f32,
    pub hi: *const f32,
    pub rs: isize,
    pub cs: isize,
}

/// The `R`×32 kernel (`R` = [`MR`] or [`MR2`]): `C[0..mr, 0..nr] (+)= A·B` over `kc`, `A` as [`ATile`] says and
/// `B` two packed `kc × 16` panels at `b0` and `b1`; then, when `epi` is given (the last k-block),
/// `act(C + bias)` on the accumulators. A 6-row tile may be partial (rows past `mr` read row `mr − 1`, results
/// discarded); a 12-row tile is whole. The 12-row tile loads each `B` vector for twice the FMAs, which is what
/// lets CPUs with two 512-bit FMA units (Intel's) reach their FMA peak instead of waiting on `B` from L2.
///
/// # Safety
/// AVX-512F present; `A` readable over `mr × kc` as `a` describes, both panels over `kc × 16` (64-byte aligned),
/// `c` writable over `mr × nr` with row stride `ldc`, `nr ≤ 32`, `mr ≤ R` (`mr == R` when `R` is [`MR2`]).
#[target_feature(enable = "avx512f")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn kernel<const R: usize>(
    kc: usize,
    a: ATile,
    b0: *const f32,
    b1: *const f32,
    c: *mut f32,
    ldc: usize,
    mr: usize,
    nr: usize,
    accumulate: bool,
    epi: Option<(&[f32; NR2], Activation)>,
) {
    debug_assert!(R == MR || (R == MR2 && mr == MR2));
    let z = _mm512_setzero_ps();
    let mut acc = [[z; 2]; R];
    // Offsets of the rows inside a panel, clamped to the last real row.
    let mut off = [0isize; MR];
    for (ii, o) in off.iter_mut().enumerate() {
        *o = ii.min(mr - 1) as isize * a.rs;
    }
    let (mut lo, mut hi) = (a.lo, a.hi);
    let (mut q0, mut q1) = (b0, b1);
    for _ in 0..kc {
        let v0 = _mm512_load_ps(q0);
        let v1 = _mm512_load_ps(q1);
        for ii in 0..R {
            let base = if ii < MR { lo } else { hi };
            let ai = _mm512_set1_ps(*base.offset(off[ii % MR]));
            acc[ii][0] = _mm512_fmadd_ps(ai, v0, acc[ii][0]);
            acc[ii][1] = _mm512_fmadd_ps(ai, v1, acc[ii][1]);
        }
        lo = lo.offset(a.cs);
        hi = hi.offset(a.cs);
        q0 = q0.add(NR);
        q1 = q1.add(NR);
    }
    // The accumulators go to a tile on the stack, and the epilogue works from there: with 24 accumulators,
    // epilogue loops over the registers would not unroll, and the compiler would then keep every accumulator in
    // memory inside the k loop too. One store and load per accumulator per tile, against `kc` FMAs each.
    let mut tile = Tile::<R>([[0.0f32; NR2]; R]);
    for (t, r) in tile.0.iter_mut().zip(&acc) {
        _mm512_store_ps(t.as_mut_ptr(), r[0]);
        _mm512_store_ps(t.as_mut_ptr().add(NR), r[1]);
    }
    let bias = epi.map(|(b, _)| (_mm512_loadu_ps(b.as_ptr()), _mm512_loadu_ps(b.as_ptr().add(NR))));
    for (i, t) in tile.0.iter_mut().enumerate().take(mr) {
        let w = nr.min(NR2);
        let cp = c.add(i * ldc);
        let mut r = [_mm512_load_ps(t.as_ptr()), _mm512_load_ps(t.as_ptr().add(NR))];
        if accumulate {
            // C + A·B; a row of C shorter than 32 is read through a copy.
            let mut row = [0.0f32; NR2];
            let src = if w == NR2 {
                cp as *const f32
            } else {
                std::ptr::copy_nonoverlapping(cp, row.as_mut_ptr(), w);
                row.as_ptr()
            };
            r[0] = _mm512_add_ps(_mm512_loadu_ps(src), r[0]);
            r[1] = _mm512_add_ps(_mm512_loadu_ps(src.add(NR)), r[1]);
        }
        if let (Some((bv0, bv1)), Some((_, act))) = (bias, epi) {
            r[0] = _mm512_add_ps(r[0], bv0);
            r[1] = _mm512_add_ps(r[1], bv1);
            if act == Activation::Elu {
                r[0] = elu16(r[0]);
                r[1] = elu16(r[1]);
            }
        }
        if w == NR2 {
            _mm512_storeu_ps(cp, r[0]);
            _mm512_storeu_ps(cp.add(NR), r[1]);
        } else {
            _mm512_store_ps(t.as_mut_ptr(), r[0]);
            _mm512_store_ps(t.as_mut_ptr().add(NR), r[1]);
            std::ptr::copy_nonoverlapping(t.as_ptr(), cp, w);
        }
    }
}

/// The accumulators of an `R`-row tile in memory, 64-byte aligned for the stores.
#[repr(C, align(64))]
struct Tile<const R: usize>([[f32; NR2]; R]);
