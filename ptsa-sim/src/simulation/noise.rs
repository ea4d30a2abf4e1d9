//! The pickoff noise: one standard-normal draw per tick, from a seed.

use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::{RngCore, SeedableRng};

/// Entries of a [`NoiseSource`]'s table.
const NOISE_TABLE: usize = 4096;

/// The per-tick noise source: wyrand (one multiply per draw) indexing a table of 4096
/// standard-normal values drawn once (Box-Muller from `ChaCha8`, normalised to mean 0 and
/// variance 1), all from the seed. Cheap enough for the hot loop; the table's 4096 levels
/// are far finer than the ADC's. Plain data but for the table, which copies of one source
/// share.
#[derive(Clone, Debug)]
pub(super) struct NoiseSource {
    /// The generator's state.
    pub(super) state: u64,
    /// The standard-normal values.
    pub(super) table: std::sync::Arc<[f64; NOISE_TABLE]>,
}

impl NoiseSource {
    /// The source of `seed`: its table and the generator's first state.
    pub(super) fn new(seed: u64) -> Self {
        let mut c = ChaCha8Rng::seed_from_u64(seed);
        // Built on the heap: 32 KiB is too much for a stack frame (`large_stack_arrays`).
        let mut t = vec![0.0f64; NOISE_TABLE];
        let unit = |x: u64| {
            #[allow(clippy::cast_precision_loss)]
            let u = ((x >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
            u
        };
        for pair in t.chunks_mut(2) {
            let (u1, u2) = (unit(c.next_u64()), unit(c.next_u64()));
            let r = (-2.0 * u1.ln()).sqrt();
            let (s, co) = (std::f64::consts::TAU * u2).sin_cos();
            pair[0] = r * co;
            if pair.len() > 1 {
                pair[1] = r * s;
            }
        }
        #[allow(clippy::cast_precision_loss)]
        let n = NOISE_TABLE as f64;
        let mean = t.iter().sum::<f64>() / n;
        let sd = (t.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        for x in &mut t {
            *x = (*x - mean) / sd;
        }
        let table = std::sync::Arc::<[f64]>::from(t)
            .try_into()
            .expect("the table has NOISE_TABLE entries");
        Self {
            state: c.next_u64(),
            table,
        }
    }

    /// Whether `other` draws the same numbers from now on (the same generator state and the
    /// same table).
    pub(super) fn same_stream(&self, other: &NoiseSource) -> bool {
        self.state == other.state
            && (std::sync::Arc::ptr_eq(&self.table, &other.table)
                || self
                    .table
                    .iter()
                    .zip(other.table.iter())
                    .all(|(a, b)| a.to_bits() == b.to_bits()))
    }

    /// One standard-normal draw.
    #[allow(clippy::inline_always, reason = "per-tick path")]
    #[inline(always)]
    pub(super) fn normal(&mut self) -> f64 {
        self.state = self.state.wrapping_add(0xa076_1d64_78bd_642f);
        let t = u128::from(self.state) * u128::from(self.state ^ 0xe703_7ed1_a0b4_28db);
        #[allow(clippy::cast_possible_truncation)]
        let r = ((t >> 64) as u64) ^ (t as u64);
        let j = (r >> 52) as usize;
        self.table[j & (NOISE_TABLE - 1)]
    }
}
