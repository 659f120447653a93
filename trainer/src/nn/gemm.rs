//! Single-threaded f32 matrix product for the layers: an AVX2/FMA 6×16 register-tile kernel with packed `B`,
//! `A` read in place when its rows are contiguous, and the layer's bias + activation applied to the accumulators
//! before they are stored. Callers parallelise over independent blocks of `C` (see [`super::layer`]).
//!
//! Why not the `gemm` crate (candle's matmul) everywhere: it is as fast per call on these shapes, but it repacks
//! `B` (the weights) on every call, allocates its packing buffers on every call, and cannot fuse the epilogue. Here
//! the weights are packed once per layer call and shared by all row blocks and threads, packing buffers are
//! thread-local and only grow, and bias + ELU run on the accumulators in registers. The `gemm` crate remains the
//! path on CPUs without AVX2/FMA.
//!
//! Summation order: every element of `C` is a sum over `k` taken in blocks of [`KC`], each block an FMA chain in
//! `k` order. It does not depend on how `C` is cut into blocks or on the thread count.

use super::kernels;
use super::kernels::Activation;
use std::cell::RefCell;
use std::sync::OnceLock;

/// Whether products use this module's AVX2/FMA kernel: when the CPU has AVX2 and FMA, unless the environment
/// variable `NN_GEMM=crate` asks for the `gemm` crate (a diagnostic switch for A/B timing; read once).
pub(crate) fn own_kernel() -> bool {
    static OWN: OnceLock<bool> = OnceLock::new();
    *OWN.get_or_init(|| kernels::has_avx2_fma() && std::env::var("NN_GEMM").map_or(true, |v| v != "crate"))
}

/// Whether products of [`own_kernel`] take the AVX-512 kernel (pairs of panels, 12-row tiles): when the CPU has
/// AVX-512F, unless `NN_GEMM=avx2` (or `crate`) asks otherwise (read once). Both kernels give bit-identical results.
pub(crate) fn wide_kernel() -> bool {
    #[cfg(test)]
    if tests::FORCE_AVX2.with(|f| f.get()) {
        return false;
    }
    static WIDE: OnceLock<bool> = OnceLock::new();
    *WIDE.get_or_init(|| {
        #[cfg(target_arch = "x86_64")]
        {
            own_kernel() && avx512::available() && std::env::var("NN_GEMM").map_or(true, |v| v != "avx2")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    })
}

/// Rows of the register tile.
pub(crate) const MR: usize = 6;
/// Columns of the register tile (two 8-lane vectors).
pub(crate) const NR: usize = 16;
/// Depth of one pass over `k`: a packed `B` panel is KC × NR floats = 32 KiB. It is part of the summation order
/// (module docs), so changing it changes results; 256 (a 16 KiB panel) timed the same on an AVX2 EPYC.
pub(crate) const KC: usize = 512;
/// Rows of `A` per cache block (a multiple of [`MR`]; MC × KC floats = 192 KiB, in L2).
pub(crate) const MC: usize = 96;

/// A read-only strided matrix view: element `(i, j)` is at `ptr + i·rs + j·cs`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MatRef {
    pub ptr: *const f32,
    pub rs: isize,
    pub cs: isize,
}
// SAFETY: a MatRef is only built from buffers that outlive the parallel section reading them, and is read-only.
unsafe impl Send for MatRef {}
unsafe impl Sync for MatRef {}

impl MatRef {
    pub fn row_major(data: &[f32], cols: usize) -> Self {
        MatRef { ptr: data.as_ptr(), rs: cols as isize, cs: 1 }
    }
    /// The view starting at row `r`.
    pub fn rows_from(self, r: usize) -> Self {
        MatRef { ptr: self.ptr.wrapping_offset(r as isize * self.rs), ..self }
    }
    /// The view starting at column `c`.
    pub fn cols_from(self, c: usize) -> Self {
        MatRef { ptr: self.ptr.wrapping_offset(c as isize * self.cs), ..self }
    }
    /// The transposed view.
    pub fn t(self) -> Self {
        MatRef { ptr: self.ptr, rs: self.cs, cs: self.rs }
    }
    /// # Safety
    /// `(i, j)` must be inside the viewed matrix.
    #[inline(always)]
    unsafe fn at(self, i: usize, j: usize) -> f32 {
        *self.ptr.offset(i as isize * self.rs + j as isize * self.cs)
    }
}

#[repr(C, align(64))]
#[derive(Clone, Copy)]
struct Line([f32; 16]);

/// A grow-only, cache-line aligned f32 buffer.
#[derive(Default, Clone)]
pub(crate) struct AlignedBuf(Vec<Line>);

impl AlignedBuf {
    fn get(&mut self, n: usize) -> *mut f32 {
        let lines = n.div_ceil(16);
        if self.0.len() < lines {
            self.0.resize(lines, Line([0.0; 16]));
        }
        self.0.as_mut_ptr() as *mut f32
    }
}

impl std::fmt::Debug for AlignedBuf {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "AlignedBuf({} floats)", self.0.len() * 16)
    }
}

/// The right operand `B[k×n]` of a product, packed for the kernel (k-block after k-block; in each, `n/NR`
/// panels of `kc × NR`, zero-padded) — or, when the `gemm` crate does the products, just the view.
#[derive(Default, Debug, Clone)]
pub(crate) struct PackedB {
    buf: AlignedBuf,
    k: usize,
    n: usize,
    /// The source view (fallback path only). Valid as long as the caller keeps the source alive.
    src: Option<(usize, isize, isize)>,
}
// SAFETY: the packed data is owned; the source pointer (fallback) is read-only and outlived by its users.
unsafe impl Send for PackedB {}
unsafe impl Sync for PackedB {}

impl PackedB {
    fn panels(&self) -> usize {
        self.n.div_ceil(NR)
    }

    /// Packs `b` (`k × n`), reusing the buffer.
    ///
    /// # Safety
    /// `b` must view `k × n` valid elements; on the fallback path they must stay alive while `self` is used.
    pub unsafe fn pack(&mut self, b: MatRef, k: usize, n: usize) {
        self.k = k;
        self.n = n;
        if !own_kernel() {
            self.src = Some((b.ptr as usize, b.rs, b.cs));
            return;
        }
        self.src = None;
        let panels = self.panels();
        let dst = self.buf.get(panels * k * NR);
        let mut pc = 0;
        while pc < k {
            let kc = KC.min(k - pc);
            pack_b_block(kc, n, b.rows_from(pc), dst.add(pc * panels * NR));
            pc += kc;
        }
    }

    fn block(&self, pc: usize) -> *const f32 {
        (self.buf.0.as_ptr() as *const f32).wrapping_add(pc * self.panels() * NR)
    }
}

/// What to do with a finished tile before storing it.
#[derive(Clone, Copy)]
pub(crate) enum Epilogue<'a> {
    None,
    /// `act(c + bias)`, bias indexed by column.
    BiasAct(&'a [f32], Activation),
}

thread_local! {
    static A_BUF: RefCell<AlignedBuf> = RefCell::new(AlignedBuf::default());
    static B_BUF: RefCell<PackedB> = RefCell::new(PackedB::default());
}

/// `C[m×n] (row stride ldc) = A[m×k]·B[k×n]` (`+ C` when `accumulate`), then the epilogue; single-threaded.
/// `B` is given packed.
///
/// # Safety
/// `a` must view `m × k` valid elements, `c` must point to `m` rows of `n` writable elements with row stride
/// `ldc`, and `b` must have been packed with this `k` and `n` from a source that is still alive.
pub(crate) unsafe fn matmul_packed(
    m: usize,
    a: MatRef,
    b: &PackedB,
    c: *mut f32,
    ldc: usize,
    accumulate: bool,
    epi: Epilogue,
) {
    let (k, n) = (b.k, b.n);
    if m == 0 || n == 0 {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if b.src.is_none() {
        // Packed, hence our kernel (AVX2/FMA present), its panels in pairs where AVX-512 is.
        avx2::matmul(m, n, k, a, b, c, ldc, accumulate, epi, wide_kernel());
        return;
    }
    let (ptr, rs, cs) = b.src.expect("PackedB::pack was called");
    fallback(m, n, k, a, MatRef { ptr: ptr as *const f32, rs, cs }, c, ldc, accumulate, epi);
}

/// As [`matmul_packed`] with `B` given as a view, packed into a thread-local buffer.
///
/// # Safety
/// As [`matmul_packed`], `b` viewing `k × n` valid elements.
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn matmul(
    m: usize,
    n: usize,
    k: usize,
    a: MatRef,
    b: MatRef,
    c: *mut f32,
    ldc: usize,
    accumulate: bool,
    epi: Epilogue,
) {
    B_BUF.with(|buf| {
        let mut pb = buf.borrow_mut();
        pb.pack(b, k, n);
        matmul_packed(m, a, &pb, c, ldc, accumulate, epi);
    });
}

/// The `gemm` crate, then the epilogue as a separate pass.
///
/// # Safety
/// As [`matmul`]: `a`, `b` readable over their shapes at their strides, `c` writable over `m × n` with row stride
/// `ldc`, and no overlap between `c` and the inputs.
#[allow(clippy::too_many_arguments)]
unsafe fn fallback(
    m: usize,
    n: usize,
    k: usize,
    a: MatRef,
    b: MatRef,
    c: *mut f32,
    ldc: usize,
    accumulate: bool,
    epi: Epilogue,
) {
    if k == 0 {
        if !accumulate {
            for i in 0..m {
                std::ptr::write_bytes(c.add(i * ldc), 0, n);
            }
        }
    } else {
        gemm::gemm(
            m,
            n,
            k,
            c,
            1,
            ldc as isize,
            accumulate,
            a.ptr,
            a.cs,
            a.rs,
            b.ptr,
            b.cs,
            b.rs,
            1.0,
            1.0,
            false,
            false,
            false,
            gemm::Parallelism::None,
        );
    }
    if let Epilogue::BiasAct(bias, act) = epi {
        for i in 0..m {
            kernels::bias_act_rows(std::slice::from_raw_parts_mut(c.add(i * ldc), n), n, bias, act);
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::*;
    use std::arch::x86_64::*;

    /// ELU on 8 lanes: the same operations, in the same order, as [`kernels::elu`] (bit-identical results).
    ///
    /// # Safety
    /// The CPU must have AVX2 and FMA (callers are `target_feature(enable = "avx2,fma")` functions).
    #[inline(always)]
    unsafe fn elu8(z: __m256) -> __m256 {
        let zc = _mm256_max_ps(_mm256_min_ps(z, _mm256_setzero_ps()), _mm256_set1_ps(-87.0));
        let magic = _mm256_set1_ps(kernels::ROUND_MAGIC);
        let t = _mm256_fmadd_ps(zc, _mm256_set1_ps(kernels::LOG2E), magic);
        let n = _mm256_sub_ps(t, magic);
        let r = _mm256_fnmadd_ps(n, _mm256_set1_ps(kernels::LN2_HI), zc);
        let r = _mm256_fnmadd_ps(n, _mm256_set1_ps(kernels::LN2_LO), r);
        let mut p = _mm256_set1_ps(1.0 / 5040.0);
        p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0 / 720.0));
        p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0 / 120.0));
        p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0 / 24.0));
        p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.0 / 6.0));
        p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(0.5));
        let em1 = _mm256_fmadd_ps(p, _mm256_mul_ps(r, r), r);
        let two_n = _mm256_castsi256_ps(_mm256_slli_epi32::<23>(_mm256_add_epi32(
            _mm256_castps_si256(t),
            _mm256_set1_epi32(127),
        )));
        let e = _mm256_fmadd_ps(two_n, em1, _mm256_sub_ps(two_n, _mm256_set1_ps(1.0)));
        let pos = _mm256_cmp_ps::<_CMP_GT_OQ>(z, _mm256_setzero_ps());
        _mm256_blendv_ps(e, z, pos)
    }

    /// A tile's share of an [`Epilogue`] (given on the last k-block only).
    #[derive(Clone, Copy)]
    pub(super) enum TileEpi<'a> {
        None,
        /// Bias for the tile's 16 columns (zero-padded) and the activation.
        BiasAct(&'a [f32; NR], Activation),
    }

    /// The 6×16 kernel: `C[0..mr, 0..nr] (+)= A·B` over `kc`, with `A(ii, p)` at `a + ii·ars + p·acs` (rows
    /// past `mr` read row `mr − 1`, results discarded) and `B` a packed `kc × 16` panel; then the epilogue.
    ///
    /// # Safety
    /// AVX2 and FMA present; `a` readable over `mr × kc`, `b` over `kc × 16`, `c` writable over `mr × nr`.
    #[target_feature(enable = "avx2,fma")]
    #[allow(clippy::too_many_arguments)]
    unsafe fn kernel(
        kc: usize,
        a: *const f32,
        ars: isize,
        acs: isize,
        b: *const f32,
        c: *mut f32,
        ldc: usize,
        mr: usize,
        nr: usize,
        accumulate: bool,
        epi: TileEpi,
    ) {
        let z = _mm256_setzero_ps();
        let mut acc = [[z; 2]; MR];
        let row = |ii: usize| a.offset(ii.min(mr - 1) as isize * ars);
        let (mut p0, mut p1, mut p2, mut p3, mut p4, mut p5) = (row(0), row(1), row(2), row(3), row(4), row(5));
        let mut bp = b;
        for _ in 0..kc {
            let b0 = _mm256_load_ps(bp);
            let b1 = _mm256_load_ps(bp.add(8));
            let a0 = _mm256_broadcast_ss(&*p0);
            acc[0][0] = _mm256_fmadd_ps(a0, b0, acc[0][0]);
            acc[0][1] = _mm256_fmadd_ps(a0, b1, acc[0][1]);
            let a1 = _mm256_broadcast_ss(&*p1);
            acc[1][0] = _mm256_fmadd_ps(a1, b0, acc[1][0]);
            acc[1][1] = _mm256_fmadd_ps(a1, b1, acc[1][1]);
            let a2 = _mm256_broadcast_ss(&*p2);
            acc[2][0] = _mm256_fmadd_ps(a2, b0, acc[2][0]);
            acc[2][1] = _mm256_fmadd_ps(a2, b1, acc[2][1]);
            let a3 = _mm256_broadcast_ss(&*p3);
            acc[3][0] = _mm256_fmadd_ps(a3, b0, acc[3][0]);
            acc[3][1] = _mm256_fmadd_ps(a3, b1, acc[3][1]);
            let a4 = _mm256_broadcast_ss(&*p4);
            acc[4][0] = _mm256_fmadd_ps(a4, b0, acc[4][0]);
            acc[4][1] = _mm256_fmadd_ps(a4, b1, acc[4][1]);
            let a5 = _mm256_broadcast_ss(&*p5);
            acc[5][0] = _mm256_fmadd_ps(a5, b0, acc[5][0]);
            acc[5][1] = _mm256_fmadd_ps(a5, b1, acc[5][1]);
            p0 = p0.offset(acs);
            p1 = p1.offset(acs);
            p2 = p2.offset(acs);
            p3 = p3.offset(acs);
            p4 = p4.offset(acs);
            p5 = p5.offset(acs);
            bp = bp.add(NR);
        }
        let full = mr == MR && nr == NR;
        if accumulate {
            // Partial tiles go through the full-tile path on a copy, below.
            if full {
                for (i, r) in acc.iter_mut().enumerate() {
                    let cp = c.add(i * ldc);
                    r[0] = _mm256_add_ps(_mm256_loadu_ps(cp), r[0]);
                    r[1] = _mm256_add_ps(_mm256_loadu_ps(cp.add(8)), r[1]);
                }
            } else {
                let mut tile = [0.0f32; MR * NR];
                for i in 0..mr {
                    for j in 0..nr {
                        tile[i * NR + j] = *c.add(i * ldc + j);
                    }
                }
                for (i, r) in acc.iter_mut().enumerate() {
                    r[0] = _mm256_add_ps(_mm256_loadu_ps(tile.as_ptr().add(i * NR)), r[0]);
                    r[1] = _mm256_add_ps(_mm256_loadu_ps(tile.as_ptr().add(i * NR + 8)), r[1]);
                }
            }
        }
        match epi {
            TileEpi::None => {}
            TileEpi::BiasAct(bias, act) => {
                let bv0 = _mm256_loadu_ps(bias.as_ptr());
                let bv1 = _mm256_loadu_ps(bias.as_ptr().add(8));
                for r in acc.iter_mut() {
                    r[0] = _mm256_add_ps(r[0], bv0);
                    r[1] = _mm256_add_ps(r[1], bv1);
                    if act == Activation::Elu {
                        r[0] = elu8(r[0]);
                        r[1] = elu8(r[1]);
                    }
                }
            }
        }
        if full {
            for (i, r) in acc.iter().enumerate() {
                let cp = c.add(i * ldc);
                _mm256_storeu_ps(cp, r[0]);
                _mm256_storeu_ps(cp.add(8), r[1]);
            }
        } else {
            let mut tile = [0.0f32; MR * NR];
            for (i, r) in acc.iter().enumerate() {
                _mm256_storeu_ps(tile.as_mut_ptr().add(i * NR), r[0]);
                _mm256_storeu_ps(tile.as_mut_ptr().add(i * NR + 8), r[1]);
            }
            for i in 0..mr {
                std::ptr::copy_nonoverlapping(tile.as_ptr().add(i * NR), c.add(i * ldc), nr);
            }
        }
    }

    /// Blocked product: for each block of [`MC`] rows of `A`, for each k-block, for each panel of `B` (each pair of
    /// panels when `wide`: the AVX-512 kernel), for each `MR` rows: the kernel. `A` is read in place when its rows
    /// are contiguous (cs = 1), else packed per block.
    ///
    /// # Safety
    /// AVX2 and FMA present (checked by the caller), AVX-512F too when `wide`; `a`, `b` readable over their shapes
    /// at their strides, `c` writable over `m × n` with row stride `ldc`, and `c` overlapping neither input.
    #[target_feature(enable = "avx2,fma")]
    #[allow(clippy::too_many_arguments)]
    pub(super) unsafe fn matmul(
        m: usize,
        n: usize,
        k: usize,
        a: MatRef,
        b: &PackedB,
        c: *mut f32,
        ldc: usize,
        accumulate: bool,
        epi: Epilogue,
        wide: bool,
    ) {
        let panels = n.div_ceil(NR);
        if k == 0 {
            for i in 0..m {
                if !accumulate {
                    std::ptr::write_bytes(c.add(i * ldc), 0, n);
                }
            }
            // Finish as the portable path does (nothing to multiply, nothing to add: only bias + act).
            if let Epilogue::BiasAct(bias, act) = epi {
                for i in 0..m {
                    kernels::bias_act_rows(std::slice::from_raw_parts_mut(c.add(i * ldc), n), n, bias, act);
                }
            }
            return;
        }
        let direct = a.cs == 1;
        A_BUF.with(|abuf| {
            let mut abuf = abuf.borrow_mut();
            let mut ic = 0;
            while ic < m {
                let mc = MC.min(m - ic);
                let mut pc = 0;
                while pc < k {
                    let kc = KC.min(k - pc);
                    let last = pc + kc == k;
                    let acc = accumulate || pc > 0;
                    let bpk = b.block(pc);
                    let ablk = a.rows_from(ic).cols_from(pc);
                    let ap = if direct {
                        std::ptr::null_mut()
                    } else {
                        let ap = abuf.get(mc.div_ceil(MR) * kc * MR);
                        pack_a_block(mc, kc, ablk, ap);
                        ap
                    };
                    let mut jp = 0;
                    while jp < panels {
                        let pair = wide && jp + 1 < panels;
                        let nr = if pair { 2 * NR } else { NR }.min(n - jp * NR);
                        let mut bias32 = [0.0f32; 2 * NR];
                        if let Epilogue::BiasAct(bias, _) = epi {
                            bias32[..nr].copy_from_slice(&bias[jp * NR..jp * NR + nr]);
                        }
                        let act = match epi {
                            Epilogue::BiasAct(_, act) if last => Some(act),
                            _ => None,
                        };
                        let bias16: &[f32; NR] = bias32[..NR].try_into().expect("NR floats");
                        let tile_epi = act.map_or(TileEpi::None, |act| TileEpi::BiasAct(bias16, act));
                        let bpanel = bpk.add(jp * kc * NR);
                        // Row panel `ip`'s first row of `A`, its row and column strides.
                        let arow = |ip: usize| -> (*const f32, isize, isize) {
                            if direct {
                                (ablk.rows_from(ip * MR).ptr, a.rs, 1)
                            } else {
                                (ap.add(ip * kc * MR) as *const f32, 1, MR as isize)
                            }
                        };
                        let mut ip = 0;
                        while ip < mc.div_ceil(MR) {
                            let mr = MR.min(mc - ip * MR);
                            let cp = c.add((ic + ip * MR) * ldc + jp * NR);
                            let (lo, ars, acs) = arow(ip);
                            if pair {
                                // Two whole row panels take the 12-row tile, the rest the 6-row one.
                                let tall = mc - ip * MR >= avx512::MR2;
                                let hi = if tall { arow(ip + 1).0 } else { lo };
                                let t = avx512::ATile { lo, hi, rs: ars, cs: acs };
                                let (b1, e) = (bpanel.add(kc * NR), act.map(|act| (&bias32, act)));
                                if tall {
                                    let mr = avx512::MR2;
                                    avx512::kernel::<{ avx512::MR2 }>(kc, t, bpanel, b1, cp, ldc, mr, nr, acc, e);
                                    ip += 2;
                                } else {
                                    avx512::kernel::<MR>(kc, t, bpanel, b1, cp, ldc, mr, nr, acc, e);
                                    ip += 1;
                                }
                            } else {
                                kernel(kc, lo, ars, acs, bpanel, cp, ldc, mr, nr, acc, tile_epi);
                                ip += 1;
                            }
                        }
                        jp += if pair { 2 } else { 1 };
                    }
                    pc += kc;
                }
                ic += mc;
            }
        });
    }
}

#[path = "gemm_pack.rs"]
mod pack;
use pack::{pack_a_block, pack_b_block};

#[cfg(target_arch = "x86_64")]
#[path = "gemm_avx512.rs"]
mod avx512;

#[cfg(test)]
#[path = "gemm_tests.rs"]
mod tests;
