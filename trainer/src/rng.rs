//! The position of a ChaCha stream as plain words, so that checkpoints (and the tasks' own snapshots) continue
//! every random stream exactly.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Words written by `save_rng`.
pub const RNG_WORDS: usize = 7;

/// Serialises a ChaCha RNG's position (seed, stream, word position) as u64 words.
pub fn save_rng(rng: &ChaCha8Rng, out: &mut Vec<u64>) {
    let seed = rng.get_seed();
    out.extend(seed.chunks(8).map(|c| u64::from_le_bytes(c.try_into().unwrap())));
    out.push(rng.get_stream());
    let pos = rng.get_word_pos();
    out.push(pos as u64);
    out.push((pos >> 64) as u64);
}

/// Inverse of `save_rng`; consumes `RNG_WORDS` words.
pub fn load_rng(words: &[u64]) -> ChaCha8Rng {
    let mut seed = [0u8; 32];
    for (i, w) in words[..4].iter().enumerate() {
        seed[i * 8..(i + 1) * 8].copy_from_slice(&w.to_le_bytes());
    }
    let mut rng = ChaCha8Rng::from_seed(seed);
    rng.set_stream(words[4]);
    rng.set_word_pos(words[5] as u128 | ((words[6] as u128) << 64));
    rng
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;

    #[test]
    fn a_restored_stream_continues_where_it_stood() {
        let mut a = ChaCha8Rng::seed_from_u64(9);
        a.set_stream(3);
        let _: Vec<u32> = (0..17).map(|_| a.random()).collect();
        let mut words = Vec::new();
        save_rng(&a, &mut words);
        assert_eq!(words.len(), RNG_WORDS);
        let mut b = load_rng(&words);
        for _ in 0..100 {
            assert_eq!(a.random::<u64>(), b.random::<u64>());
        }
    }
}
