//! Bit-packed integers, low bit first: fixed widths for values of a known range and Rice
//! codes for gaps between sorted integers — how the live store packs a patch's rows, ids
//! and positions (`packed_columns.rs`) in about half the bytes of plain words.

/// Appends values of any width up to 32 bits to a byte vector.
pub struct BitWriter<'a> {
    out: &'a mut Vec<u8>,
    word: u64,
    filled: u32,
}

impl<'a> BitWriter<'a> {
    pub fn new(out: &'a mut Vec<u8>) -> Self {
        BitWriter {
            out,
            word: 0,
            filled: 0,
        }
    }

    /// The low `width` bits of `value` (`width` <= 32).
    pub fn put(&mut self, value: u32, width: u32) {
        debug_assert!(width <= 32 && (width == 32 || value >> width == 0));
        self.word |= (value as u64) << self.filled;
        self.filled += width;
        while self.filled >= 8 {
            self.out.push(self.word as u8);
            self.word >>= 8;
            self.filled -= 8;
        }
    }

    /// `value`'s Rice code with parameter `k` (< 32): `value >> k` ones, a zero, the low `k`
    /// bits.
    pub fn rice(&mut self, value: u32, k: u32) {
        let mut q = value >> k;
        while q >= 32 {
            self.put(u32::MAX, 32);
            q -= 32;
        }
        self.put((1u32 << q) - 1, q + 1);
        self.put(value & ((1u32 << k) - 1), k);
    }

    /// Pads to a whole byte.
    pub fn finish(mut self) {
        if self.filled > 0 {
            self.out.push(self.word as u8);
        }
        self.word = 0;
        self.filled = 0;
    }
}

/// Reads what a `BitWriter` wrote, from a byte slice that starts where it started.
pub struct BitReader<'a> {
    bytes: &'a [u8],
    at: usize,
    word: u64,
    filled: u32,
}

impl<'a> BitReader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        BitReader {
            bytes,
            at: 0,
            word: 0,
            filled: 0,
        }
    }

    #[inline]
    fn refill(&mut self) {
        // Whole bytes that fit: the same `at` and `filled` `refill_near_the_end` leaves, read at once
        // where eight bytes remain (the loop's byte at a time was most of decoding a record).
        let n = ((56 - self.filled.min(56)) / 8 + 1) as usize;
        if self.filled <= 56 && self.at + 8 <= self.bytes.len() {
            let next = u64::from_le_bytes(
                self.bytes[self.at..self.at + 8]
                    .try_into()
                    .expect("eight bytes"),
            );
            let kept = if n == 8 {
                next
            } else {
                next & ((1u64 << (8 * n)) - 1)
            };
            self.word |= kept << self.filled;
            self.at += n;
            self.filled += 8 * n as u32;
            return;
        }
        self.refill_near_the_end();
    }

    /// `refill` a byte at a time, where fewer than eight bytes remain.
    #[cold]
    fn refill_near_the_end(&mut self) {
        while self.filled <= 56 {
            // Past the end reads zeros: the writer's padding, or damage a checksum catches.
            let byte = self.bytes.get(self.at).copied().unwrap_or(0);
            self.word |= (byte as u64) << self.filled;
            self.at += 1;
            self.filled += 8;
        }
    }

    #[inline]
    pub fn get(&mut self, width: u32) -> u32 {
        if width == 0 {
            return 0;
        }
        if self.filled < width {
            self.refill();
        }
        let value = (self.word & ((1u64 << width) - 1)) as u32;
        self.word >>= width;
        self.filled -= width;
        value
    }

    /// A Rice code with parameter `k`; `None` where its value overflows (damage).
    #[inline]
    pub fn rice(&mut self, k: u32) -> Option<u32> {
        let mut q = 0u32;
        loop {
            if self.filled == 0 {
                self.refill();
            }
            let ones = (!self.word).trailing_zeros().min(self.filled);
            q = q.checked_add(ones)?;
            self.word = self.word.checked_shr(ones).unwrap_or(0);
            self.filled -= ones;
            if self.filled > 0 {
                // The terminating zero.
                self.word >>= 1;
                self.filled -= 1;
                break;
            }
        }
        let high = q.checked_mul(1u32.checked_shl(k)?)?;
        high.checked_add(self.get(k))
    }

    /// Bytes consumed, counting the last partly read byte.
    pub fn bytes_read(&self) -> usize {
        self.at - (self.filled / 8) as usize
    }

    /// Whether reading went past the bytes (what was read there was zeros: damage).
    pub fn overran(&self) -> bool {
        self.bytes_read() > self.bytes.len()
    }
}

/// Bits `max` needs (0 for 0).
pub fn width_of(max: u32) -> u32 {
    32 - max.leading_zeros()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A xorshift64 stream from `seed` (nonzero): the tests' random bits.
    fn xorshift(mut state: u64) -> impl FnMut() -> u64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        }
    }

    #[test]
    fn fixed_widths_and_rice_codes_read_back_as_written() {
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
        let mut items = Vec::new();
        for i in 0..5000 {
            let r = next();
            let width = (r % 33) as u32;
            let value = if width == 32 {
                (r >> 32) as u32
            } else {
                ((r >> 32) as u32) & ((1u32 << width) - 1)
            };
            let k = (r >> 8) as u32 % 20;
            // Mostly small gaps, now and then a huge one.
            let gap = if i % 97 == 0 {
                (r >> 40) as u32
            } else {
                ((r >> 16) as u32) % (4u32 << k)
            };
            items.push((value, width, gap, k));
        }
        let mut bytes = vec![0xAB]; // something before, as in a record
        let mut w = BitWriter::new(&mut bytes);
        for &(value, width, gap, k) in &items {
            w.put(value, width);
            w.rice(gap, k);
        }
        w.finish();
        let mut r = BitReader::new(&bytes[1..]);
        for &(value, width, gap, k) in &items {
            assert_eq!(r.get(width), value);
            assert_eq!(r.rice(k), Some(gap));
        }
        assert_eq!(r.bytes_read(), bytes.len() - 1);
        assert_eq!(width_of(0), 0);
        assert_eq!(width_of(1), 1);
        assert_eq!(width_of(255), 8);
        assert_eq!(width_of(u32::MAX), 32);
    }

    #[test]
    fn every_read_is_the_bits_at_its_position_near_the_end_and_past_it() {
        // A reference: bit p of the bytes, zeros past them.
        let bit = |bytes: &[u8], p: usize| bytes.get(p / 8).map_or(0, |b| (b >> (p % 8)) & 1);
        let mut next = xorshift(0x2545_f491_4f6c_dd1d);
        for len in 0..40 {
            let bytes: Vec<u8> = (0..len).map(|_| next() as u8).collect();
            let mut r = BitReader::new(&bytes);
            let mut p = 0usize;
            while p < 8 * len + 80 {
                let width = (next() % 33) as u32;
                let expected =
                    (0..width as usize).fold(0u32, |v, i| v | (bit(&bytes, p + i) as u32) << i);
                assert_eq!(r.get(width), expected, "{width} bits at {p} of {len} bytes");
                p += width as usize;
                assert_eq!(r.bytes_read(), p.div_ceil(8));
                assert_eq!(r.overran(), p.div_ceil(8) > len);
            }
        }
    }

    #[test]
    fn reading_past_the_bytes_or_over_32_bits_is_seen() {
        let bytes = vec![0xFF; 64];
        let mut r = BitReader::new(&bytes);
        assert!(!r.overran());
        r.rice(3);
        assert!(r.overran());
        let mut r = BitReader::new(&bytes);
        assert_eq!(r.rice(31), None);
    }
}
