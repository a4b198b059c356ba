//! Tests of `coded.rs`: coding is lossless on every shape of patch, predicts a regular mesh
//! to almost nothing, and decoding refuses damaged or cut streams without panicking.
use proptest::prelude::*;

use super::*;
use crate::repository::packed::{pack_patch, StripCoding};
use crate::repository::patch::{encode_patch, PatchData, STRIP_RESTART};

fn xorshift(seed: u64) -> impl FnMut() -> u64 {
    let mut state = seed | 1;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    }
}

/// A patch of `n` vertices with the attributes of `attributes`, scattered positions and a
/// strip of `m` indices in any order (restarts included), from `seed`.
fn scattered(n: usize, m: usize, attributes: u32, seed: u64) -> PatchData {
    let mut next = xorshift(seed);
    let positions = (0..n)
        .map(|_| [0; 3].map(|_: u32| (next() % (POSITION_MAX as u64 + 1)) as u32))
        .collect();
    let mut strip: Vec<u32> = Vec::with_capacity(m + m / 4);
    while n > 0 && strip.len() < m {
        if !strip.is_empty() {
            strip.push(STRIP_RESTART);
            if strip.len() % 2 == 1 {
                strip.push(STRIP_RESTART);
            }
        }
        let length = 1 + next() % 20;
        strip.extend((0..length).map(|_| (next() % n as u64) as u32));
    }
    with_attributes(n, positions, strip, attributes, &mut next)
}

fn with_attributes(
    n: usize,
    positions: Vec<[u32; 3]>,
    strip: Vec<u32>,
    attributes: u32,
    next: &mut impl FnMut() -> u64,
) -> PatchData {
    PatchData {
        global_ids: (0..n as u32).collect(),
        positions,
        normals: (attributes & ATTR_NORMALS != 0)
            .then(|| (0..n).map(|_| [next() as i16, next() as i16]).collect()),
        colors: (attributes & ATTR_COLORS != 0)
            .then(|| (0..n).map(|_| (next() as u32).to_le_bytes()).collect()),
        uvs: (attributes & ATTR_UVS != 0).then(|| {
            (0..n)
                .map(|_| [f32::from_bits(next() as u32), next() as f32 * 1e-9])
                .collect()
        }),
        strip,
        triangle_count: 0,
    }
}

/// A regular grid of `side` × `side` vertices, as strips of two rows each (restart between),
/// numbered in first-use order: what a scanned surface's patch looks like, flattened.
fn grid(side: usize, attributes: u32, seed: u64) -> PatchData {
    let mut order = vec![u32::MAX; side * side];
    let (mut strip, mut positions) = (Vec::new(), Vec::new());
    for row in 0..side - 1 {
        if row > 0 {
            strip.push(STRIP_RESTART);
            if strip.len() % 2 == 1 {
                strip.push(STRIP_RESTART);
            }
        }
        for col in 0..side {
            for r in [row, row + 1] {
                let g = r * side + col;
                if order[g] == u32::MAX {
                    order[g] = positions.len() as u32;
                    positions.push([1000 + 37 * col as u32, 5000 + 41 * r as u32, 77]);
                }
                strip.push(order[g]);
            }
        }
    }
    let n = positions.len();
    with_attributes(n, positions, strip, attributes, &mut xorshift(seed))
}

fn raw_bytes(p: &PatchData, attributes: u32) -> Vec<u8> {
    let (mut raw, mut ids) = (Vec::new(), Vec::new());
    encode_patch(p, attributes, &mut raw, &mut ids);
    raw
}

/// Codes and decodes `p`; returns the coded bytes.
fn round_trip(p: &PatchData, attributes: u32) -> Vec<u8> {
    let raw = raw_bytes(p, attributes);
    let (n, m) = (p.vertex_count(), p.strip.len());
    let mut coded = vec![0u8; 8];
    let size = code_patch(&raw, n, m, attributes, &mut coded);
    assert_eq!((coded.len(), size % 8), (8 + size, 0));
    let mut out = vec![0xAA; raw.len()];
    decode_patch(&coded[8..], n, m, attributes, &mut out).expect("decodes");
    assert!(
        out == raw,
        "{n} vertices, {m} indices, attributes {attributes:#x}"
    );
    // The same through `packed.rs`'s entry points, as readers call them.
    let mut again = Vec::new();
    pack_patch(&raw, n, m, attributes, StripCoding::Coded, &mut again);
    assert_eq!(again, coded[8..]);
    out.fill(0x55);
    crate::repository::packed::unpack_patch(&again, n, m, attributes, StripCoding::Coded, &mut out)
        .expect("decodes");
    assert!(out == raw);
    coded.split_off(8)
}

#[test]
fn empty_patches_code_to_nothing() {
    assert!(round_trip(&PatchData::default(), 0).is_empty());
    let err = decode_patch(&[0; 8], 0, 0, 0, &mut []).unwrap_err();
    assert!(err.0.contains("empty patch"), "{err}");
}

#[test]
fn a_regular_grid_codes_to_a_fraction_of_its_packed_size() {
    let p = grid(24, 0, 1);
    let coded = round_trip(&p, 0);
    let raw = raw_bytes(&p, 0);
    let mut packed = Vec::new();
    pack_patch(
        &raw,
        p.vertex_count(),
        p.strip.len(),
        0,
        StripCoding::Nibbles,
        &mut packed,
    );
    // Parallelograms predict every interior vertex exactly: a few bits a vertex.
    assert!(
        coded.len() * 4 < packed.len(),
        "coded {} B, packed {} B, raw {} B",
        coded.len(),
        packed.len(),
        raw.len()
    );
}

#[test]
fn wide_patches_keep_u32_indices_and_restarts() {
    let n = MAX_U16_PATCH_VERTICES + 10;
    round_trip(&scattered(n, 3000, ATTR_ALL, 7), ATTR_ALL);
    round_trip(&scattered(MAX_U16_PATCH_VERTICES, 3000, 0, 8), 0);
}

#[test]
fn vertices_without_a_strip_and_a_strip_of_restarts_code() {
    round_trip(&scattered(30, 0, ATTR_ALL, 2), ATTR_ALL);
    let restarts = PatchData {
        strip: vec![STRIP_RESTART; 6],
        ..PatchData::default()
    };
    round_trip(&restarts, 0);
}

#[test]
fn extreme_coordinates_and_long_strip_jumps_code() {
    let n = 40_000;
    let mut p = scattered(n, 0, 0, 3);
    p.positions[0] = [POSITION_MAX; 3];
    p.positions[1] = [0; 3];
    p.positions[2] = [POSITION_MAX, 0, POSITION_MAX];
    p.strip = vec![39_999, 0, 1, 5, 39_000, 2, 3, 4, 38_000];
    round_trip(&p, 0);
}

#[test]
fn wrong_sizes_padding_and_cuts_are_errors() {
    let p = grid(10, ATTR_NORMALS, 3);
    let (n, m) = (p.vertex_count(), p.strip.len());
    let coded = round_trip(&p, ATTR_NORMALS);
    let mut out = vec![0; raw_bytes(&p, ATTR_NORMALS).len()];
    // Another mask decodes into another size: refused before any decoding.
    assert!(decode_patch(&coded, n, m, ATTR_UVS, &mut out).is_err());
    let mut long = coded.clone();
    long.extend_from_slice(&[0; 8]);
    assert!(decode_patch(&long, n, m, ATTR_NORMALS, &mut out).is_err());
    for cut in 0..coded.len() {
        assert!(
            decode_patch(&coded[..cut], n, m, ATTR_NORMALS, &mut out).is_err(),
            "cut {cut}"
        );
    }
    // One index fewer or more than coded: the streams are not used exactly.
    let mut fewer = vec![0; crate::repository::patch::patch_bytes(n, m - 1, ATTR_NORMALS)];
    assert!(decode_patch(&coded, n, m - 1, ATTR_NORMALS, &mut fewer).is_err());
}

#[test]
fn a_bloated_length_is_refused_without_reading_past_the_patch() {
    let p = grid(6, 0, 4);
    let coded = round_trip(&p, 0);
    let mut out = vec![0; raw_bytes(&p, 0).len()];
    // The tables' end: the strip table then the position table, each 2 + ⌈used/2⌉ bytes.
    let mut at = 0;
    for _ in 0..2 {
        at += 2 + (coded[at + 1] as usize).div_ceil(2);
    }
    let mut bad = coded[..at].to_vec();
    write_varint(u32::MAX as u64 * 4, &mut bad);
    bad.extend_from_slice(&coded[at + 1..]);
    let err = decode_patch(&bad, p.vertex_count(), p.strip.len(), 0, &mut out).unwrap_err();
    assert!(err.0.contains("past the patch"), "{err}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn coding_is_lossless(n in 1usize..400, m in 0usize..900, attributes in 0u32..8, seed: u64) {
        round_trip(&scattered(n, m, attributes, seed), attributes);
    }

    #[test]
    fn grids_code_losslessly(side in 2usize..30, attributes in 0u32..8, seed: u64) {
        round_trip(&grid(side, attributes, seed), attributes);
    }

    /// Any damage: a clean error or a decoded patch whose indices and coordinates are in
    /// range; never a panic.
    #[test]
    fn damaged_patches_never_panic(
        side in 3usize..16, attributes in 0u32..8, seed: u64,
        at in any::<prop::sample::Index>(), xor in 1u8..=255, cut in any::<prop::sample::Index>(),
    ) {
        let p = grid(side, attributes, seed);
        let (n, m) = (p.vertex_count(), p.strip.len());
        let coded = round_trip(&p, attributes);
        let mut out = vec![0; raw_bytes(&p, attributes).len()];
        let mut flipped = coded.clone();
        flipped[at.index(coded.len())] ^= xor;
        let truncated = &coded[..cut.index(coded.len())];
        for bytes in [&flipped[..], truncated] {
            if decode_patch(bytes, n, m, attributes, &mut out).is_ok() {
                for w in out[..8 * n].chunks_exact(8) {
                    let q = unpack_position([lane(&w[..4], 4), lane(&w[4..], 4)]);
                    prop_assert!(q.iter().all(|&c| c <= POSITION_MAX));
                }
                let strip_start = crate::repository::patch::strip_byte_offset(n, attributes);
                for c in out[strip_start..].chunks_exact(2).take(m) {
                    let i = u16::from_le_bytes([c[0], c[1]]);
                    prop_assert!(i == u16::MAX || (i as usize) < n);
                }
            }
        }
    }
}
