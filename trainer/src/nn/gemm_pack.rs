//! Packing for the kernels of [`super`]: `B` into zero-padded panels of [`NR`] columns, `A` (when its rows are
//! not contiguous) into panels of [`MR`] rows, each in the order the kernels read it.

use super::{MatRef, MR, NR};

/// Packs `B[0..kc, 0..n]` into `n/NR` panels of `kc × NR` (zero-padded columns).
///
/// # Safety
/// `b` must be readable over `kc × n` at its strides and `dst` writable for `n.div_ceil(NR) · kc · NR` floats.
pub(super) unsafe fn pack_b_block(kc: usize, n: usize, b: MatRef, dst: *mut f32) {
    let panels = n.div_ceil(NR);
    if b.cs == 1 {
        // Row-major source (activations, W in `dZ·W`): read each row once, in order, and deal it to the panels.
        let tail = n % NR;
        for p in 0..kc {
            let src = b.ptr.offset(p as isize * b.rs);
            for jp in 0..n / NR {
                std::ptr::copy_nonoverlapping(src.add(jp * NR), dst.add(jp * kc * NR + p * NR), NR);
            }
            if tail != 0 {
                let d = dst.add((panels - 1) * kc * NR + p * NR);
                std::ptr::copy_nonoverlapping(src.add(n - tail), d, tail);
                std::ptr::write_bytes(d.add(tail), 0, NR - tail);
            }
        }
        return;
    }
    for jp in 0..panels {
        let j0 = jp * NR;
        let w = NR.min(n - j0);
        let d = dst.add(jp * kc * NR);
        if b.rs == 1 {
            // Column-major source (Wᵀ in the forward): walk each column contiguously.
            for jj in 0..NR {
                if jj < w {
                    let col = b.ptr.offset((j0 + jj) as isize * b.cs);
                    for p in 0..kc {
                        *d.add(p * NR + jj) = *col.add(p);
                    }
                } else {
                    for p in 0..kc {
                        *d.add(p * NR + jj) = 0.0;
                    }
                }
            }
        } else {
            for p in 0..kc {
                for jj in 0..NR {
                    *d.add(p * NR + jj) = if jj < w { b.at(p, j0 + jj) } else { 0.0 };
                }
            }
        }
    }
}

/// Packs `A[0..mc, 0..kc]` into panels of `MR` rows (`kc × MR` each, rows past `mc` zero).
///
/// # Safety
/// `a` must be readable over `mc × kc` at its strides and `dst` writable for `mc.div_ceil(MR) · kc · MR` floats.
pub(super) unsafe fn pack_a_block(mc: usize, kc: usize, a: MatRef, dst: *mut f32) {
    for ip in 0..mc.div_ceil(MR) {
        let i0 = ip * MR;
        let h = MR.min(mc - i0);
        let d = dst.add(ip * kc * MR);
        if a.rs == 1 && h == MR {
            // Aᵀ row-major (the weight gradient's dZᵀ): MR consecutive floats per k.
            for p in 0..kc {
                std::ptr::copy_nonoverlapping(a.ptr.offset(p as isize * a.cs + i0 as isize), d.add(p * MR), MR);
            }
        } else {
            for p in 0..kc {
                for ii in 0..MR {
                    *d.add(p * MR + ii) = if ii < h { a.at(i0 + ii, p) } else { 0.0 };
                }
            }
        }
    }
}
