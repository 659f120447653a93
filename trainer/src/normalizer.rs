//! Running observation normalisation (mean/std over everything seen), frozen at evaluation and saved with the
//! policy. With a symmetry it is updated with each batch and its mirror image, so its statistics are exactly
//! symmetric and normalise(S_o(o)) = S_o(normalise(o)) holds bit for bit — the symmetry loss can then mirror
//! normalised observations directly.

use topa_env::SignedPermutation;

/// Added to the standard deviation (rsl_rl's EmpiricalNormalization uses 1e-2), so constant inputs stay finite.
pub const STD_EPS: f64 = 1e-2;

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
        let d = self.dim();
        if self.frozen || batch.is_empty() {
            return;
        }
        let rows = batch.len() / d;
        let mut sum = vec![0.0f64; d];
        for row in batch.chunks_exact(d) {
            for (s, &x) in sum.iter_mut().zip(row) {
                *s += x as f64;
            }
        }
        let (bmean, nb) = match &self.mirror {
            None => (sum.iter().map(|s| s / rows as f64).collect::<Vec<_>>(), rows as f64),
            Some(m) => {
                let n = 2.0 * rows as f64;
                ((0..d).map(|i| (sum[i] + m.sign[i] as f64 * sum[m.perm[i]]) / n).collect(), n)
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
        let bm2: Vec<f64> = match &self.mirror {
            None => q.clone(),
            // The mirrored rows of column i are sign·column perm[i], whose deviations from mean[i] are those of
            // column perm[i] from its own mean (mean[perm i] = sign·mean[i]).
            Some(m) => (0..d).map(|i| q[i] + q[m.perm[i]]).collect(),
        };
        let total = self.count + nb;
        for i in 0..d {
            let delta = bmean[i] - self.mean[i];
            self.mean[i] += delta * nb / total;
            self.m2[i] += bm2[i] + delta * delta * self.count * nb / total;
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
    pub fn set_stats(&mut self, mean: Vec<f64>, m2: Vec<f64>, count: f64) -> Result<(), String> {
        if mean.len() != self.dim() || m2.len() != self.dim() {
            return Err(format!("normaliser has {} inputs, the file has {}", self.dim(), mean.len()));
        }
        if !(count.is_finite() && count >= 0.0) || mean.iter().chain(&m2).any(|x| !x.is_finite()) {
            return Err("normaliser statistics are not finite".into());
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
