//! Tests of the rANS coder: round trips, tables, and streams cut or damaged.

use super::*;

/// A deterministic pseudo-random sequence (xorshift), skewed towards small symbols.
fn symbols(count: usize, alphabet: u32, seed: u64) -> Vec<usize> {
    let mut s = seed | 1;
    (0..count)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            // The minimum of two draws: small symbols likelier.
            let a = (s % alphabet as u64) as usize;
            let b = ((s >> 32) % alphabet as u64) as usize;
            a.min(b)
        })
        .collect()
}

fn counts(symbols: &[usize], alphabet: usize) -> Vec<u64> {
    let mut counts = vec![0u64; alphabet];
    for &s in symbols {
        counts[s] += 1;
    }
    counts
}

/// Codes `symbols` with their table; returns (table bytes, stream).
fn code(symbols: &[usize], alphabet: usize) -> (Vec<u8>, Vec<u8>) {
    let table = Table::from_counts(&counts(symbols, alphabet));
    let mut head = Vec::new();
    table.write(&mut head);
    let mut encoder = Encoder::new();
    for &s in symbols.iter().rev() {
        encoder.put(&table, s);
    }
    let mut stream = Vec::new();
    encoder.finish(&mut stream);
    (head, stream)
}

fn decode(head: &[u8], stream: &[u8], count: usize) -> Result<Vec<usize>, String> {
    let mut table = DecodeTable::new();
    let mut at = 0;
    table.read(head, &mut at, 255)?;
    let mut decoder = Decoder::new(stream)?;
    let decoded: Vec<usize> = (0..count).map(|_| decoder.get(&table) as usize).collect();
    decoder.finish()?;
    Ok(decoded)
}

#[test]
fn symbols_round_trip_and_cost_near_their_entropy() {
    for (alphabet, count, seed) in [(2, 1, 1), (1, 500, 2), (40, 3000, 3), (255, 10_000, 4)] {
        let input = symbols(count, alphabet, seed);
        let (head, stream) = code(&input, alphabet as usize);
        assert_eq!(decode(&head, &stream, count).unwrap(), input);
        let c = counts(&input, alphabet as usize);
        let entropy: f64 = c
            .iter()
            .filter(|&&k| k > 0)
            .map(|&k| -(k as f64) * (k as f64 / count as f64).log2())
            .sum();
        // 4 bytes of final state, a word's rounding, and the weights' rounding to powers of
        // two: within 8 % + 7 bytes.
        assert!(
            (stream.len() as f64) <= entropy / 8.0 * 1.08 + 7.0,
            "{alphabet} symbols: {} bytes for {:.1} bytes of entropy",
            stream.len(),
            entropy / 8.0
        );
    }
}

#[test]
fn a_single_symbol_costs_next_to_nothing() {
    let input = vec![3usize; 100_000];
    let (head, stream) = code(&input, 4);
    assert_eq!(stream.len(), 4, "only the final state");
    assert_eq!(decode(&head, &stream, input.len()).unwrap(), input);
}

#[test]
fn tables_give_every_counted_symbol_a_slot() {
    let mut c = vec![1u64; 200];
    c[0] = 1_000_000_000;
    let t = Table::from_counts(&c);
    assert!(t.freq.iter().all(|&f| f >= 1));
    assert_eq!(t.freq.iter().sum::<u32>(), PROB_SCALE);
    assert_eq!(t.alphabet(), 200);
}

#[test]
fn truncated_and_damaged_streams_are_errors_never_panics() {
    let input = symbols(2000, 30, 9);
    let (head, stream) = code(&input, 30);
    for cut in 0..stream.len() {
        assert!(
            decode(&head, &stream[..cut], input.len()).is_err(),
            "cut {cut}"
        );
    }
    let mut longer = stream.clone();
    longer.push(0);
    assert!(decode(&head, &longer, input.len()).is_err());
    // Every single-byte change either fails or decodes to other symbols (never panics).
    for at in 0..stream.len() {
        let mut damaged = stream.clone();
        damaged[at] ^= 0x5A;
        if let Ok(decoded) = decode(&head, &damaged, input.len()) {
            assert_ne!(decoded, input, "byte {at}");
        }
    }
}

#[test]
fn bad_tables_are_errors() {
    // No byte; no symbol; more symbols than allowed; weights cut short; a non-zero half byte
    // after an odd count; the last symbol without weight.
    for bad in [
        vec![],
        vec![0u8],
        vec![0u8, 0],
        vec![0u8, 9, 0x11, 0x11, 0x11, 0x11, 0x11],
        vec![6u8, 3, 0x11, 0x01],
        vec![0u8, 3, 0x11],
        vec![0u8, 3, 0x11, 0x11],
        vec![0u8, 2, 0x01],
        vec![0u8, 2, 0x10],
    ] {
        let mut table = DecodeTable::new();
        assert!(table.read(&bad, &mut 0, 8).is_err(), "{bad:?}");
    }
    let mut table = DecodeTable::new();
    let mut at = 0;
    table.read(&[2u8, 3, 0x21, 0x01, 0xFF], &mut at, 8).unwrap();
    assert_eq!((at, table.alphabet()), (4, 5));
}

#[test]
fn weights_normalise_to_the_scale_whatever_they_are() {
    for weights in [vec![1u8], vec![15, 1, 1], vec![15; 255], vec![0, 0, 3]] {
        let freq = normalise(&weights);
        assert_eq!(freq.iter().sum::<u32>(), PROB_SCALE, "{weights:?}");
        for (w, f) in weights.iter().zip(&freq) {
            assert_eq!(*w == 0, *f == 0, "{weights:?}");
        }
    }
}

#[test]
fn raw_bits_round_trip_and_check_their_end() {
    let mut w = BitWriter::default();
    let values: Vec<(u32, u32)> = (0..300u32)
        .map(|i| {
            let count = i % 33;
            let value = (i.wrapping_mul(2_654_435_761))
                & if count == 32 {
                    u32::MAX
                } else {
                    (1 << count) - 1
                };
            (value, count)
        })
        .collect();
    for &(v, c) in &values {
        w.put(v, c);
    }
    let bytes = w.finish();
    let mut r = BitReader::new(&bytes);
    for &(v, c) in &values {
        assert_eq!(r.get(c), v);
    }
    r.finish().unwrap();
    // One bit more than the bytes hold: past the end, which `finish` refuses.
    let mut past = BitReader::new(&bytes);
    for _ in 0..bytes.len() {
        past.get(8);
    }
    past.get(1);
    assert!(past.finish().is_err(), "a read past the end");
    let mut extra = bytes.clone();
    extra.push(0);
    let mut r = BitReader::new(&extra);
    for &(_, c) in &values {
        r.get(c);
    }
    assert!(r.finish().is_err(), "a byte too many");
    let mut dirty = bytes.clone();
    *dirty.last_mut().unwrap() |= 0x80;
    let mut r = BitReader::new(&dirty);
    for &(_, c) in &values {
        r.get(c);
    }
    let total: u32 = values.iter().map(|v| v.1).sum();
    assert_eq!(
        r.finish().is_err(),
        !total.is_multiple_of(8),
        "padding bits set"
    );
}

#[test]
fn varints_refuse_overlong_and_truncated_forms() {
    let mut out = Vec::new();
    write_varint(300, &mut out);
    assert_eq!(read_varint(&out, &mut 0, 2), Ok(300));
    assert!(read_varint(&[0x80, 0x80, 0x01], &mut 0, 2).is_err());
    assert!(read_varint(&[0x80], &mut 0, 2).is_err());
}
