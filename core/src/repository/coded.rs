//! Coded patches (`SECTION_CODED_STRIPS`, issue 49): the strip, the positions predicted along
//! it and every attribute entropy-coded with rANS (`rans.rs`), decoded on the loader's thread
//! into exactly the bytes `patch::encode_patch` writes. Lossless, like `packed.rs`: a coded
//! repository draws the pixels of a raw one and its stored errors need no margin.
//!
//! A coded patch of n = `vertex_count` vertices and m = `strip_index_count` strip indices:
//!
//! ```text
//! tables          rans::Table × (strip if m > 0; positions, then normals / colours / uvs as
//!                 the attribute mask has them, if n > 0)
//! varint × 2      the rANS stream's bytes, the raw bits' bytes
//! rANS stream     the strip's m symbols, then per vertex its 3 position residuals, then
//!                 per vertex each attribute's lanes (normals 2, colours 4, uvs 2)
//! raw bits        the low bits of large residuals and long strip distances, in that order
//! zero padding    to a multiple of 8, and more where needed so that the decoded patch is at
//!                 most `MAX_PACKING_RATIO` × the stored one + 256 (the directory's bound)
//! ```
//!
//! Strip symbols (with `next` one past the largest index so far, as in `strip_codec.rs`):
//! 0 the new vertex `next`, 1 a restart, 2 + b (b < 28) the vertex `next − 1 − b`, 30 a longer
//! back and 31 a forward jump, both with their distance in the raw bits (6 bits of length,
//! then the value).
//!
//! Positions (and attributes) follow vertex order. Vertex v's prediction comes from where the
//! strip first uses it, slot k: when s[k−1], s[k−2], s[k−3] are three distinct vertices
//! before v (no restart among them), the parallelogram s[k−1] + s[k−2] − s[k−3] across the
//! strip's previous triangle; else vertex s[k−1] if it is before v; else vertex v − 1; else 0.
//! Attributes use the same reference vertex (s[k−1] for a parallelogram). A residual r
//! (wrapping, per lane) is zig-zagged to z and coded as a bucket symbol: z < 16 itself, else
//! with L the bit length of z, 16 + 2(L − 5) + the bit below the top, and the L − 2 bits below
//! those raw.
//!
//! Decoding trusts nothing: tables are checked as they are read, every strip index is below
//! n or a restart, every back reference reaches a vertex already seen, every coordinate is
//! ≤ `POSITION_MAX`, both streams are used exactly and the padding is exactly what the encoder
//! writes; any stream is decoded or refused in time linear in its size and the patch's counts.

use super::directory_check::MAX_PACKING_RATIO;
use super::format::{
    align8, unpack_position, ATTR_ALL, ATTR_COLORS, ATTR_NORMALS, ATTR_UVS, POSITION_BITS,
    POSITION_MAX,
};
use super::packed::UnpackError;
use super::patch::{patch_bytes_checked, MAX_U16_PATCH_VERTICES};
use super::rans::{
    read_varint, write_varint, BitReader, BitWriter, DecodeTable, Decoder, Encoder, Table,
};

mod decode;
pub use decode::decode_patch;

/// Strip symbols: the new vertex, a restart, backs 0..`SHORT_BACKS`, a longer back, a jump.
const NEW: u32 = 0;
const RESTART: u32 = 1;
const BACK: u32 = 2;
const SHORT_BACKS: u32 = 28;
const LONG_BACK: u32 = BACK + SHORT_BACKS;
const FORWARD: u32 = LONG_BACK + 1;
const STRIP_ALPHABET: usize = FORWARD as usize + 1;
/// Residual buckets: 16 small values, then 2 per bit length 5..=32.
const RESIDUAL_ALPHABET: usize = 16 + 2 * 28;
/// A strip restart in the decoded-to-u32 strip.
const NONE: u32 = u32::MAX;

/// The tables of a patch, in stored order: strip, positions, then the attributes present.
const STRIP_TABLE: usize = 0;
const POSITION_TABLE: usize = 1;

/// The attribute lanes of a patch: (mask bit, lanes a vertex, bytes a lane).
const ATTRIBUTES: [(u32, usize, usize); 3] =
    [(ATTR_NORMALS, 2, 2), (ATTR_COLORS, 4, 1), (ATTR_UVS, 2, 4)];

#[inline(always)]
fn zigzag(r: i32) -> u32 {
    ((r << 1) ^ (r >> 31)) as u32
}

#[inline(always)]
fn unzigzag(z: u32) -> i32 {
    (z >> 1) as i32 ^ -((z & 1) as i32)
}

/// The bucket symbol of `z`, the raw bits below it and their count.
#[inline(always)]
fn bucket(z: u32) -> (usize, u32, u32) {
    if z < 16 {
        return (z as usize, 0, 0);
    }
    let length = 32 - z.leading_zeros();
    let symbol = 16 + 2 * (length - 5) + ((z >> (length - 2)) & 1);
    (symbol as usize, z & ((1 << (length - 2)) - 1), length - 2)
}

/// The value of bucket `symbol` (< `RESIDUAL_ALPHABET`), its raw bits read from `bits`.
#[inline(always)]
fn unbucket(symbol: u32, bits: &mut BitReader) -> u32 {
    if symbol < 16 {
        return symbol;
    }
    let t = symbol - 16;
    let below = 3 + t / 2;
    (2 | (t & 1)) << below | bits.get(below)
}

/// How vertex v is predicted: a parallelogram a + b − c, one vertex, or zero.
#[derive(Clone, Copy)]
enum Prediction {
    Parallelogram(u32, u32, u32),
    Vertex(u32),
    Zero,
}

impl Prediction {
    /// The reference vertex for attributes.
    fn reference(self) -> Option<u32> {
        match self {
            Prediction::Parallelogram(a, _, _) | Prediction::Vertex(a) => Some(a),
            Prediction::Zero => None,
        }
    }
}

/// Vertex `v`'s prediction, given the strip (restarts `NONE`) and the slot where it is first
/// used (`NONE` if never).
#[inline(always)]
fn predict(strip: &[u32], first: u32, v: u32) -> Prediction {
    if first != NONE {
        let k = first as usize;
        if k >= 3 {
            let (a, b, c) = (strip[k - 1], strip[k - 2], strip[k - 3]);
            // Restarts are NONE, never below v.
            if a < v && b < v && c < v && a != b && b != c && a != c {
                return Prediction::Parallelogram(a, b, c);
            }
        }
        if k >= 1 && strip[k - 1] < v {
            return Prediction::Vertex(strip[k - 1]);
        }
    }
    match v {
        0 => Prediction::Zero,
        v => Prediction::Vertex(v - 1),
    }
}

#[inline(always)]
fn predicted(positions: &[[u32; 3]], p: Prediction) -> [i32; 3] {
    let at = |i: u32| positions[i as usize].map(|c| c as i32);
    match p {
        Prediction::Parallelogram(a, b, c) => {
            let (a, b, c) = (at(a), at(b), at(c));
            [0, 1, 2].map(|i| a[i] + b[i] - c[i])
        }
        Prediction::Vertex(a) => at(a),
        Prediction::Zero => [0; 3],
    }
}

/// A lane's value (zero-extended) and its width in bits.
#[inline(always)]
fn lane(bytes: &[u8], width: usize) -> u32 {
    let mut word = [0u8; 4];
    word[..width].copy_from_slice(bytes);
    u32::from_le_bytes(word)
}

/// The residual of lane value `value` against `reference`, wrapping in the lane's width.
#[inline(always)]
fn lane_residual(value: u32, reference: u32, width: usize) -> u32 {
    let shift = 32 - 8 * width as u32;
    // The difference in the lane's width, sign-extended from its top bit.
    zigzag((value.wrapping_sub(reference) << shift) as i32 >> shift)
}

/// The lane value of residual `z` against `reference`.
#[inline(always)]
fn lane_value(z: u32, reference: u32, width: usize) -> u32 {
    let mask = if width == 4 {
        u32::MAX
    } else {
        (1 << (8 * width)) - 1
    };
    (unzigzag(z) as u32).wrapping_add(reference) & mask
}

/// Appends the coded form of `raw` (one patch as `encode_patch` wrote it) to `out` (length a
/// multiple of 8); returns its size (a multiple of 8, 0 for an empty patch). Panics if `raw`
/// is not such a patch (the build made it: a bug, not an input).
pub fn code_patch(
    raw: &[u8],
    vertex_count: usize,
    strip_index_count: usize,
    attributes: u32,
    out: &mut Vec<u8>,
) -> usize {
    code_patch_parts(raw, vertex_count, strip_index_count, attributes, out).0
}

/// Where a coded patch's bytes go (fractional: a rANS symbol costs log2 of its probability),
/// for the figures: tables and lengths, strip (symbols and their raw bits), positions,
/// attributes, padding (with the final state's 4 bytes).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CodedParts {
    pub header: f64,
    pub strip: f64,
    pub positions: f64,
    pub attributes: f64,
    pub padding: f64,
}

/// `code_patch`, and where its bytes go.
pub fn code_patch_parts(
    raw: &[u8],
    vertex_count: usize,
    strip_index_count: usize,
    attributes: u32,
    out: &mut Vec<u8>,
) -> (usize, CodedParts) {
    assert!(
        attributes & !ATTR_ALL == 0,
        "attribute bits {attributes:#x}"
    );
    assert!(
        out.len().is_multiple_of(8),
        "coded patch would start unaligned"
    );
    let (n, m) = (vertex_count, strip_index_count);
    let decoded = patch_bytes_checked(n as u64, m as u64, attributes);
    assert_eq!(Some(raw.len() as u64), decoded, "raw patch size");
    if n == 0 && m == 0 {
        return (0, CodedParts::default());
    }
    let wide = n > MAX_U16_PATCH_VERTICES;
    let positions: Vec<[u32; 3]> = raw[..8 * n]
        .chunks_exact(8)
        .map(|w| unpack_position([lane(&w[..4], 4), lane(&w[4..], 4)]))
        .collect();
    let mut at = 8 * n;
    let mut lanes: Vec<(&[u8], usize, usize)> = Vec::new();
    for (bit, count, width) in ATTRIBUTES {
        if attributes & bit != 0 {
            lanes.push((&raw[at..at + n * count * width], count, width));
            at += n * count * width;
        }
    }
    let strip: Vec<u32> = if wide {
        raw[at..at + 4 * m]
            .chunks_exact(4)
            .map(|c| lane(c, 4))
            .collect()
    } else {
        raw[at..at + 2 * m]
            .chunks_exact(2)
            .map(|c| match lane(c, 2) {
                0xFFFF => NONE,
                i => i,
            })
            .collect()
    };
    // Symbols (table, symbol) in decoding order; raw bits in the same order.
    let mut symbols: Vec<(u8, u8)> = Vec::with_capacity(m + 3 * n);
    let mut bits = BitWriter::default();
    // Raw bits of the strip, the positions and the attributes.
    let mut raw_bits = [0u64; 3];
    let mut first = vec![NONE; n];
    let mut next: u64 = 0;
    for (k, &index) in strip.iter().enumerate() {
        let symbol = if index == NONE {
            RESTART
        } else {
            let i = index as u64;
            if first[index as usize] == NONE {
                first[index as usize] = k as u32;
            }
            if i == next {
                next += 1;
                NEW
            } else if i < next {
                let back = next - 1 - i;
                if back < SHORT_BACKS as u64 {
                    BACK + back as u32
                } else {
                    raw_bits[0] += put_long(&mut bits, back - SHORT_BACKS as u64);
                    LONG_BACK
                }
            } else {
                raw_bits[0] += put_long(&mut bits, i - next - 1);
                next = i + 1;
                FORWARD
            }
        };
        symbols.push((STRIP_TABLE as u8, symbol as u8));
    }
    let predictions: Vec<Prediction> = (0..n as u32)
        .map(|v| predict(&strip, first[v as usize], v))
        .collect();
    for (v, &p) in predictions.iter().enumerate() {
        let guess = predicted(&positions, p);
        for axis in 0..3 {
            let (symbol, low, count) = bucket(zigzag(positions[v][axis] as i32 - guess[axis]));
            symbols.push((POSITION_TABLE as u8, symbol as u8));
            bits.put(low, count);
            raw_bits[1] += count as u64;
        }
    }
    for (t, &(bytes, count, width)) in lanes.iter().enumerate() {
        let value = |v: usize, l: usize| {
            let at = (v * count + l) * width;
            lane(&bytes[at..at + width], width)
        };
        for (v, p) in predictions.iter().enumerate() {
            for l in 0..count {
                let reference = p.reference().map_or(0, |r| value(r as usize, l));
                let z = lane_residual(value(v, l), reference, width);
                let (symbol, low, bit_count) = bucket(z);
                symbols.push(((POSITION_TABLE + 1 + t) as u8, symbol as u8));
                bits.put(low, bit_count);
                raw_bits[2] += bit_count as u64;
            }
        }
    }
    // The tables of the symbols used (a table for each stream with symbols).
    let table_count = POSITION_TABLE + 1 + lanes.len();
    let mut counts = vec![vec![0u64; RESIDUAL_ALPHABET.max(STRIP_ALPHABET)]; table_count];
    for &(t, s) in &symbols {
        counts[t as usize][s as usize] += 1;
    }
    let tables: Vec<Option<Table>> = counts
        .iter()
        .map(|c| c.iter().any(|&k| k > 0).then(|| Table::from_counts(c)))
        .collect();
    let start = out.len();
    for table in tables.iter().flatten() {
        table.write(out);
    }
    let mut encoder = Encoder::new();
    for &(t, s) in symbols.iter().rev() {
        encoder.put(tables[t as usize].as_ref().expect("counted"), s as usize);
    }
    let mut stream = Vec::new();
    encoder.finish(&mut stream);
    let bits = bits.finish();
    write_varint(stream.len() as u64, out);
    write_varint(bits.len() as u64, out);
    out.extend_from_slice(&stream);
    out.extend_from_slice(&bits);
    let used = out.len() - start;
    let size = stored_size(used as u64, raw.len() as u64);
    out.resize(start + size as usize, 0);
    let mut parts = CodedParts::default();
    for &(t, s) in &symbols {
        let bits = tables[t as usize]
            .as_ref()
            .expect("counted")
            .cost_bits(s as usize)
            / 8.0;
        match t as usize {
            STRIP_TABLE => parts.strip += bits,
            POSITION_TABLE => parts.positions += bits,
            _ => parts.attributes += bits,
        }
    }
    parts.strip += raw_bits[0] as f64 / 8.0;
    parts.positions += raw_bits[1] as f64 / 8.0;
    parts.attributes += raw_bits[2] as f64 / 8.0;
    parts.header = (used - stream.len() - bits.len()) as f64;
    parts.padding = size as f64 - parts.header - parts.strip - parts.positions - parts.attributes;
    (out.len() - start, parts)
}

/// The raw-bit form of a long strip distance: its bit length in 6 bits, then its bits.
fn put_long(bits: &mut BitWriter, value: u64) -> u64 {
    let length = 64 - value.leading_zeros();
    assert!(length <= 32, "a strip distance of {value}");
    bits.put(length, 6);
    bits.put(value as u32, length);
    6 + length as u64
}

/// The stored size of a coded patch whose streams take `used` bytes and which decodes to
/// `decoded` bytes: `used` padded to 8, or more so the directory's ratio bound holds.
fn stored_size(used: u64, decoded: u64) -> u64 {
    let least = decoded.saturating_sub(256).div_ceil(MAX_PACKING_RATIO);
    align8(used.max(least)).expect("small")
}

#[cfg(test)]
#[path = "coded_tests.rs"]
mod tests;
