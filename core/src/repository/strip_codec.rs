//! The strip of a packed patch, coded in 4-bit symbols that keep every index and restart in
//! order (seed 001: "topology is compressed using a mesh encoding scheme preserving
//! stripification").
//!
//! The builder numbers a patch's vertices in order of first use by its strip
//! (`tessera_preprocess::strips`), so each index is either the next unseen vertex or one seen
//! a few vertices before. With `next` = one past the largest index so far (0 at the start):
//!
//! ```text
//! nibble 0        the new vertex: index = next, next += 1
//! nibble 1        a restart marker
//! nibble 2..=13   back b = nibble − 2 (0..11): index = next − 1 − b
//! nibble 14, n    back b = 12 + n (12..27)
//! nibble 15, v    v a varint of nibbles (3 bits each, low groups first, bit 3 = more):
//!                 v even: back b = 28 + v / 2; v odd: forward, index = next + 1 + (v − 1) / 2
//!                 and next = index + 1 (a strip not in first-use order still codes)
//! ```
//!
//! Nibbles fill each byte low half first; an odd count leaves a zero high half. On the
//! Stanford dragon's patches (first-use order) this takes 5.0 bits an index where meshopt's
//! index-sequence codec takes 8.4 (BENCHMARKS.md). Decoding is a few branches an index,
//! checked: every index below the patch's vertex count, every back reference to a
//! vertex already seen, the stream used exactly (a crafted stream is an error, never a read
//! outside it or an index past the patch).

/// `SYMBOLS` entry bit: a restart marker.
const RESTART_BIT: u32 = 4;

/// For every three nibbles (the first lowest): bits 0–1 how many nibbles the symbol they
/// start takes (0: a varint of three nibbles or more, decoded apart), bit 2 a restart, bits
/// 16–31 the distance d as i16 (index = next − d).
static SYMBOLS: [u32; 4096] = symbols();

const fn symbols() -> [u32; 4096] {
    let mut table = [0u32; 4096];
    let mut w = 0;
    while w < 4096 {
        let (a, b, c) = (w & 15, (w >> 4) & 15, (w >> 8) & 15);
        // (nibbles, distance, restart)
        let (width, distance, restart): (u32, i32, bool) = match a {
            0 => (1, 0, false),
            1 => (1, 0, true),
            2..=13 => (1, a as i32 - 1, false),
            14 => (2, 13 + b as i32, false),
            _ => {
                let (width, v) = if b & 8 == 0 {
                    (2, b & 7)
                } else if c & 8 == 0 {
                    (3, (b & 7) | ((c & 7) << 3))
                } else {
                    (0, 0)
                };
                if v % 2 == 0 {
                    // back 28 + v / 2: index = next − 1 − back
                    (width, 29 + (v / 2) as i32, false)
                } else {
                    // forward: index = next + 1 + (v − 1) / 2
                    (width, -(1 + ((v - 1) / 2) as i32), false)
                }
            }
        };
        let restart_bit = if restart { RESTART_BIT } else { 0 };
        table[w] = width | restart_bit | ((distance as i16 as u16 as u32) << 16);
        w += 1;
    }
    table
}

/// For every three nibbles (the first lowest), the symbols of at most three nibbles in all
/// that they hold (up to three), decoded together relative to `next` before them: bits 0–1
/// how many nibbles they take (0 when the first symbol is a longer varint), bits 2–4 which
/// are restarts, bits 8–15 the smallest offset (0 or below, as i8), bits 16–23 how much
/// `next` grows, bits 24 + 8i.. the ith symbol's offset as i8 (index = next + offset; 0 for
/// a restart or past the last symbol), bits 48–49 how many symbols. The one-nibble symbols
/// (new vertices, restarts, backs 0–11) are most of a strip in first-use order, backs 12–27
/// most of the rest.
static RUNS: [u64; 4096] = runs();

const fn runs() -> [u64; 4096] {
    let mut table = [0u64; 4096];
    let mut w = 0;
    while w < 4096 {
        let (mut taken, mut count) = (0u32, 0u32);
        // `next` relative to its value before the run, and the smallest index so relative.
        let (mut next, mut smallest) = (0i64, 0i64);
        let (mut restarts, mut offsets) = (0u64, 0u64);
        while count < 3 {
            let entry = SYMBOLS[w >> (4 * taken)];
            let width = entry & 3;
            // A longer varint, or a symbol reaching past the three nibbles.
            if width == 0 || taken + width > 3 {
                break;
            }
            if entry & RESTART_BIT != 0 {
                restarts |= 1 << count;
            } else {
                let index = next - (entry as i32 >> 16) as i64;
                if index < smallest {
                    smallest = index;
                }
                if index + 1 > next {
                    next = index + 1;
                }
                offsets |= (index as i8 as u8 as u64) << (24 + 8 * count);
            }
            taken += width;
            count += 1;
        }
        table[w] = taken as u64
            | restarts << 2
            | (smallest as i8 as u8 as u64) << 8
            | (next as u64) << 16
            | offsets
            | (count as u64) << 48;
        w += 1;
    }
    table
}

/// Largest varint (in nibbles) a back or forward distance below 2^32 needs: 33 bits / 3.
const MAX_VARINT_NIBBLES: usize = 11;

/// Appends the coding of `indices` (restart markers equal to `restart`) to `out`; returns the
/// bytes written.
pub fn encode_strip(indices: &[u32], restart: u32, out: &mut Vec<u8>) -> usize {
    let start = out.len();
    let mut nibbles = Nibbles { out, half: false };
    let mut next: u64 = 0;
    for &index in indices {
        if index == restart {
            nibbles.push(1);
            continue;
        }
        let index = index as u64;
        if index == next {
            nibbles.push(0);
            next += 1;
        } else if index < next {
            let back = next - 1 - index;
            if back < 12 {
                nibbles.push(2 + back as u8);
            } else if back < 28 {
                nibbles.push(14);
                nibbles.push((back - 12) as u8);
            } else {
                nibbles.push(15);
                nibbles.varint((back - 28) * 2);
            }
        } else {
            nibbles.push(15);
            nibbles.varint((index - next - 1) * 2 + 1);
            next = index + 1;
        }
    }
    out.len() - start
}

struct Nibbles<'a> {
    out: &'a mut Vec<u8>,
    /// True when the last byte's high half is free.
    half: bool,
}

impl Nibbles<'_> {
    fn push(&mut self, nibble: u8) {
        debug_assert!(nibble < 16);
        if self.half {
            *self.out.last_mut().expect("a half byte") |= nibble << 4;
        } else {
            self.out.push(nibble);
        }
        self.half = !self.half;
    }

    fn varint(&mut self, mut value: u64) {
        while value >= 8 {
            self.push((value & 7) as u8 | 8);
            value >>= 3;
        }
        self.push(value as u8);
    }
}

/// Decodes the strip of a patch of `vertex_count` vertices from `stream` into `target`, the
/// stored indices as little-endian u16 (`width` 2, restart 0xFFFF) or u32 (`width` 4, restart
/// 0xFFFF_FFFF), as many as `target` holds. Fails on any stream that `encode_strip` could not
/// have written for such a patch: truncated, with bytes or a non-zero half byte left over, an
/// index at or past `vertex_count`, a back reference before the first vertex, a varint longer
/// than a u32 distance needs.
pub fn decode_strip(
    stream: &[u8],
    vertex_count: usize,
    width: usize,
    target: &mut [u8],
) -> Result<(), String> {
    match width {
        2 => decode::<2>(stream, vertex_count as u64, target),
        4 => decode::<4>(stream, vertex_count as u64, target),
        _ => Err(format!("strip indices of {width} bytes")),
    }
}

/// `decode_strip` for `W`-byte indices. The next three nibbles pick one `RUNS` entry: the
/// symbols they hold (up to three), checked and written together, so the loop's chain of
/// dependent loads is walked once for several indices. What a run cannot take (a varint of
/// four nibbles or more, the stream's last bytes, the last two slots, a run that fails its
/// check) goes one symbol at a time: its
/// `SYMBOLS` entry, how many nibbles and the distance d, index = next − d (d < 0 for a
/// forward jump), next = max(next, index + 1), or the general path. The reader's 64-bit
/// buffer holds at least three nibbles between refills of 7 bytes.
fn decode<const W: usize>(stream: &[u8], n: u64, target: &mut [u8]) -> Result<(), String> {
    let restart: u64 = if W == 2 {
        u16::MAX as u64
    } else {
        u32::MAX as u64
    };
    // The reader's state in plain locals, so that the loop keeps it in registers (a struct
    // whose address a call takes lives on the stack: one store and load an index).
    let (mut rest, mut buffer, mut available) = (stream, 0u64, 0u32);
    let mut next: u64 = 0;
    let count = target.len() / W;
    let mut k = 0;
    while k < count {
        let mut general = false;
        if available < 3 {
            match rest.first_chunk::<8>() {
                Some(eight) => {
                    let word = u64::from_le_bytes(*eight) & 0x00FF_FFFF_FFFF_FFFF;
                    buffer |= word << (4 * available);
                    available += 14;
                    rest = &rest[7..];
                }
                // The stream's last bytes.
                None => general = true,
            }
        }
        // Up to three symbols at once (three nibbles' worth), where three slots are left:
        // the slots past them are written too and overwritten by what follows. They are
        // checked together (the largest index below n, the smallest at or after the first
        // vertex); ones that fail are decoded one by one for the error.
        if !general && count - k >= 3 {
            let run = RUNS[(buffer & 0xFFF) as usize];
            let taken = (run & 3) as u32;
            let smallest = (run >> 8) as u8 as i8 as i64 as u64;
            let grown = (run >> 16) & 0xFF;
            if taken != 0 && next + grown <= n && next.wrapping_add(smallest) <= n {
                let slots = &mut target[k * W..(k + 3) * W];
                for (i, slot) in slots.chunks_exact_mut(W).enumerate() {
                    let value = if run & (4 << i) != 0 {
                        restart
                    } else {
                        next.wrapping_add((run >> (24 + 8 * i)) as u8 as i8 as i64 as u64)
                    };
                    write::<W>(slot, value);
                }
                next += grown;
                buffer >>= 4 * taken;
                available -= taken;
                k += (run >> 48) as usize & 3;
                continue;
            }
        }
        let entry = SYMBOLS[(buffer & 0xFFF) as usize];
        let width = entry & 3;
        // A long varint (width 0) or the stream's end: the general path, one symbol.
        let value = if general || width == 0 {
            let reader = Reader {
                rest,
                buffer,
                available,
            };
            let (value, after_next, after) = any_symbol(reader, next, n, restart, k)?;
            (next, rest, buffer, available) =
                (after_next, after.rest, after.buffer, after.available);
            value
        } else {
            buffer >>= 4 * width;
            available -= width;
            if entry & RESTART_BIT != 0 {
                restart
            } else {
                let index = next.wrapping_sub((entry as i32 >> 16) as i64 as u64);
                // A back before the first vertex wraps past n.
                if index >= n {
                    return Err(out_of_range(k, index, n));
                }
                next = next.max(index + 1);
                index
            }
        };
        write::<W>(&mut target[k * W..k * W + W], value);
        k += 1;
    }
    let reader = Reader {
        rest,
        buffer,
        available,
    };
    reader.check_end(stream, count)
}

#[inline(always)]
fn write<const W: usize>(slot: &mut [u8], index: u64) {
    slot.copy_from_slice(&index.to_le_bytes()[..W]);
}

/// One symbol decoded the general way, for what the hot loop leaves: refilling from the
/// stream's last bytes, a varint of three nibbles or more, a stream that ends inside a symbol.
/// Returns the value to store, `next` after it and the reader after it. Apart and cold, and
/// the reader passed by value, so that the hot loop keeps its state in registers.
#[cold]
#[inline(never)]
fn any_symbol<'a>(
    mut reader: Reader<'a>,
    next: u64,
    n: u64,
    restart: u64,
    k: usize,
) -> Result<(u64, u64, Reader<'a>), String> {
    reader.ensure_three();
    if reader.available == 0 {
        return Err(truncated(k));
    }
    let entry = SYMBOLS[(reader.buffer & 0xFFF) as usize];
    let width = entry & 3;
    let index = if width != 0 {
        if width > reader.available {
            return Err(truncated(k));
        }
        reader.buffer >>= 4 * width;
        reader.available -= width;
        if entry & RESTART_BIT != 0 {
            return Ok((restart, next, reader));
        }
        next.wrapping_sub((entry as i32 >> 16) as i64 as u64)
    } else {
        reader.buffer >>= 4;
        reader.available -= 1;
        let v = reader
            .varint()
            .ok_or_else(|| format!("strip index {k}: a truncated or over-long varint"))?;
        if v % 2 == 0 {
            next.wrapping_sub(29 + v / 2)
        } else {
            next + 1 + (v - 1) / 2
        }
    };
    if index >= n {
        return Err(out_of_range(k, index, n));
    }
    Ok((index, next.max(index + 1), reader))
}

#[cold]
#[inline(never)]
fn out_of_range(k: usize, index: u64, n: u64) -> String {
    if index > u64::MAX / 2 {
        format!("strip index {k} refers back before the first vertex")
    } else {
        format!("strip index {k} is {index}, past the {n} vertices")
    }
}

#[cold]
fn truncated(k: usize) -> String {
    format!("the strip stream ends before index {k}")
}

/// The last (fewer than 8) bytes of a stream as a word, and how many of them it holds (at
/// most 7). Apart and cold: its variable-length copy would otherwise make the decoding loop
/// save its registers around a call.
#[cold]
#[inline(never)]
fn tail_word(rest: &[u8]) -> (u64, usize) {
    let take = rest.len().min(7);
    let mut bytes = [0u8; 8];
    bytes[..take].copy_from_slice(&rest[..take]);
    (u64::from_le_bytes(bytes), take)
}

#[derive(Clone, Copy)]
struct Reader<'a> {
    /// The bytes not yet moved into `buffer`.
    rest: &'a [u8],
    /// The next nibbles, lowest first.
    buffer: u64,
    /// Nibbles left in `buffer`.
    available: u32,
}

impl Reader<'_> {
    /// At least three nibbles in `buffer` unless the stream has fewer left.
    #[inline(always)]
    fn ensure_three(&mut self) {
        if self.available < 3 {
            self.refill();
        }
    }

    /// Appends up to 7 bytes to the (at most two) nibbles left: 64 bits at most. One
    /// unaligned 8-byte load while 8 bytes remain; a copy only at the stream's end.
    #[inline(always)]
    fn refill(&mut self) {
        let (word, take) = match self.rest.first_chunk::<8>() {
            Some(eight) => (u64::from_le_bytes(*eight) & 0x00FF_FFFF_FFFF_FFFF, 7),
            None => tail_word(self.rest),
        };
        self.buffer |= word << (4 * self.available);
        self.available += 2 * take as u32;
        self.rest = &self.rest[take..];
    }

    #[inline(always)]
    fn next(&mut self) -> Option<u8> {
        if self.available == 0 {
            self.refill();
            if self.available == 0 {
                return None;
            }
        }
        let nibble = (self.buffer & 15) as u8;
        self.buffer >>= 4;
        self.available -= 1;
        Some(nibble)
    }

    /// After the last of `count` indices: the stream used exactly (bytes left over, or a
    /// non-zero half byte after an odd count of nibbles, are errors).
    fn check_end(&self, stream: &[u8], count: usize) -> Result<(), String> {
        let consumed = self.consumed(stream);
        let used = consumed.div_ceil(2);
        if used != stream.len() {
            return Err(format!(
                "{} bytes after the strip's {count} indices",
                stream.len() - used
            ));
        }
        if consumed % 2 == 1 && stream[used - 1] >> 4 != 0 {
            return Err("a non-zero half byte after the strip".into());
        }
        Ok(())
    }

    /// Nibbles taken so far from `stream` (which this reader started on).
    fn consumed(&self, stream: &[u8]) -> usize {
        2 * (stream.len() - self.rest.len()) - self.available as usize
    }

    fn varint(&mut self) -> Option<u64> {
        let mut value = 0u64;
        for shift in 0..MAX_VARINT_NIBBLES {
            let nibble = self.next()?;
            value |= ((nibble & 7) as u64) << (3 * shift);
            if nibble & 8 == 0 {
                return Some(value);
            }
        }
        None
    }
}

#[cfg(test)]
#[path = "strip_codec_tests.rs"]
mod tests;
