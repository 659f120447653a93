//! A network between the two sides that is worse than loopback (as Linux's netem makes one): each datagram is
//! lost with a probability, or delivered after a fixed latency plus a uniform jitter — so frames can also arrive
//! out of order, which the receiver then refuses as stale. Seeded: a run's losses are reproducible.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How many datagrams can be in flight at once; more are lost (and counted).
const SLOTS: usize = 256;

#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Impairment {
    /// Probability that a datagram is lost, 0–1.
    pub loss: f64,
    /// Fixed one-way latency, s.
    pub latency_s: f64,
    /// Extra latency drawn uniformly from [0, jitter_s] per datagram, s.
    pub jitter_s: f64,
}

impl Impairment {
    pub fn is_none(&self) -> bool {
        self.loss == 0.0 && self.latency_s == 0.0 && self.jitter_s == 0.0
    }

    pub fn validate(&self) -> crate::Result<()> {
        let ok = (0.0..1.0).contains(&self.loss) && self.latency_s >= 0.0 && self.jitter_s >= 0.0;
        if ok && self.latency_s.is_finite() && self.jitter_s.is_finite() {
            Ok(())
        } else {
            Err(crate::Error::Invalid(format!(
                "network impairment: loss must be in [0, 1), latency and jitter ≥ 0 s (got loss {}, latency {} s, jitter {} s)",
                self.loss, self.latency_s, self.jitter_s
            )))
        }
    }
}

/// Datagrams on their way through an impaired network, in buffers allocated once.
pub struct Netem {
    cfg: Impairment,
    rng: ChaCha8Rng,
    due: Vec<f64>,
    len: Vec<usize>,
    data: Vec<Vec<u8>>,
    /// Datagrams the network lost (drawn, or no slot free).
    pub lost: u64,
}

impl Netem {
    pub fn new(cfg: Impairment, seed: u64) -> Netem {
        Netem {
            cfg,
            rng: ChaCha8Rng::seed_from_u64(seed),
            due: vec![f64::INFINITY; SLOTS],
            len: vec![0; SLOTS],
            data: (0..SLOTS).map(|_| Vec::with_capacity(1024)).collect(),
            lost: 0,
        }
    }

    /// A datagram enters the network at `now_s`.
    pub fn push(&mut self, now_s: f64, datagram: &[u8]) {
        let lose = self.cfg.loss > 0.0 && self.rng.random::<f64>() < self.cfg.loss;
        let free = self.due.iter().position(|d| d.is_infinite());
        match free {
            Some(i) if !lose => {
                let jitter = if self.cfg.jitter_s > 0.0 { self.rng.random::<f64>() * self.cfg.jitter_s } else { 0.0 };
                self.due[i] = now_s + self.cfg.latency_s + jitter;
                self.len[i] = datagram.len();
                self.data[i].clear();
                self.data[i].extend_from_slice(datagram);
            }
            _ => self.lost += 1,
        }
    }

    /// Hands every datagram due by `now_s` to `deliver`, earliest first.
    pub fn deliver(&mut self, now_s: f64, mut deliver: impl FnMut(&[u8])) {
        loop {
            let (i, t) =
                self.due.iter().copied().enumerate().fold((0, f64::INFINITY), |b, x| if x.1 < b.1 { x } else { b });
            // An infinite due time is an empty slot.
            if t.is_infinite() || t > now_s {
                return;
            }
            self.due[i] = f64::INFINITY;
            deliver(&self.data[i][..self.len[i]]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loss_rate_and_delays_are_what_was_asked() {
        let cfg = Impairment { loss: 0.05, latency_s: 0.001, jitter_s: 0.002 };
        let mut n = Netem::new(cfg, 7);
        let (mut got, mut late) = (0u64, (f64::INFINITY, 0.0f64));
        // Time in steps of 0.1 ms; a datagram enters every 1 ms.
        for k in 0..100_000u32 {
            let t = k as f64 * 1e-4;
            if k % 10 == 0 {
                n.push(t, &k.to_le_bytes());
            }
            n.deliver(t, |d| {
                let delay = t - u32::from_le_bytes(d.try_into().unwrap()) as f64 * 1e-4;
                late = (late.0.min(delay), late.1.max(delay));
                got += 1;
            });
        }
        n.deliver(f64::INFINITY, |_| got += 1);
        let lost = n.lost as f64 / 10_000.0;
        assert!((lost - 0.05).abs() < 0.01, "lost {lost}");
        assert_eq!(got + n.lost, 10_000, "every datagram delivered, or lost");
        assert!(late.0 >= 0.001 - 1e-9 && late.1 <= 0.003 + 1e-4 + 1e-9, "delays {late:?}");
        assert!(late.1 - late.0 > 0.0015, "the jitter spreads the delays: {late:?}");
    }
}
