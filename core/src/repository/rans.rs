//! A small static-model rANS coder (Duda's range asymmetric numeral systems, with a 32-bit
//! state renormalised by 16-bit words, as Giesen's `rans_word`: at most one word a symbol, read
//! without a branch) with its frequency tables, for the coded patches (`coded.rs`): alphabets
//! of at most 256 symbols, probabilities in `PROB_BITS` bits, and a second stream of raw bits
//! beside it (`BitWriter` / `BitReader`).
//!
//! Encoding runs backwards over the symbols (rANS is last in, first out); the bytes are
//! reversed once at the end, so the decoder reads forward. A table is written as the range of
//! symbols with a weight (two bytes) then a 4-bit weight a symbol of it (`Table::write`), from
//! which encoder and decoder compute the same frequencies (`normalise`).
//!
//! Decoding trusts nothing: any table's weights normalise to 2^`PROB_BITS`, the state starts in
//! [L, 2^16 L), each symbol reads at most one word, and a read past the stream's end reads
//! zero and is remembered (so the hot loop has no early exit): `finish` then fails, as it does
//! unless the final state is the encoder's initial one with every byte used. A crafted stream
//! is an error in time linear in its length and symbol count.

/// Bits of probability precision: 2^10 slots a table (4 KiB of decoding entries, filled per
/// patch: fewer slots fill faster, and a patch's few hundred symbols need no finer).
pub const PROB_BITS: u32 = 10;
/// The sum of a table's frequencies.
pub const PROB_SCALE: u32 = 1 << PROB_BITS;
/// The lower bound of the normalised state.
const RANS_L: u32 = 1 << 16;

/// Normalised frequencies of an alphabet (sum `PROB_SCALE`), with their cumulative starts and
/// the log-scale weights they were made from (what `write` stores).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Table {
    freq: Vec<u32>,
    start: Vec<u32>,
    weights: Vec<u8>,
}

/// Largest weight code: weight k stands for 2^(k − 1), 0 for a symbol never coded.
const MAX_WEIGHT: u8 = 15;

impl Table {
    /// The table of `counts` (one per symbol; at least one non-zero): each counted symbol's
    /// count scaled so the largest is 2^14, rounded to a power of two in the log domain (a
    /// 4-bit weight, so a table costs half a byte a symbol: patches hold a few hundred
    /// symbols, exact frequencies would cost more than they save), then normalised
    /// (`normalise`). Panics if no symbol is counted or the alphabet has more than 255
    /// symbols (the coder's callers bound both).
    pub fn from_counts(counts: &[u64]) -> Table {
        let used = counts
            .iter()
            .rposition(|&c| c > 0)
            .expect("a symbol counted")
            + 1;
        assert!(used <= 255, "alphabet of {used} symbols");
        let largest = *counts.iter().max().expect("non-empty") as f64;
        let weights: Vec<u8> = counts[..used]
            .iter()
            .map(|&c| match c {
                0 => 0,
                c => {
                    let log = (c as f64 / largest).log2() + (MAX_WEIGHT - 1) as f64;
                    (log.round() as i64 + 1).clamp(1, MAX_WEIGHT as i64) as u8
                }
            })
            .collect();
        Table::from_weights(weights)
    }

    fn from_weights(weights: Vec<u8>) -> Table {
        let freq = normalise(&weights);
        let mut start = Vec::with_capacity(freq.len());
        let mut at = 0;
        for &f in &freq {
            start.push(at);
            at += f;
        }
        debug_assert_eq!(at, PROB_SCALE);
        Table {
            freq,
            start,
            weights,
        }
    }

    /// The number of symbols (the largest counted + 1).
    pub fn alphabet(&self) -> usize {
        self.freq.len()
    }

    /// The cost in bits of coding `symbol` with this table.
    pub fn cost_bits(&self, symbol: usize) -> f64 {
        PROB_BITS as f64 - (self.freq[symbol] as f64).log2()
    }

    /// Appends the table's serialised form: the first symbol with a weight, how many symbols
    /// from it to the last one with a weight (one byte each), then their weights, two a byte
    /// (low half first; an odd count leaves the last high half zero).
    pub fn write(&self, out: &mut Vec<u8>) {
        let first = self.weights.iter().position(|&w| w > 0).expect("a symbol");
        let used = &self.weights[first..];
        out.push(first as u8);
        out.push(used.len() as u8);
        for pair in used.chunks(2) {
            out.push(pair[0] | pair.get(1).map_or(0, |&w| w << 4));
        }
    }
}

/// The frequencies (sum `PROB_SCALE`) of weight codes (k: 2^(k − 1), 0: none; at most 255,
/// one non-zero at least): each in proportion, at least 1 where the weight is not 0, the
/// rounding's difference taken from or given to the largest. Integer arithmetic only: the
/// encoder and every decoder compute the same table.
fn normalise(weights: &[u8]) -> Vec<u32> {
    let total: u64 = weights
        .iter()
        .map(|&k| if k == 0 { 0 } else { 1u64 << (k - 1) })
        .sum();
    let mut freq: Vec<u32> = weights
        .iter()
        .map(|&k| match k {
            0 => 0,
            k => (((1u64 << (k - 1)) * PROB_SCALE as u64 / total) as u32).max(1),
        })
        .collect();
    let mut sum: i64 = freq.iter().map(|&f| f as i64).sum();
    while sum != PROB_SCALE as i64 {
        // The first of the largest.
        let mut largest = 0;
        for (s, &f) in freq.iter().enumerate() {
            if f > freq[largest] {
                largest = s;
            }
        }
        if sum > PROB_SCALE as i64 {
            let excess = (sum - PROB_SCALE as i64).min(freq[largest] as i64 - 1);
            freq[largest] -= excess as u32;
            sum -= excess;
        } else {
            freq[largest] += (PROB_SCALE as i64 - sum) as u32;
            sum = PROB_SCALE as i64;
        }
    }
    freq
}

/// Appends `value` as a LEB128 varint.
pub fn write_varint(mut value: u64, out: &mut Vec<u8>) {
    while value >= 0x80 {
        out.push(value as u8 | 0x80);
        value >>= 7;
    }
    out.push(value as u8);
}

/// Reads a LEB128 varint of at most `max_bytes` bytes from `bytes` at `*at`.
pub fn read_varint(bytes: &[u8], at: &mut usize, max_bytes: usize) -> Result<u64, String> {
    let mut value = 0u64;
    for shift in 0..max_bytes {
        let Some(&b) = bytes.get(*at) else {
            return Err(format!("a varint truncated at byte {at}"));
        };
        *at += 1;
        value |= ((b & 0x7F) as u64) << (7 * shift);
        if b & 0x80 == 0 {
            return Ok(value);
        }
    }
    Err(format!("a varint longer than {max_bytes} bytes"))
}

/// A table ready for decoding: for each of the `PROB_SCALE` slots its symbol (bits 0–7), its
/// frequency (bits 8–19) and the slot's offset from the symbol's start (bits 20–31).
pub struct DecodeTable {
    slots: Vec<u32>,
    alphabet: usize,
}

impl DecodeTable {
    /// An empty table (to be filled by `read`), reused across patches.
    pub fn new() -> DecodeTable {
        DecodeTable {
            slots: vec![0; PROB_SCALE as usize],
            alphabet: 0,
        }
    }

    /// Reads a table written by `Table::write` from `bytes` at `*at`, whose alphabet may have
    /// at most `max_alphabet` (≤ 255) symbols.
    pub fn read(
        &mut self,
        bytes: &[u8],
        at: &mut usize,
        max_alphabet: usize,
    ) -> Result<(), String> {
        let Some(&[first, used]) = bytes.get(*at..*at + 2) else {
            return Err("a table truncated".into());
        };
        let (first, used) = (first as usize, used as usize);
        let alphabet = first + used;
        if used == 0 || alphabet > max_alphabet {
            return Err(format!(
                "a table of symbols {first}..{alphabet} (at most {max_alphabet})"
            ));
        }
        let Some(packed) = bytes.get(*at + 2..*at + 2 + used.div_ceil(2)) else {
            return Err("a table truncated".into());
        };
        *at += 2 + packed.len();
        let mut weights = [0u8; 256];
        for (s, w) in weights[first..alphabet].iter_mut().enumerate() {
            *w = (packed[s / 2] >> (4 * (s % 2))) & 15;
        }
        if used % 2 == 1 && packed[used / 2] >> 4 != 0 {
            return Err("a table with a non-zero half byte after its weights".into());
        }
        if weights[first] == 0 || weights[alphabet - 1] == 0 {
            return Err("a table whose first or last symbol has no weight".into());
        }
        let mut start = 0u32;
        for (symbol, freq) in normalise(&weights[..alphabet]).into_iter().enumerate() {
            for offset in 0..freq {
                self.slots[(start + offset) as usize] = symbol as u32 | freq << 8 | offset << 20;
            }
            start += freq;
        }
        self.alphabet = alphabet;
        Ok(())
    }

    /// The number of symbols.
    pub fn alphabet(&self) -> usize {
        self.alphabet
    }
}

impl Default for DecodeTable {
    fn default() -> Self {
        DecodeTable::new()
    }
}

/// Collects symbols (with their table) in decoding order and codes them backwards.
pub struct Encoder {
    x: u32,
    reversed: Vec<u8>,
}

impl Encoder {
    /// A fresh encoder.
    pub fn new() -> Encoder {
        Encoder {
            x: RANS_L,
            reversed: Vec::new(),
        }
    }

    /// Codes `symbol` of `table`: call in reverse decoding order. Panics on a symbol the
    /// table gives no frequency (a bug: tables come from the same symbols' counts).
    #[inline]
    pub fn put(&mut self, table: &Table, symbol: usize) {
        let freq = table.freq[symbol];
        assert!(freq > 0, "symbol {symbol} has no frequency");
        // 2^32 for a symbol of probability 1: in u64.
        let x_max = (((RANS_L >> PROB_BITS) as u64) << 16) * freq as u64;
        if self.x as u64 >= x_max {
            // Low byte last: reversed, the word reads little-endian.
            self.reversed.push((self.x >> 8) as u8);
            self.reversed.push(self.x as u8);
            self.x >>= 16;
        }
        self.x = ((self.x / freq) << PROB_BITS) + self.x % freq + table.start[symbol];
    }

    /// Appends the coded stream (the final state first, then the renormalisation bytes).
    pub fn finish(mut self, out: &mut Vec<u8>) {
        for shift in [24, 16, 8, 0] {
            self.reversed.push((self.x >> shift) as u8);
        }
        out.extend(self.reversed.iter().rev());
    }
}

impl Default for Encoder {
    fn default() -> Self {
        Encoder::new()
    }
}

/// Decodes a stream `Encoder::finish` wrote.
pub struct Decoder<'a> {
    x: u32,
    stream: &'a [u8],
    at: usize,
    /// Whether a word was read past the stream's end (as zero).
    overrun: bool,
}

impl<'a> Decoder<'a> {
    /// Starts on `stream` (its first 4 bytes the state, which must lie in [L, 2^16 L)).
    pub fn new(stream: &'a [u8]) -> Result<Decoder<'a>, String> {
        let Some(head) = stream.first_chunk::<4>() else {
            return Err(format!("a coded stream of {} bytes", stream.len()));
        };
        let x = u32::from_le_bytes(*head);
        if x < RANS_L {
            return Err(format!("a coded stream starting in state {x:#x}"));
        }
        Ok(Decoder {
            x,
            stream,
            at: 4,
            overrun: false,
        })
    }

    /// The next symbol of `table`. Past the stream's end it reads zeros: `finish` says so.
    #[inline(always)]
    pub fn get(&mut self, table: &DecodeTable) -> u32 {
        let slot = self.x & (PROB_SCALE - 1);
        let entry = table.slots[slot as usize];
        let freq = (entry >> 8) & 0xFFF;
        let x = freq * (self.x >> PROB_BITS) + (entry >> 20);
        // At most one word: x ≥ 1 and 2^16 x ≥ L afterwards.
        let need = x < RANS_L;
        let word = match self.stream.get(self.at..self.at + 2) {
            Some(w) => u16::from_le_bytes([w[0], w[1]]) as u32,
            None => {
                self.overrun |= need;
                0
            }
        };
        self.x = if need { x << 16 | word } else { x };
        self.at += 2 * need as usize;
        entry & 0xFF
    }

    /// After the last symbol: no read past the end, the state back at its start and every
    /// byte used.
    pub fn finish(&self) -> Result<(), String> {
        if self.overrun {
            return Err("the coded stream ends early".into());
        }
        if self.x != RANS_L || self.at != self.stream.len() {
            return Err(format!(
                "the coded stream ends in state {:#x} with {} of its {} bytes used",
                self.x,
                self.at,
                self.stream.len()
            ));
        }
        Ok(())
    }
}

/// Raw bits, least significant first, appended to bytes.
#[derive(Default)]
pub struct BitWriter {
    bytes: Vec<u8>,
    buffer: u64,
    filled: u32,
}

impl BitWriter {
    /// Appends the low `count` (≤ 32) bits of `value`.
    #[inline]
    pub fn put(&mut self, value: u32, count: u32) {
        debug_assert!(count <= 32 && (count == 32 || value >> count == 0));
        self.buffer |= (value as u64) << self.filled;
        self.filled += count;
        while self.filled >= 8 {
            self.bytes.push(self.buffer as u8);
            self.buffer >>= 8;
            self.filled -= 8;
        }
    }

    /// The bytes, the last one zero-padded.
    pub fn finish(mut self) -> Vec<u8> {
        if self.filled > 0 {
            self.bytes.push(self.buffer as u8);
        }
        self.bytes
    }
}

/// Reads what `BitWriter` wrote.
pub struct BitReader<'a> {
    bytes: &'a [u8],
    /// Bits taken so far.
    at: usize,
}

impl<'a> BitReader<'a> {
    /// Starts on `bytes`.
    pub fn new(bytes: &'a [u8]) -> BitReader<'a> {
        BitReader { bytes, at: 0 }
    }

    /// The next `count` (≤ 32) bits. Past the end it reads zeros: `finish` says so.
    #[inline(always)]
    pub fn get(&mut self, count: u32) -> u32 {
        let byte = self.at / 8;
        let word = match self.bytes.get(byte..byte + 8) {
            Some(eight) => u64::from_le_bytes(eight.try_into().expect("8 bytes")),
            None => tail_word(self.bytes, byte),
        };
        // At most 7 bits skipped + 32 taken: within the word.
        let value = (word >> (self.at % 8)) & ((1u64 << count) - 1);
        self.at += count as usize;
        value as u32
    }

    /// After the last read: every byte used (none past the end), the last one's unused bits
    /// zero.
    pub fn finish(&self) -> Result<(), String> {
        let used = self.at.div_ceil(8);
        if used > self.bytes.len() {
            return Err("the raw bits end early".into());
        }
        if used != self.bytes.len() {
            return Err(format!("{} raw bytes, {used} used", self.bytes.len()));
        }
        if !self.at.is_multiple_of(8) && self.bytes[used - 1] >> (self.at % 8) != 0 {
            return Err("non-zero bits after the raw bits".into());
        }
        Ok(())
    }
}

/// The bytes of `bytes` from `byte` on (fewer than 8; none past the end) as a word, zeros
/// after them. Apart and cold: the stream's last bytes only.
#[cold]
#[inline(never)]
fn tail_word(bytes: &[u8], byte: usize) -> u64 {
    let mut eight = [0u8; 8];
    if byte < bytes.len() {
        let tail = &bytes[byte..];
        eight[..tail.len()].copy_from_slice(tail);
    }
    u64::from_le_bytes(eight)
}

#[cfg(test)]
#[path = "rans_tests.rs"]
mod tests;
