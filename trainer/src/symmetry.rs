//! The paper's S_o and S_a as the learner sees them: mirror maps of observations and actions, each a signed
//! permutation (`out[i] = sign[i] · in[perm[i]]`). The task derives them from its robot.

#[derive(Debug, Clone, PartialEq)]
pub struct SignedPermutation {
    pub perm: Vec<usize>,
    pub sign: Vec<f32>,
}

impl SignedPermutation {
    pub fn identity(n: usize) -> Self {
        SignedPermutation { perm: (0..n).collect(), sign: vec![1.0; n] }
    }

    pub fn len(&self) -> usize {
        self.perm.len()
    }

    pub fn is_empty(&self) -> bool {
        self.perm.is_empty()
    }

    /// Mirrors one row.
    pub fn apply(&self, src: &[f32], dst: &mut [f32]) {
        for ((d, &p), &s) in dst.iter_mut().zip(&self.perm).zip(&self.sign) {
            *d = s * src[p];
        }
    }

    /// Mirrors every row of a row-major matrix with `self.len()` columns.
    pub fn apply_rows(&self, src: &[f32], dst: &mut [f32]) {
        let n = self.len();
        for (s, d) in src.chunks_exact(n).zip(dst.chunks_exact_mut(n)) {
            self.apply(s, d);
        }
    }

    /// True if applying the map twice gives the identity.
    pub fn is_involution(&self) -> bool {
        (0..self.len()).all(|i| self.perm[self.perm[i]] == i && self.sign[i] * self.sign[self.perm[i]] == 1.0)
    }

    /// Sets entries [offset, offset + perm.len()) to a block map (indices of `perm` relative to the block).
    pub fn set_block(&mut self, offset: usize, perm: &[usize], sign: &[f32]) {
        for i in 0..perm.len() {
            self.perm[offset + i] = offset + perm[i];
            self.sign[offset + i] = sign[i];
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Symmetry {
    pub obs: SignedPermutation,
    pub act: SignedPermutation,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_compose_into_an_involution() {
        let mut m = SignedPermutation::identity(5);
        m.set_block(1, &[1, 0], &[-1.0, -1.0]);
        m.set_block(3, &[0, 1], &[1.0, -1.0]);
        assert!(m.is_involution());
        let mut out = [0.0; 5];
        m.apply(&[1.0, 2.0, 3.0, 4.0, 5.0], &mut out);
        assert_eq!(out, [1.0, -3.0, -2.0, 4.0, -5.0]);
        let mut swap_only_one_sign = SignedPermutation::identity(2);
        swap_only_one_sign.set_block(0, &[1, 0], &[1.0, -1.0]);
        assert!(!swap_only_one_sign.is_involution());
    }
}
