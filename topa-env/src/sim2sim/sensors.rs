//! Sensor and actuator imperfections, each switchable and drawn from the env's own sim2sim random stream:
//! IMU noise with a random-walk bias, encoder quantisation and velocity noise, and fixed delays.

use std::collections::VecDeque;

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Gaussian draw (Box–Muller on our seeded stream).
pub fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// White noise plus a bias that starts at N(0, `bias_initial`²) and walks with `bias_walk` per √s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct NoiseConfig {
    /// Corrupt this sensor's readings (false: exact).
    pub enabled: bool,
    /// Standard deviation of the white noise per sample, in the sensor's unit.
    pub white: f64,
    /// Standard deviation of the initial bias, in the sensor's unit.
    pub bias_initial: f64,
    /// Bias random walk, the sensor's unit per √s.
    pub bias_walk: f64,
}

impl Default for NoiseConfig {
    fn default() -> Self {
        NoiseConfig { enabled: false, white: 0.0, bias_initial: 0.0, bias_walk: 0.0 }
    }
}

/// The noise of a 3-axis sensor: its current bias and the draws that corrupt each reading.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Noise3 {
    pub bias: [f64; 3],
}

impl Noise3 {
    pub fn reset(&mut self, cfg: &NoiseConfig, rng: &mut ChaCha8Rng) {
        self.bias = [0.0; 3];
        if cfg.enabled {
            self.bias = std::array::from_fn(|_| cfg.bias_initial * gaussian(rng));
        }
    }

    /// `v` as the sensor reads it after `dt` seconds of bias drift.
    pub fn corrupt(&mut self, cfg: &NoiseConfig, v: [f64; 3], dt: f64, rng: &mut ChaCha8Rng) -> [f64; 3] {
        if !cfg.enabled {
            return v;
        }
        let walk = cfg.bias_walk * dt.sqrt();
        std::array::from_fn(|k| {
            self.bias[k] += walk * gaussian(rng);
            v[k] + self.bias[k] + cfg.white * gaussian(rng)
        })
    }
}

/// Motor encoders: positions quantised to `counts_per_rev` steps per output revolution; the driver's velocity
/// estimate with Gaussian noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct EncoderConfig {
    /// Quantise positions and add velocity noise (false: exact encoders).
    pub enabled: bool,
    /// Counts per output revolution (0 = no quantisation).
    pub counts_per_rev: f64,
    /// Standard deviation of the velocity noise, rad/s.
    pub velocity_noise: f64,
}

impl Default for EncoderConfig {
    fn default() -> Self {
        EncoderConfig { enabled: false, counts_per_rev: 0.0, velocity_noise: 0.0 }
    }
}

impl EncoderConfig {
    pub fn quantise(&self, q: f64) -> f64 {
        if !self.enabled || self.counts_per_rev <= 0.0 {
            return q;
        }
        let step = std::f64::consts::TAU / self.counts_per_rev;
        (q / step).round() * step
    }

    pub fn velocity(&self, qd: f64, rng: &mut ChaCha8Rng) -> f64 {
        if !self.enabled || self.velocity_noise <= 0.0 {
            return qd;
        }
        qd + self.velocity_noise * gaussian(rng)
    }
}

/// A fixed delay of `delay` pushes: `push` returns what was pushed `delay` calls earlier (the fill value at first).
#[derive(Debug, Clone, PartialEq)]
pub struct Delay<T: Clone> {
    queue: VecDeque<T>,
    delay: usize,
}

impl<T: Clone> Delay<T> {
    pub fn new(delay: usize, fill: T) -> Self {
        Delay { queue: std::iter::repeat_n(fill, delay).collect(), delay }
    }

    pub fn reset(&mut self, fill: T) {
        self.queue.clear();
        self.queue.extend(std::iter::repeat_n(fill, self.delay));
    }

    pub fn push(&mut self, v: T) -> T {
        self.queue.push_back(v);
        self.queue.pop_front().expect("a delay queue holds at least the value just pushed")
    }

    pub fn delay(&self) -> usize {
        self.delay
    }

    /// The queued values, oldest first (for snapshots).
    pub fn items(&self) -> impl Iterator<Item = &T> {
        self.queue.iter()
    }

    pub fn set_items(&mut self, items: impl IntoIterator<Item = T>) {
        self.queue = items.into_iter().collect();
    }
}

impl Delay<Vec<f64>> {
    /// `push` for vectors without allocating (it runs every physics step): `out` gets the value of `delay` pushes
    /// ago, and the oldest buffer is reused for `input`.
    pub fn shift(&mut self, input: &[f64], out: &mut [f64]) {
        match self.queue.pop_front() {
            None => out.copy_from_slice(input),
            Some(mut oldest) => {
                out.copy_from_slice(&oldest);
                oldest.copy_from_slice(input);
                self.queue.push_back(oldest);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn stats(x: &[f64]) -> (f64, f64) {
        let n = x.len() as f64;
        let m = x.iter().sum::<f64>() / n;
        (m, (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt())
    }

    #[test]
    fn white_noise_and_bias_walk_match_their_configuration() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        // White noise only: mean 0, sd as configured.
        let cfg = NoiseConfig { enabled: true, white: 0.02, bias_initial: 0.0, bias_walk: 0.0 };
        let mut n = Noise3::default();
        n.reset(&cfg, &mut rng);
        let x: Vec<f64> = (0..40_000).map(|_| n.corrupt(&cfg, [1.0, 0.0, 0.0], 0.001, &mut rng)[0] - 1.0).collect();
        let (m, sd) = stats(&x);
        assert!(m.abs() < 3.0 * 0.02 / 200.0 && (sd - 0.02).abs() < 0.02 * 0.02, "mean {m}, sd {sd}");
        // Bias walk only: after T seconds the bias has sd bias_walk·√T across independent runs.
        let cfg = NoiseConfig { enabled: true, white: 0.0, bias_initial: 0.0, bias_walk: 0.01 };
        let finals: Vec<f64> = (0..2000)
            .map(|_| {
                let mut n = Noise3::default();
                n.reset(&cfg, &mut rng);
                for _ in 0..400 {
                    n.corrupt(&cfg, [0.0; 3], 0.01, &mut rng);
                }
                n.bias[1]
            })
            .collect();
        let (m, sd) = stats(&finals);
        assert!(m.abs() < 0.0015 && (sd - 0.01 * 2.0).abs() < 0.002, "bias after 4 s: mean {m}, sd {sd}");
        // Disabled: readings pass through untouched.
        let off = NoiseConfig { enabled: false, ..cfg };
        assert_eq!(Noise3::default().corrupt(&off, [0.3, 0.2, 0.1], 0.01, &mut rng), [0.3, 0.2, 0.1]);
    }

    #[test]
    fn encoders_quantise_to_their_resolution_and_add_velocity_noise() {
        let e = EncoderConfig { enabled: true, counts_per_rev: 4096.0, velocity_noise: 0.05 };
        let step = std::f64::consts::TAU / 4096.0;
        for k in 0..1000 {
            let q = -1.3 + k as f64 * 0.00271;
            let r = e.quantise(q);
            assert!((r - q).abs() <= step / 2.0 + 1e-12 && ((r / step) - (r / step).round()).abs() < 1e-9);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let x: Vec<f64> = (0..40_000).map(|_| e.velocity(2.0, &mut rng) - 2.0).collect();
        let (m, sd) = stats(&x);
        assert!(m.abs() < 0.001 && (sd - 0.05).abs() < 0.001, "mean {m}, sd {sd}");
    }

    #[test]
    fn a_delay_returns_what_was_pushed_that_many_calls_before() {
        for d in 0..4 {
            let mut q = Delay::new(d, -1);
            let out: Vec<i32> = (0..8).map(|i| q.push(i)).collect();
            let want: Vec<i32> = (0..8).map(|i| if i < d as i32 { -1 } else { i - d as i32 }).collect();
            assert_eq!(out, want, "delay {d}");
        }
    }
    #[test]
    fn shift_delays_vectors_like_push() {
        for delay in [0, 1, 3] {
            let mut a = Delay::new(delay, vec![0.0, 0.0]);
            let mut b = a.clone();
            let mut out = [f64::NAN; 2];
            for k in 1..8 {
                let v = vec![k as f64, -(k as f64)];
                b.shift(&v, &mut out);
                assert_eq!(a.push(v).as_slice(), out.as_slice(), "delay {delay}, push {k}");
            }
        }
    }
}
