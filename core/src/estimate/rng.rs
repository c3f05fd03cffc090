//! A small deterministic pseudo-random generator for RANSAC sampling.
//!
//! PCG-XSH-RR 32 (O'Neill 2014): 8 bytes of state, no floating point, the same sequence on every
//! target. The caller seeds it, so runs repeat exactly.

/// PCG-XSH-RR with 64-bit state and 32-bit output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pcg32 {
    state: u64,
}

/// PCG's default multiplier.
const MULTIPLIER: u64 = 6_364_136_223_846_793_005;
/// PCG's default (odd) increment.
const INCREMENT: u64 = 1_442_695_040_888_963_407;

impl Pcg32 {
    /// A generator seeded with `seed`.
    #[must_use]
    pub const fn new(seed: u64) -> Self {
        let mut g = Self { state: 0 };
        g.state = g.state.wrapping_mul(MULTIPLIER).wrapping_add(INCREMENT);
        g.state = g.state.wrapping_add(seed);
        g.state = g.state.wrapping_mul(MULTIPLIER).wrapping_add(INCREMENT);
        g
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULTIPLIER).wrapping_add(INCREMENT);
        // Truncations are the algorithm: the top bits are output, rotated by the top 5 bits.
        #[allow(clippy::cast_possible_truncation)]
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        #[allow(clippy::cast_possible_truncation)]
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A value in `0..n` (0 when `n == 0`), by Lemire's multiply-shift (bias below 2^-32 * n).
    pub fn below(&mut self, n: usize) -> usize {
        let n64 = n as u64;
        let r = u64::from(self.next_u32());
        // (r * n) >> 32 < n, so the conversion back cannot fail.
        usize::try_from((r * n64) >> 32).unwrap_or(0)
    }

    /// Three distinct indices in `0..n`, or `None` when `n < 3`.
    pub fn three_distinct(&mut self, n: usize) -> Option<[usize; 3]> {
        if n < 3 {
            return None;
        }
        let a = self.below(n);
        let mut b = self.below(n - 1);
        if b >= a {
            b += 1;
        }
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        let mut c = self.below(n - 2);
        if c >= lo {
            c += 1;
        }
        if c >= hi {
            c += 1;
        }
        Some([a, b, c])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeatable_and_distinct() {
        let mut a = Pcg32::new(42);
        let mut b = Pcg32::new(42);
        for _ in 0..100 {
            assert_eq!(a.next_u32(), b.next_u32());
        }
        let mut g = Pcg32::new(1);
        let mut hits = [0u32; 5];
        for _ in 0..5000 {
            let [x, y, z] = g.three_distinct(5).unwrap_or([0, 0, 0]);
            assert!(x != y && y != z && x != z && x < 5 && y < 5 && z < 5);
            for i in [x, y, z] {
                if let Some(h) = hits.get_mut(i) {
                    *h += 1;
                }
            }
        }
        // Each index appears in about 3/5 of the draws.
        assert!(hits.iter().all(|&h| (2700..3300).contains(&h)), "{hits:?}");
        assert!(g.three_distinct(2).is_none());
    }
}
