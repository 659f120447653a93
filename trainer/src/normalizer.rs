//! Running observation normalisation (mean/std over everything seen), frozen at evaluation and saved with the
//! policy. With a symmetry it is updated with each batch and its mirror image, so its statistics are exactly
//! symmetric and normalise(S_o(o)) = S_o(normalise(o)) holds bit for bit — the symmetry loss can then mirror
//! normalised observations directly.

use crate::symmetry::SignedPermutation;

/// Added to the standard deviation (rsl_rl's EmpiricalNormalization uses 1e-2), so constant inputs stay finite.
pub const STD_EPS: f64 = 1e-2;

/// One batch's statistics, as merged into a `Normalizer` (and exchanged between ranks).
#[derive(Debug, Clone, PartialEq)]
pub struct Moments {
    pub mean: Vec<f64>,
    pub m2: Vec<f64>,
    pub count: f64,
}

impl Moments {
    /// `[count, mean…, m2…]`, the layout ranks exchange.
    pub fn to_flat(&self) -> Vec<f64> {
        std::iter::once(self.count).chain(self.mean.iter().copied()).chain(self.m2.iter().copied()).collect()
    }

    pub fn from_flat(f: &[f64]) -> Moments {
        let d = (f.len() - 1) / 2;
        Moments { count: f[0], mean: f[1..1 + d].to_vec(), m2: f[1 + d..].to_vec() }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Normalizer {
    pub mean: Vec<f64>,
    /// Sum of squared deviations from the mean (Chan et al.'s parallel algorithm).
    pub m2: Vec<f64>,
    pub count: f64,
    pub frozen: bool,
    mirror: Option<SignedPermutation>,
}

impl Normalizer {
    pub fn new(dim: usize, mirror: Option<SignedPermutation>) -> Self {
        if let Some(m) = &mirror {
            assert_eq!(m.len(), dim, "mirror map size");
        }
        Normalizer { mean: vec![0.0; dim], m2: vec![0.0; dim], count: 0.0, frozen: false, mirror }
    }

    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    pub fn std(&self) -> Vec<f64> {
        let n = self.count.max(1.0);
        self.m2.iter().map(|m| (m / n).sqrt()).collect()
    }

    /// Adds a batch (`rows` × dim, row-major) to the statistics, unless frozen.
    pub fn update(&mut self, batch: &[f32]) {
        if self.frozen || batch.is_empty() {
            return;
        }
        let m = self.batch_moments(batch);
        self.merge(&m);
    }

    /// A batch's mean, squared deviations and row count (its mirror image included when there is a symmetry).
    pub fn batch_moments(&self, batch: &[f32]) -> Moments {
        let d = self.dim();
        let rows = batch.len() / d;
        let mut sum = vec![0.0f64; d];
        for row in batch.chunks_exact(d) {
            for (s, &x) in sum.iter_mut().zip(row) {
                *s += x as f64;
            }
        }
        let (bmean, nb) = match &self.mirror {
            None => (sum.iter().map(|s| s / rows.max(1) as f64).collect::<Vec<_>>(), rows as f64),
            Some(m) => {
                let n = (2 * rows.max(1)) as f64;
                ((0..d).map(|i| (sum[i] + m.sign[i] as f64 * sum[m.perm[i]]) / n).collect(), 2.0 * rows as f64)
            }
        };
        // Per-column squared deviations, each column around its own batch mean.
        let mut q = vec![0.0f64; d];
        for row in batch.chunks_exact(d) {
            for i in 0..d {
                let dev = row[i] as f64 - bmean[i];
                q[i] += dev * dev;
            }
        }
        let m2: Vec<f64> = match &self.mirror {
            None => q,
            // The mirrored rows of column i are sign·column perm[i], whose deviations from mean[i] are those of
            // column perm[i] from its own mean (mean[perm i] = sign·mean[i]).
            Some(m) => (0..d).map(|i| q[i] + q[m.perm[i]]).collect(),
        };
        Moments { mean: bmean, m2, count: nb }
    }

    /// Chan et al.'s merge of a batch's moments into the running statistics.
    pub fn merge(&mut self, b: &Moments) {
        if b.count <= 0.0 {
            return;
        }
        let total = self.count + b.count;
        for i in 0..self.dim() {
            let delta = b.mean[i] - self.mean[i];
            self.mean[i] += delta * b.count / total;
            self.m2[i] += b.m2[i] + delta * delta * self.count * b.count / total;
        }
        self.count = total;
    }

    /// Writes (x − mean) / (std + ε) for every row of `src` into `dst`.
    pub fn normalize(&self, src: &[f32], dst: &mut [f32]) {
        let d = self.dim();
        let n = self.count.max(1.0);
        let scale: Vec<f64> = self.m2.iter().map(|m| 1.0 / ((m / n).sqrt() + STD_EPS)).collect();
        for (s, t) in src.chunks_exact(d).zip(dst.chunks_exact_mut(d)) {
            for i in 0..d {
                t[i] = ((s[i] as f64 - self.mean[i]) * scale[i]) as f32;
            }
        }
    }

    /// Replaces the statistics (loading a policy or checkpoint); checks the size.
    pub fn set_stats(&mut self, mean: Vec<f64>, m2: Vec<f64>, count: f64) -> crate::error::Result<()> {
        if mean.len() != self.dim() || m2.len() != self.dim() {
            return Err(crate::error::Error::bad_file(format!(
                "normaliser has {} inputs, the file has {}",
                self.dim(),
                mean.len()
            )));
        }
        if !(count.is_finite() && count >= 0.0) || mean.iter().chain(&m2).any(|x| !x.is_finite()) {
            return Err(crate::error::Error::bad_file("normaliser statistics are not finite"));
        }
        self.mean = mean;
        self.m2 = m2;
        self.count = count;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_plain_mean_and_std() {
        let mut n = Normalizer::new(2, None);
        let data: Vec<f32> = (0..100).flat_map(|i| [i as f32, (i * i) as f32 * 0.01]).collect();
        n.update(&data[..60]);
        n.update(&data[60..]);
        let col = |c: usize| data.iter().skip(c).step_by(2).map(|&x| x as f64).collect::<Vec<_>>();
        for c in 0..2 {
            let v = col(c);
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let s = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
            assert!((n.mean[c] - m).abs() < 1e-9 && (n.std()[c] - s).abs() < 1e-9);
        }
    }

    #[test]
    fn symmetric_statistics_commute_with_the_mirror_exactly() {
        let mirror = SignedPermutation { perm: vec![1, 0, 2], sign: vec![1.0, 1.0, -1.0] };
        let mut n = Normalizer::new(3, Some(mirror.clone()));
        let batch: Vec<f32> = (0..30).map(|i| ((i * 37) % 17) as f32 * 0.3 - 1.0).collect();
        n.update(&batch);
        n.update(&batch[..12]);
        let (mut a, mut b, mut m) = (vec![0.0; 30], vec![0.0; 30], vec![0.0; 30]);
        n.normalize(&batch, &mut a);
        mirror.apply_rows(&batch, &mut m);
        n.normalize(&m, &mut b);
        let mut ma = vec![0.0; 30];
        mirror.apply_rows(&a, &mut ma);
        assert_eq!(ma, b);
        assert_eq!(n.mean[2], 0.0, "a sign-flipped input has zero mean under the mirror");
    }

    #[test]
    fn frozen_ignores_updates() {
        let mut n = Normalizer::new(1, None);
        n.update(&[1.0, 2.0]);
        n.frozen = true;
        n.update(&[100.0]);
        assert_eq!(n.count, 2.0);
    }
}
