//! The strip coding's tests: round trips, the cost of first-use order, crafted streams,
//! and the hot loop's runs against the general path one symbol at a time.

use super::*;

const R: u32 = u32::MAX;

/// Codes `indices` (u32 restarts) and decodes them as u32 and, where they fit, as u16.
fn round_trip(indices: &[u32], vertex_count: usize) -> Vec<u8> {
    let mut stream = Vec::new();
    let written = encode_strip(indices, R, &mut stream);
    assert_eq!(written, stream.len());
    let mut wide = vec![0u8; 4 * indices.len()];
    decode_strip(&stream, vertex_count, 4, &mut wide)
        .unwrap_or_else(|e| panic!("{indices:?}: {e}"));
    let expected: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    assert_eq!(wide, expected);
    if vertex_count < u16::MAX as usize {
        let narrow: Vec<u32> = indices
            .iter()
            .map(|&i| if i == R { u16::MAX as u32 } else { i })
            .collect();
        let mut stream16 = Vec::new();
        encode_strip(&narrow, u16::MAX as u32, &mut stream16);
        assert_eq!(stream16, stream, "the coding does not depend on the width");
        let mut short = vec![0u8; 2 * indices.len()];
        decode_strip(&stream, vertex_count, 2, &mut short).unwrap();
        let expected: Vec<u8> = narrow
            .iter()
            .flat_map(|&i| (i as u16).to_le_bytes())
            .collect();
        assert_eq!(short, expected);
    }
    stream
}

#[test]
fn every_symbol_round_trips() {
    // New vertices, short and long backs, restarts, far backs through the varint.
    let mut strip: Vec<u32> = (0..40).collect();
    strip.extend([39, 38, 27, 28, 12, 11, 0, R, R, 5, 39, 1]);
    round_trip(&strip, 40);
    // Forward jumps: a strip not in first-use order.
    round_trip(&[5, 2, 7, R, 0, 1, 9, 8, 3], 10);
    // Large distances (u32 patches).
    let far = [0, 1, 2, 3_000_000, 3_000_001, 1, 0, 2_999_999];
    round_trip(&far, 3_000_002);
    round_trip(&[], 0);
    round_trip(&[R, R], 0);
}

#[test]
fn first_use_order_costs_a_nibble_for_new_vertices_and_short_backs() {
    // A strip of 2 rows: 0 1 2 3 … 9, then backs of 1 (a zigzag along a row).
    let strip: Vec<u32> = (0..10).chain([8, 9, 7]).collect();
    let stream = round_trip(&strip, 10);
    assert_eq!(stream.len(), 13usize.div_ceil(2));
}

/// The decoding one symbol at a time through the general path alone, with the hot
/// loop's checks of what is left: what `decode` must agree with.
fn decode_symbol_by_symbol(stream: &[u8], n: u64, count: usize) -> Result<Vec<u32>, String> {
    let mut reader = Reader {
        rest: stream,
        buffer: 0,
        available: 0,
    };
    let (mut next, mut out) = (0, Vec::new());
    for k in 0..count {
        let (value, after_next, after) = any_symbol(reader, next, n, u32::MAX as u64, k)?;
        (next, reader) = (after_next, after);
        out.push(value as u32);
    }
    reader.check_end(stream, count)?;
    Ok(out)
}

/// `decode` agrees with `decode_symbol_by_symbol` on `stream`, in both widths (values or error).
fn decodes_as_symbol_by_symbol(stream: &[u8], n: u64, count: usize, what: &str) {
    let expected = decode_symbol_by_symbol(stream, n, count);
    assert_eq!(
        decode_as_u32::<4>(stream, n, count),
        expected,
        "{what}, {count} indices"
    );
    assert_eq!(
        decode_as_u32::<2>(stream, n, count),
        expected,
        "u16: {what}, {count} indices"
    );
}

/// `decode` of `count` indices as u32 (`W` 4) or u16 (`W` 2), read back as u32 with the
/// restart marker as `R`.
fn decode_as_u32<const W: usize>(stream: &[u8], n: u64, count: usize) -> Result<Vec<u32>, String> {
    let mut target = vec![0u8; W * count];
    decode::<W>(stream, n, &mut target)?;
    Ok(target
        .chunks_exact(W)
        .map(|c| match W {
            2 => match u16::from_le_bytes([c[0], c[1]]) {
                u16::MAX => R,
                i => i as u32,
            },
            _ => u32::from_le_bytes(c.try_into().unwrap()),
        })
        .collect())
}

#[test]
fn runs_decode_as_single_symbols_do() {
    // A small deterministic generator (no dependency): xorshift.
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut random = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for case in 0..4000 {
        let len = (random() % 64) as usize;
        // Mostly one-nibble symbols (as strips in first-use order are), some longer ones,
        // and on odd cases any bytes at all.
        let stream: Vec<u8> = (0..len)
            .map(|_| {
                let r = random();
                if case % 2 == 1 || r % 8 == 0 {
                    (r >> 8) as u8
                } else {
                    ((r >> 8) % 14) as u8 | (((r >> 16) % 14) as u8) << 4
                }
            })
            .collect();
        let n = random() % 80;
        let count = (random() % (2 * len as u64 + 4)) as usize;
        decodes_as_symbol_by_symbol(&stream, n, count, &format!("{stream:x?}, {n} vertices"));
    }
}

#[test]
fn crafted_streams_fail_cleanly() {
    let stream = round_trip(&[0, 1, 2, 1, 0], 3);
    let decode = |s: &[u8], count: usize, n: usize| decode_strip(s, n, 4, &mut vec![0; 4 * count]);
    assert!(decode(&stream, 5, 3).is_ok());
    // Truncated: fewer indices in the stream than asked for (an even count of nibbles,
    // so no padding half byte reads as a new vertex; with one, that index is past the
    // vertices).
    let even = round_trip(&[0, 1, 2, 1], 3);
    assert!(decode(&even, 5, 3).unwrap_err().contains("ends before"));
    assert!(decode(&stream, 6, 3).unwrap_err().contains("past the 3"));
    // Bytes left over.
    let mut long = stream.clone();
    long.push(0);
    assert!(decode(&long, 5, 3).unwrap_err().contains("after the strip"));
    // Too few vertices for the indices.
    assert!(decode(&stream, 5, 2)
        .unwrap_err()
        .contains("past the 2 vertices"));
    // A back reference before the first vertex: nibble 2 (back 0) first.
    assert!(decode(&[0x02], 1, 3)
        .unwrap_err()
        .contains("before the first"));
    // A non-zero half byte after an odd count.
    assert!(decode(&[0x10], 1, 3).unwrap_err().contains("half byte"));
    // An endless varint.
    assert!(decode(&[0xFF; 16], 1, 3).unwrap_err().contains("varint"));
    // Any byte string decodes or fails, never panics.
    for a in 0..=255u8 {
        for b in [0u8, 0x0F, 0xF0, 0x8F, 0xFF] {
            for count in 0..4 {
                let _ = decode(&[a, b], count, 4);
            }
        }
    }
}

/// Strips `encode_strip` writes (new vertices, short and far backs, restarts, forward jumps),
/// whole and with one bit flipped: the hot loop's runs give what the general path gives, one
/// symbol at a time, and the whole ones give back their indices.
#[test]
fn valid_strips_decode_as_single_symbols_do() {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut random = move |below: u64| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state % below.max(1)
    };
    let mut runs = 0;
    for _ in 0..3000 {
        let n = 1 + random(300);
        let len = random(400) as usize;
        let mut next = 0u64;
        let mut indices = Vec::with_capacity(len);
        for _ in 0..len {
            let kind = random(100);
            let index = if kind < 5 {
                R as u64
            } else if (kind < 55 || next == 0) && next < n {
                next
            } else if kind < 58 && next + 1 < n {
                next + 1 + random(n - next - 1)
            } else if next > 0 {
                // Mostly short backs (one nibble), some of two nibbles and some far.
                let reach = [12, 28, 200][random(3) as usize].min(next);
                next - 1 - random(reach)
            } else {
                R as u64
            };
            if index != R as u64 {
                next = next.max(index + 1);
            }
            indices.push(index as u32);
        }
        let mut stream = Vec::new();
        encode_strip(&indices, R, &mut stream);
        let count = indices.len();
        assert_eq!(decode_as_u32::<4>(&stream, n, count), Ok(indices.clone()));
        assert_eq!(decode_as_u32::<2>(&stream, n, count), Ok(indices.clone()));
        assert_eq!(
            decode_symbol_by_symbol(&stream, n, count),
            Ok(indices.clone())
        );
        runs += (count >= 3) as usize;
        if stream.is_empty() {
            continue;
        }
        let bit = random(8 * stream.len() as u64);
        stream[(bit / 8) as usize] ^= 1 << (bit % 8);
        decodes_as_symbol_by_symbol(
            &stream,
            n,
            count,
            &format!("{indices:?}, bit {bit} flipped"),
        );
    }
    assert!(runs > 2000, "{runs} strips long enough for runs");
}
