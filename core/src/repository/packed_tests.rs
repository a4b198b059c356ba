//! Tests of `packed.rs`: packing is lossless on every shape of patch, and decoding never
//! panics nor lets a bad index or coordinate through.
use proptest::prelude::*;

use super::*;
use crate::repository::patch::{encode_patch, PatchData, STRIP_RESTART};

/// A patch of `n` vertices with every attribute in `attributes`, scattered positions and a
/// strip of `m` indices (restarts included), from `seed`.
fn patch(n: usize, m: usize, attributes: u32, seed: u64) -> PatchData {
    let mut state = seed | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let positions = (0..n)
        .map(|_| [0; 3].map(|_: u32| (next() % (POSITION_MAX as u64 + 1)) as u32))
        .collect();
    // Segments of 1..20 indices, each starting at an even position (as `encode_patch` asks).
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

fn raw_bytes(p: &PatchData, attributes: u32) -> Vec<u8> {
    let (mut raw, mut ids) = (Vec::new(), Vec::new());
    encode_patch(p, attributes, &mut raw, &mut ids);
    raw
}

const CODINGS: [StripCoding; 2] = [StripCoding::Nibbles, StripCoding::IndexSequence];

/// Packs and unpacks `p` with both strip codings.
fn round_trip(p: &PatchData, attributes: u32) {
    let raw = raw_bytes(p, attributes);
    let (n, m) = (p.vertex_count(), p.strip.len());
    for strips in CODINGS {
        let mut packed = vec![0u8; 8];
        let size = pack_patch(&raw, n, m, attributes, strips, &mut packed);
        assert_eq!(packed.len(), 8 + size);
        assert_eq!(size % 8, 0);
        let mut out = vec![0xAA; raw.len()];
        unpack_patch(&packed[8..], n, m, attributes, strips, &mut out).expect("decodes");
        assert!(
            out == raw,
            "{n} vertices, {m} indices, attributes {attributes:#x}, {strips:?}"
        );
    }
}

#[test]
fn empty_patches_pack_to_nothing() {
    let empty = PatchData::default();
    round_trip(&empty, 0);
    for strips in CODINGS {
        assert_eq!(pack_patch(&[], 0, 0, 0, strips, &mut Vec::new()), 0);
        let err = unpack_patch(&[0; 8], 0, 0, 0, strips, &mut []).unwrap_err();
        assert!(err.0.contains("empty patch"), "{err}");
    }
}

#[test]
fn wide_patches_keep_u32_indices_and_restarts() {
    let n = MAX_U16_PATCH_VERTICES + 10;
    round_trip(&patch(n, 3000, ATTR_ALL, 7), ATTR_ALL);
    round_trip(&patch(MAX_U16_PATCH_VERTICES, 3000, 0, 8), 0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn packing_is_lossless(n in 1usize..400, m in 0usize..900, attributes in 0u32..8, seed: u64) {
        round_trip(&patch(n, m, attributes, seed), attributes);
    }

    /// Any damage: a clean error or a decoded patch whose indices and coordinates are in
    /// range; never a panic.
    #[test]
    fn damaged_patches_never_panic(
        n in 1usize..200, m in 3usize..400, attributes in 0u32..8, seed: u64,
        at in any::<prop::sample::Index>(), xor in 1u8..=255, cut in any::<prop::sample::Index>(),
        nibbles: bool,
    ) {
        let strips = CODINGS[usize::from(!nibbles)];
        let p = patch(n, m, attributes, seed);
        let raw = raw_bytes(&p, attributes);
        let mut packed = Vec::new();
        pack_patch(&raw, n, p.strip.len(), attributes, strips, &mut packed);
        let mut out = vec![0; raw.len()];
        let mut flipped = packed.clone();
        flipped[at.index(packed.len())] ^= xor;
        let truncated = &packed[..cut.index(packed.len())];
        for bytes in [&flipped[..], truncated] {
            if unpack_patch(bytes, n, p.strip.len(), attributes, strips, &mut out).is_ok() {
                let positions = &out[..8 * n];
                for w in positions.chunks_exact(8) {
                    let q = unpack_position([le_u32(&w[..4]), le_u32(&w[4..])]);
                    prop_assert!(q.iter().all(|&c| c <= POSITION_MAX));
                }
                let strip_start = out.len() - align_strip(&p, attributes);
                for c in out[strip_start..].chunks_exact(2).take(p.strip.len()) {
                    let i = u16::from_le_bytes([c[0], c[1]]);
                    prop_assert!(i == u16::MAX || (i as usize) < n);
                }
            }
        }
    }
}

/// Bytes from the strip's start to the end of the decoded patch (strip and padding).
fn align_strip(p: &PatchData, attributes: u32) -> usize {
    let total = crate::repository::patch::patch_bytes(p.vertex_count(), p.strip.len(), attributes);
    total - crate::repository::patch::strip_byte_offset(p.vertex_count(), attributes)
}

#[test]
fn wrong_sizes_are_errors() {
    let p = patch(50, 120, ATTR_NORMALS, 3);
    let raw = raw_bytes(&p, ATTR_NORMALS);
    let strips = StripCoding::Nibbles;
    let mut packed = Vec::new();
    pack_patch(&raw, 50, p.strip.len(), ATTR_NORMALS, strips, &mut packed);
    let mut out = vec![0; raw.len()];
    // Another attribute mask decodes into another size: refused before any decoding.
    assert!(unpack_patch(&packed, 50, p.strip.len(), ATTR_UVS, strips, &mut out).is_err());
    // A stream size past the end.
    let mut bad = packed.clone();
    bad[0..4].copy_from_slice(&u32::MAX.to_le_bytes());
    let err = unpack_patch(&bad, 50, p.strip.len(), ATTR_NORMALS, strips, &mut out).unwrap_err();
    assert!(err.0.contains("positions stream"), "{err}");
    // Trailing bytes beyond the padding.
    let mut long = packed.clone();
    long.extend_from_slice(&[0; 8]);
    let err = unpack_patch(&long, 50, p.strip.len(), ATTR_NORMALS, strips, &mut out).unwrap_err();
    assert!(err.0.contains("after the streams"), "{err}");
    // A strip packed one way does not decode the other way into the same indices.
    let mut v1 = Vec::new();
    pack_patch(
        &raw,
        50,
        p.strip.len(),
        ATTR_NORMALS,
        StripCoding::IndexSequence,
        &mut v1,
    );
    let decoded = unpack_patch(&v1, 50, p.strip.len(), ATTR_NORMALS, strips, &mut out);
    assert!(decoded.is_err() || out != raw);
}
