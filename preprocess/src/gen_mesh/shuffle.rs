//! `gen mesh --shuffle-vertices`: a pseudo-random bijection of [0, n) computable both ways in
//! O(1) memory — a Feistel network on the smallest power of two ≥ n (an unbalanced one when
//! the bit count is odd: rounds alternately xor a keyed hash of one part into the other), with
//! cycle walking (apply again until the value falls below n; the domain is < 2n, so a walk
//! takes fewer than 2 steps on average). Neighbouring indices land far apart: the output has
//! no locality for an importer to exploit.

const ROUNDS: usize = 6;

/// A keyed permutation of [0, n).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Shuffle {
    n: u64,
    /// Bits of the low part; the high part has the rest.
    low_bits: u32,
    high_bits: u32,
    keys: [u64; ROUNDS],
}

impl Shuffle {
    /// The permutation of [0, n) for `seed`.
    pub fn new(n: u64, seed: u64) -> Shuffle {
        assert!(n > 0, "Shuffle of an empty range");
        let bits = (64 - (n - 1).leading_zeros()).max(2);
        let mut keys = [0; ROUNDS];
        let mut k = super::surface::splitmix64(seed ^ 0x0073_6875_6666_6c65);
        for key in &mut keys {
            k = super::surface::splitmix64(k);
            *key = k;
        }
        Shuffle {
            n,
            low_bits: bits / 2,
            high_bits: bits - bits / 2,
            keys,
        }
    }

    /// A keyed hash of `x` cut to `bits` bits.
    fn hash(x: u64, key: u64, bits: u32) -> u64 {
        let h = (x ^ key).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let h = (h ^ (h >> 29)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        (h >> 32 ^ h) & ((1 << bits) - 1)
    }

    /// Round `r` (its own inverse): even rounds change the high part, odd ones the low part.
    fn round(&self, x: u64, r: usize) -> u64 {
        let (hi, lo) = (x >> self.low_bits, x & ((1 << self.low_bits) - 1));
        if r.is_multiple_of(2) {
            let hi = hi ^ Self::hash(lo, self.keys[r], self.high_bits);
            (hi << self.low_bits) | lo
        } else {
            (hi << self.low_bits) | (lo ^ Self::hash(hi, self.keys[r], self.low_bits))
        }
    }

    fn forward_once(&self, x: u64) -> u64 {
        (0..ROUNDS).fold(x, |x, r| self.round(x, r))
    }

    fn inverse_once(&self, y: u64) -> u64 {
        (0..ROUNDS).rev().fold(y, |y, r| self.round(y, r))
    }

    /// Where index `i` < n goes.
    pub fn forward(&self, i: u64) -> u64 {
        debug_assert!(i < self.n);
        let mut y = self.forward_once(i);
        while y >= self.n {
            y = self.forward_once(y);
        }
        y
    }

    /// The index that goes to `j` < n.
    pub fn inverse(&self, j: u64) -> u64 {
        debug_assert!(j < self.n);
        let mut x = self.inverse_once(j);
        while x >= self.n {
            x = self.inverse_once(x);
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bijective_both_ways() {
        for n in [1, 2, 3, 5, 16, 17, 1000, 65_537, 100_003] {
            let s = Shuffle::new(n, 42);
            let mut hit = vec![false; n as usize];
            for i in 0..n {
                let j = s.forward(i);
                assert!(j < n && !hit[j as usize], "n = {n}: {i} → {j}");
                hit[j as usize] = true;
                assert_eq!(s.inverse(j), i);
            }
        }
    }

    #[test]
    fn no_locality_and_seeded() {
        let n = 1_000_003;
        let s = Shuffle::new(n, 1);
        // Consecutive indices land far apart: the mean jump is near n / 3 (uniform pairs).
        let jumps: f64 = (0..10_000)
            .map(|i| s.forward(i).abs_diff(s.forward(i + 1)) as f64)
            .sum::<f64>()
            / 10_000.0;
        assert!(
            jumps > 0.25 * n as f64 && jumps < 0.42 * n as f64,
            "{jumps}"
        );
        let fixed = (0..10_000).filter(|&i| s.forward(i) == i).count();
        assert!(fixed < 5, "{fixed} fixed points");
        let other = Shuffle::new(n, 2);
        let same = (0..10_000)
            .filter(|&i| s.forward(i) == other.forward(i))
            .count();
        assert!(same < 5, "seeds 1 and 2 agree on {same} of 10,000");
    }
}
