//! Decoding a coded patch (the layout and the checks: `coded.rs`), on the loader's thread,
//! with scratch kept per thread.

use super::*;

/// Scratch of the decoder, per thread, grown and never shrunk.
#[derive(Default)]
struct Scratch {
    tables: Vec<DecodeTable>,
    strip: Vec<u32>,
    first: Vec<u32>,
    positions: Vec<[u32; 3]>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// Decodes a coded patch into `out`, which must be exactly the decoded size
/// (`patch_bytes(vertex_count, strip_index_count, attributes)`): afterwards `out` holds the
/// bytes `encode_patch` wrote for it. Never panics; its scratch (4 KiB a table, 20 bytes a
/// vertex, 4 a strip index) is kept per thread.
pub fn decode_patch(
    coded: &[u8],
    vertex_count: usize,
    strip_index_count: usize,
    attributes: u32,
    out: &mut [u8],
) -> Result<(), UnpackError> {
    if attributes & !ATTR_ALL != 0 {
        return Err(UnpackError(format!(
            "unknown attribute bits {attributes:#x}"
        )));
    }
    let decoded = patch_bytes_checked(vertex_count as u64, strip_index_count as u64, attributes);
    if decoded != Some(out.len() as u64) {
        return Err(UnpackError(format!(
            "{} bytes to decode into, {vertex_count} vertices and {strip_index_count} strip \
             indices take {decoded:?}",
            out.len()
        )));
    }
    if vertex_count == 0 && strip_index_count == 0 {
        out.fill(0);
        return match coded.len() {
            0 => Ok(()),
            len => Err(UnpackError(format!(
                "an empty patch coded in {len} bytes, not 0"
            ))),
        };
    }
    SCRATCH.with_borrow_mut(|scratch| {
        decode_into(
            coded,
            vertex_count,
            strip_index_count,
            attributes,
            out,
            scratch,
        )
        .map_err(|e| UnpackError(format!("coded: {e}")))
    })
}

fn decode_into(
    coded: &[u8],
    n: usize,
    m: usize,
    attributes: u32,
    out: &mut [u8],
    scratch: &mut Scratch,
) -> Result<(), String> {
    let lanes: Vec<(usize, usize)> = ATTRIBUTES
        .iter()
        .filter(|a| attributes & a.0 != 0)
        .map(|&(_, count, width)| (count, width))
        .collect();
    let table_count = POSITION_TABLE + 1 + lanes.len();
    while scratch.tables.len() < table_count {
        scratch.tables.push(DecodeTable::new());
    }
    let mut at = 0;
    if m > 0 {
        scratch.tables[STRIP_TABLE].read(coded, &mut at, STRIP_ALPHABET)?;
    }
    if n > 0 {
        for t in POSITION_TABLE..table_count {
            scratch.tables[t].read(coded, &mut at, RESIDUAL_ALPHABET)?;
        }
    }
    let stream_bytes = read_varint(coded, &mut at, 5)?;
    let bit_bytes = read_varint(coded, &mut at, 5)?;
    let stream_end = at as u64 + stream_bytes;
    let bits_end = stream_end + bit_bytes;
    if bits_end > coded.len() as u64 {
        return Err(format!(
            "streams of {stream_bytes} and {bit_bytes} bytes at {at} past the patch's {} bytes",
            coded.len()
        ));
    }
    let expected = stored_size(bits_end, out.len() as u64);
    if coded.len() as u64 != expected || coded[bits_end as usize..].iter().any(|&b| b != 0) {
        return Err(format!(
            "{} bytes stored where the streams end at {bits_end} (padded: {expected}), or \
             non-zero padding",
            coded.len()
        ));
    }
    let mut decoder = Decoder::new(&coded[at..stream_end as usize])?;
    let mut bits = BitReader::new(&coded[stream_end as usize..bits_end as usize]);
    let Scratch {
        tables,
        strip,
        first,
        positions,
    } = scratch;
    strip.clear();
    first.clear();
    first.resize(n, NONE);
    decode_strip(
        &mut decoder,
        &tables[STRIP_TABLE],
        &mut bits,
        m,
        n,
        strip,
        first,
    )?;
    // Positions.
    positions.clear();
    positions.reserve(n);
    let table = &tables[POSITION_TABLE];
    let mut above = 0u32;
    for v in 0..n as u32 {
        let guess = predicted(positions, predict(strip, first[v as usize], v));
        let mut q = [0u32; 3];
        for (axis, c) in q.iter_mut().enumerate() {
            let z = unbucket(decoder.get(table), &mut bits);
            *c = guess[axis].wrapping_add(unzigzag(z)) as u32;
            above |= *c;
        }
        if above > POSITION_MAX {
            return Err(format!(
                "vertex {v} at {q:?} is off the {POSITION_MAX} grid"
            ));
        }
        positions.push(q);
    }
    for (q, to) in positions.iter().zip(out.chunks_exact_mut(8)) {
        let packed =
            q[0] as u64 | (q[1] as u64) << POSITION_BITS | (q[2] as u64) << (2 * POSITION_BITS);
        to.copy_from_slice(&packed.to_le_bytes());
    }
    let mut to = 8 * n;
    for (t, &(count, width)) in lanes.iter().enumerate() {
        let table = &tables[POSITION_TABLE + 1 + t];
        let target = &mut out[to..to + n * count * width];
        let lanes = Lanes {
            strip,
            first,
            decoder: &mut decoder,
            table,
            bits: &mut bits,
        };
        match (count, width) {
            (2, 2) => lanes.decode::<2, 2>(target),
            (4, 1) => lanes.decode::<4, 1>(target),
            _ => lanes.decode::<2, 4>(target),
        }
        to += n * count * width;
    }
    let target = &mut out[to..];
    if n > MAX_U16_PATCH_VERTICES {
        for (i, slot) in strip.iter().zip(target.chunks_exact_mut(4)) {
            slot.copy_from_slice(&i.to_le_bytes());
        }
        target[4 * m..].fill(0);
    } else {
        for (&i, slot) in strip.iter().zip(target.chunks_exact_mut(2)) {
            slot.copy_from_slice(&(i as u16).to_le_bytes());
        }
        target[2 * m..].fill(0);
    }
    decoder.finish()?;
    bits.finish()
}

/// What an attribute's lanes decode from.
struct Lanes<'s, 'd, 'a> {
    strip: &'s [u32],
    first: &'s [u32],
    decoder: &'d mut Decoder<'a>,
    table: &'s DecodeTable,
    bits: &'d mut BitReader<'a>,
}

impl Lanes<'_, '_, '_> {
    /// Decodes C lanes of W bytes a vertex into `target` (n × C × W bytes), each against the
    /// same lane of the vertex's reference (written before it).
    fn decode<const C: usize, const W: usize>(self, target: &mut [u8]) {
        let n = target.len() / (C * W);
        for v in 0..n {
            let reference = predict(self.strip, self.first[v], v as u32).reference();
            for l in 0..C {
                let base = reference.map_or(0, |r| {
                    let at = (r as usize * C + l) * W;
                    let mut word = [0u8; 4];
                    word[..W].copy_from_slice(&target[at..at + W]);
                    u32::from_le_bytes(word)
                });
                let z = unbucket(self.decoder.get(self.table), self.bits);
                let value = lane_value(z, base, W);
                let at = (v * C + l) * W;
                target[at..at + W].copy_from_slice(&value.to_le_bytes()[..W]);
            }
        }
    }
}

/// Decodes the m strip symbols into `strip` (restarts `NONE`), recording each vertex's first
/// slot in `first`.
fn decode_strip(
    decoder: &mut Decoder,
    table: &DecodeTable,
    bits: &mut BitReader,
    m: usize,
    n: usize,
    strip: &mut Vec<u32>,
    first: &mut [u32],
) -> Result<(), String> {
    let n = n as u64;
    let mut next = 0u64;
    strip.reserve(m);
    for k in 0..m {
        let symbol = decoder.get(table);
        let index = match symbol {
            RESTART => {
                strip.push(NONE);
                continue;
            }
            NEW => next,
            LONG_BACK => {
                let back = SHORT_BACKS as u64 + get_long(bits)?;
                if back >= next {
                    return Err(format!(
                        "strip index {k} refers back before the first vertex"
                    ));
                }
                next - 1 - back
            }
            FORWARD => next + 1 + get_long(bits)?,
            s => {
                let back = (s - BACK) as u64;
                if back >= next {
                    return Err(format!(
                        "strip index {k} refers back before the first vertex"
                    ));
                }
                next - 1 - back
            }
        };
        if index >= n {
            return Err(format!("strip index {k} is {index}, past the {n} vertices"));
        }
        next = next.max(index + 1);
        if first[index as usize] == NONE {
            first[index as usize] = k as u32;
        }
        strip.push(index as u32);
    }
    Ok(())
}

fn get_long(bits: &mut BitReader) -> Result<u64, String> {
    let length = bits.get(6);
    if length > 32 {
        return Err(format!("a strip distance of {length} bits"));
    }
    Ok(bits.get(length) as u64)
}
