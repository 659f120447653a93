//! Element-wise CPU kernels of the fused layers: bias + activation (forward), activation derivative from the
//! stored output + bias-gradient column sums (backward), and a vectorised `expm1`.
//!
//! Every kernel has one portable body, compiled twice: once for the baseline target and once with AVX2+FMA enabled
//! (chosen at run time). Both bodies use the same operations in the same order, and `f32::mul_add` is a fused
//! multiply-add in both, so the two give bit-identical results; the AVX2 copy is just the one LLVM can vectorise
//! 8 lanes wide.

/// The activation applied after a layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Activation {
    /// ELU with α = 1.
    Elu,
    /// No activation (the output layer).
    Identity,
}

/// `true` when the CPU has AVX2 and FMA (checked once; `is_x86_feature_detected!` caches it).
#[inline]
pub(crate) fn has_avx2_fma() -> bool {
    #[cfg(test)]
    if tests::FORCE_PORTABLE.with(|f| f.get()) {
        return false;
    }
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Defines `fn $name` whose body is compiled twice, portable and with AVX2+FMA, the latter chosen at run time.
macro_rules! multiversion {
    ($(#[$m:meta])* $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $body:block) => {
        $(#[$m])*
        $vis fn $name($($arg: $ty),*) {
            #[inline(always)]
            #[allow(clippy::too_many_arguments)]
            fn body($($arg: $ty),*) $body
            // Safety: callable only where the CPU has AVX2 and FMA (checked at run time below).
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2,fma")]
            #[allow(clippy::too_many_arguments)]
            unsafe fn avx2($($arg: $ty),*) {
                body($($arg),*)
            }
            #[cfg(target_arch = "x86_64")]
            if has_avx2_fma() {
                // SAFETY: the CPU supports the features `avx2` was compiled for.
                return unsafe { avx2($($arg),*) };
            }
            body($($arg),*)
        }
    };
}

pub(crate) const LOG2E: f32 = std::f32::consts::LOG2_E;
// ln 2 split so that n·LN2_HI is exact for the n we meet (written in full on purpose).
#[allow(clippy::excessive_precision)]
pub(crate) const LN2_HI: f32 = 0.693_145_751_953_125;
#[allow(clippy::excessive_precision)]
pub(crate) const LN2_LO: f32 = 1.428_606_765_330_187_045e-6;
pub(crate) const ROUND_MAGIC: f32 = 12_582_912.0; // 1.5·2²³

/// `expm1(z)` for `z <= 0` (callers clamp), accurate to a few ulp, written so that LLVM vectorises it: no
/// branches, no libm calls. Range reduction `z = n·ln2 + r`, `|r| <= ln2/2`; `expm1(r)` by its Taylor series to
/// degree 7 (truncation < 2e-8 relative); then `expm1(z) = 2ⁿ·expm1(r) + (2ⁿ − 1)`, which keeps full relative
/// accuracy near 0 (no `exp(z) − 1` cancellation). Inputs below −87 give −1 (the exact f32 answer).
#[inline(always)]
pub(crate) fn expm1_nonpos(z: f32) -> f32 {
    let z = z.max(-87.0);
    // n = round-to-nearest-even(z·log2 e) by the 1.5·2²³ trick: the sum's low mantissa bits hold n, so 2ⁿ is
    // built from bits without a float→int conversion (Rust's saturating `as` would not vectorise).
    let t = z.mul_add(LOG2E, ROUND_MAGIC);
    let n = t - ROUND_MAGIC;
    let r = (-n).mul_add(LN2_HI, z);
    let r = (-n).mul_add(LN2_LO, r);
    let mut p: f32 = 1.0 / 5040.0;
    p = p.mul_add(r, 1.0 / 720.0);
    p = p.mul_add(r, 1.0 / 120.0);
    p = p.mul_add(r, 1.0 / 24.0);
    p = p.mul_add(r, 1.0 / 6.0);
    p = p.mul_add(r, 0.5);
    let em1 = p.mul_add(r * r, r);
    // 2ⁿ for n in [-126, 0]: (n + 127) << 23; the magic's own bits shift out past bit 31.
    let two_n = f32::from_bits(t.to_bits().wrapping_add(127) << 23);
    two_n.mul_add(em1, two_n - 1.0)
}

/// ELU with α = 1: `z` for `z > 0`, `expm1(z)` otherwise.
#[inline(always)]
pub(crate) fn elu(z: f32) -> f32 {
    let e = expm1_nonpos(z.min(0.0));
    if z > 0.0 {
        z
    } else {
        e
    }
}

multiversion! {
    /// `y[r, :] = act(y[r, :] + bias)` for every row of the row-major block `y` (`n` columns).
    pub(crate) fn bias_act_rows(y: &mut [f32], n: usize, bias: &[f32], act: Activation) {
        let bias = &bias[..n];
        match act {
            Activation::Elu => {
                for row in y.chunks_exact_mut(n) {
                    for (v, &b) in row.iter_mut().zip(bias) {
                        *v = elu(*v + b);
                    }
                }
            }
            Activation::Identity => {
                for row in y.chunks_exact_mut(n) {
                    for (v, &b) in row.iter_mut().zip(bias) {
                        *v += b;
                    }
                }
            }
        }
    }
}

multiversion! {
    /// Gradient with respect to the pre-activation, `dz = dy ⊙ act'(z)`, with ELU'(z) taken from the stored output
    /// `y = act(z)`: 1 where `y > 0`, `y + 1` elsewhere. `dy` row `r` starts at `dy[r * dy_rs]` with column stride
    /// `dy_cs` (candle may hand us a broadcast or transposed gradient); `y` and `dz` are row-major with `n` columns.
    /// Adds the column sums of `dz` to `colsum` (row by row, in row order).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn act_backward_rows(
        dy: &[f32], dy_rs: usize, dy_cs: usize, y: &[f32], dz: &mut [f32], n: usize, act: Activation,
        colsum: &mut [f32],
    ) {
        let colsum = &mut colsum[..n];
        for (r, (dz_row, y_row)) in dz.chunks_exact_mut(n).zip(y.chunks_exact(n)).enumerate() {
            if dy_cs == 1 {
                let dy_row = &dy[r * dy_rs..r * dy_rs + n];
                match act {
                    Activation::Elu => {
                        for (((d, &g), &v), s) in dz_row.iter_mut().zip(dy_row).zip(y_row).zip(colsum.iter_mut()) {
                            let e = g * if v > 0.0 { 1.0 } else { v + 1.0 };
                            *d = e;
                            *s += e;
                        }
                    }
                    Activation::Identity => {
                        for ((d, &g), s) in dz_row.iter_mut().zip(dy_row).zip(colsum.iter_mut()) {
                            *d = g;
                            *s += g;
                        }
                    }
                }
            } else {
                for j in 0..n {
                    let g = dy[r * dy_rs + j * dy_cs];
                    let v = y_row[j];
                    let e = match act {
                        Activation::Elu => g * if v > 0.0 { 1.0 } else { v + 1.0 },
                        Activation::Identity => g,
                    };
                    dz_row[j] = e;
                    colsum[j] += e;
                }
            }
        }
    }
}

multiversion! {
    /// In place: `g = g ⊙ act'(z)` with act' from the stored output `y` (see [`act_backward_rows`]), adding the
    /// column sums of the result to `colsum`. Used as the epilogue of the `dX` product of the next layer.
    pub(crate) fn act_backward_inplace_rows(g: &mut [f32], y: &[f32], n: usize, act: Activation, colsum: &mut [f32]) {
        let colsum = &mut colsum[..n];
        for (g_row, y_row) in g.chunks_exact_mut(n).zip(y.chunks_exact(n)) {
            match act {
                Activation::Elu => {
                    for ((d, &v), s) in g_row.iter_mut().zip(y_row).zip(colsum.iter_mut()) {
                        // Multiply by an exact 1 rather than skip the store: a conditional store becomes a masked
                        // store, which is slow on AMD.
                        let e = *d * if v > 0.0 { 1.0 } else { v + 1.0 };
                        *d = e;
                        *s += e;
                    }
                }
                Activation::Identity => {
                    for (d, s) in g_row.iter().zip(colsum.iter_mut()) {
                        *s += *d;
                    }
                }
            }
        }
    }
}

multiversion! {
    /// `acc += x`, element-wise (fixed-order reduction of per-block partial sums).
    pub(crate) fn add_assign(acc: &mut [f32], x: &[f32]) {
        for (a, &v) in acc.iter_mut().zip(x) {
            *a += v;
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::cell::Cell;

    thread_local! {
        /// Makes this thread's element-wise kernels take their portable copies.
        pub(crate) static FORCE_PORTABLE: Cell<bool> = const { Cell::new(false) };
    }

    #[test]
    fn portable_and_avx2_copies_agree_bit_for_bit() {
        let n = 45;
        let rows = 9;
        let z: Vec<f32> = (0..n * rows).map(|i| ((i * 7919 % 1000) as f32 / 90.0) - 8.0).collect();
        let bias: Vec<f32> = (0..n).map(|j| (j as f32 * 0.37).sin()).collect();
        let run = |portable: bool| -> Vec<u32> {
            FORCE_PORTABLE.with(|f| f.set(portable));
            let mut out = Vec::new();
            for act in [Activation::Elu, Activation::Identity] {
                let mut y = z.clone();
                bias_act_rows(&mut y, n, &bias, act);
                let mut dz = vec![0.0f32; n * rows];
                let mut colsum = vec![0.25f32; n];
                act_backward_rows(&z, n, 1, &y, &mut dz, n, act, &mut colsum);
                let mut g = z.clone();
                act_backward_inplace_rows(&mut g, &y, n, act, &mut colsum);
                add_assign(&mut colsum, &bias);
                out.extend(y.iter().chain(&dz).chain(&g).chain(&colsum).map(|v| v.to_bits()));
            }
            FORCE_PORTABLE.with(|f| f.set(false));
            out
        };
        assert_eq!(run(true), run(false));
    }

    #[test]
    fn expm1_accuracy() {
        let mut worst: f64 = 0.0;
        let mut z = -100.0f32;
        while z <= 0.0 {
            let got = expm1_nonpos(z) as f64;
            let want = (z as f64).exp_m1();
            let rel = (got - want).abs() / want.abs().max(1e-30);
            if z != 0.0 {
                worst = worst.max(rel);
            }
            z += 0.000_731;
        }
        for &z in &[-1e-7f32, -1e-5, -1e-3, -0.3, -0.35, -0.5, -1.0, -20.0, -87.5, -1000.0] {
            let got = expm1_nonpos(z) as f64;
            let want = (z as f64).exp_m1();
            worst = worst.max((got - want).abs() / want.abs());
        }
        assert_eq!(expm1_nonpos(0.0), 0.0);
        assert!(worst < 5e-7, "worst relative error {worst}");
    }

    #[test]
    fn vector_and_scalar_paths_agree() {
        // The same input at every lane position and in the scalar tail must give the same bits.
        let n = 37;
        let bias: Vec<f32> = (0..n).map(|j| (j as f32 * 0.37).sin()).collect();
        let base: Vec<f32> = (0..n * 5).map(|i| ((i * 7919 % 1000) as f32 / 100.0) - 6.0).collect();
        let mut y = base.clone();
        bias_act_rows(&mut y, n, &bias, Activation::Elu);
        for (i, (&got, &x)) in y.iter().zip(&base).enumerate() {
            assert_eq!(got.to_bits(), elu(x + bias[i % n]).to_bits());
        }
    }
}
