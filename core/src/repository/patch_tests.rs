//! Tests of `patch.rs`: encoding round trips and the validating view.
use super::*;

const R: u32 = STRIP_RESTART;

fn decode(strip: &[u32]) -> Vec<[u32; 3]> {
    StripTriangles::new(StripIndices::U32(strip)).collect()
}

#[test]
fn strips_decode_like_meshopt_unstripify() {
    let cases: &[(&[u32], &[[u32; 3]])] = &[
        (&[], &[]),
        (&[0, 1], &[]),
        (&[0, 1, 2], &[[0, 1, 2]]),
        // Odd triangles swap their first two vertices.
        (&[0, 1, 2, 3, 4], &[[0, 1, 2], [2, 1, 3], [2, 3, 4]]),
        // Restart resets the parity.
        (
            &[0, 1, 2, 3, R, 4, 5, 6, 7],
            &[[0, 1, 2], [2, 1, 3], [4, 5, 6], [6, 5, 7]],
        ),
        (&[R, R, 0, 1, R, 2, 3, 4, R], &[[2, 3, 4]]),
        // A repeated index makes degenerate joints, skipped but counted for parity.
        (&[0, 1, 2, 2, 3, 4], &[[0, 1, 2], [3, 2, 4]]),
        // (0 0 1) is degenerate; the odd (0 1 2) swaps to (1 0 2).
        (&[0, 0, 1, 2], &[[1, 0, 2]]),
    ];
    for (strip, expected) in cases {
        assert_eq!(decode(strip), *expected, "strip {strip:?}");
    }
}

/// Meshoptimizer's stripify of the quad list [0 1 2, 2 1 3] is [0 1 2 3]: both triangles
/// come back with their input winding (up to rotation).
#[test]
fn winding_is_preserved() {
    let tris = decode(&[0, 1, 2, 3]);
    let same =
        |a: [u32; 3], b: [u32; 3]| (0..3).any(|r| [a[r], a[(r + 1) % 3], a[(r + 2) % 3]] == b);
    assert!(
        same(tris[0], [0, 1, 2]) && same(tris[1], [2, 1, 3]),
        "{tris:?}"
    );
}

fn sample(n: usize, attributes: u32) -> PatchData {
    // A second restart keeps the second segment at an even position.
    let restarts = if n.is_multiple_of(2) { 2 } else { 1 };
    let strip: Vec<u32> = (0..n as u32)
        .chain(std::iter::repeat_n(R, restarts))
        .chain((0..n.min(3) as u32).rev())
        .collect();
    let triangle_count = decode(&strip).len() as u32;
    PatchData {
        global_ids: (0..n as u32).map(|i| i * 7 + 1).collect(),
        positions: (0..n as u32).map(|i| [i % 2_000_000, 3, i % 5]).collect(),
        normals: (attributes & ATTR_NORMALS != 0).then(|| {
            (0..n)
                .map(|i| [i as i16, (i as i16).wrapping_neg()])
                .collect()
        }),
        colors: (attributes & ATTR_COLORS != 0)
            .then(|| (0..n).map(|i| [i as u8, 1, 2, 255]).collect()),
        uvs: (attributes & ATTR_UVS != 0).then(|| (0..n).map(|i| [i as f32, 0.5]).collect()),
        strip,
        triangle_count,
    }
}

fn record(patch: &PatchData, placement: PatchPlacement) -> TetRecord {
    TetRecord {
        patch_offset: placement.patch_offset,
        patch_bytes: placement.patch_bytes,
        id_offset: placement.id_offset,
        id_bytes: placement.id_bytes,
        vertex_count: patch.vertex_count() as u32,
        strip_index_count: patch.strip.len() as u32,
        triangle_count: patch.triangle_count,
        ..bytemuck::Zeroable::zeroed()
    }
}

/// An 8-aligned copy of `bytes`.
fn aligned(bytes: &[u8]) -> Vec<u64> {
    let mut words = vec![0u64; bytes.len().div_ceil(8)];
    bytemuck::cast_slice_mut::<u64, u8>(&mut words)[..bytes.len()].copy_from_slice(bytes);
    words
}

fn source<'a>(patch_blob: &'a [u8], id_blob: &'a [u8], attributes: u32) -> PatchSource<'a> {
    PatchSource {
        patch_blob,
        id_blob,
        attributes,
        input_vertex_count: 1 << 20,
    }
}

#[test]
fn encode_parse_round_trip() {
    for attributes in 0..=ATTR_ALL {
        for n in [0, 1, 3, 5, 65_535, 65_536] {
            let patch = sample(n, attributes);
            let mut blob = vec![0u8; 8];
            let mut ids = vec![9u8; 3];
            let placement = encode_patch(&patch, attributes, &mut blob, &mut ids);
            assert_eq!((placement.patch_offset, placement.id_offset), (8, 3));
            assert_eq!(ids.len(), 3 + placement.id_bytes as usize);
            let tet = record(&patch, placement);
            assert_eq!(blob.len() as u64, 8 + tet.patch_bytes as u64);
            assert_eq!(
                tet.patch_bytes as usize,
                patch_bytes(n, patch.strip.len(), attributes)
            );
            let words = aligned(&blob);
            let bytes = &bytemuck::cast_slice::<u64, u8>(&words)[..blob.len()];
            let view = PatchView::parse(&source(bytes, &ids, attributes), &tet).unwrap();
            assert_eq!(view.to_patch_data(), patch);
            assert_eq!(matches!(view.strip(), StripIndices::U32(_)), n > 65_535);
            assert_eq!(
                view.triangles().collect::<Vec<_>>(),
                patch.triangles().collect::<Vec<_>>()
            );
            if n > 0 {
                assert_eq!(
                    view.position(n - 1),
                    [(n as u32 - 1) % 2_000_000, 3, (n as u32 - 1) % 5]
                );
                // The positions are the first array: a renderer reads them from the blob.
                assert_eq!(
                    view.packed_positions()[n - 1],
                    pack_position(view.position(n - 1))
                );
            }
        }
    }
}

#[test]
fn sizes_are_exact() {
    assert_eq!(strip_byte_offset(3, ATTR_ALL), 72);
    assert_eq!(strip_byte_offset(3, ATTR_NORMALS), 36);
    assert_eq!(strip_byte_offset(0, ATTR_ALL), 0);
    assert_eq!(patch_bytes(0, 0, 0), 0);
    assert_eq!(patch_bytes(1, 1, 0), 16); // 8 + 2 → 16
    assert_eq!(patch_bytes(3, 4, ATTR_ALL), 80); // 3 × 24 + 4 × 2 = 80
    assert_eq!(patch_bytes(3, 5, ATTR_ALL), 88); // 82 → 88
    assert_eq!(patch_bytes(65_536, 3, 0), 65_536 * 8 + 16);
    assert_eq!(
        patch_bytes_checked(u32::MAX as u64, u32::MAX as u64, ATTR_ALL),
        Some(8 * ((u32::MAX as u64 * 28).div_ceil(8)))
    );
    assert_eq!(patch_bytes_checked(u64::MAX, 1, 0), None);
}

#[test]
fn parse_rejects_bad_patches_without_panicking() {
    let attributes = ATTR_NORMALS;
    let patch = sample(5, attributes);
    let (mut blob, mut ids) = (Vec::new(), Vec::new());
    let good = record(
        &patch,
        encode_patch(&patch, attributes, &mut blob, &mut ids),
    );
    let words = aligned(&blob);
    let bytes = &bytemuck::cast_slice::<u64, u8>(&words)[..blob.len()];
    let check_with = |tet: TetRecord, source: PatchSource, expected: &str| {
        let err = PatchView::parse(&source, &tet).unwrap_err().to_string();
        assert!(
            err.contains(expected),
            "{err:?} should mention {expected:?}"
        );
    };
    let check = |tet: TetRecord, bytes: &[u8], attributes: u32, expected: &str| {
        check_with(tet, source(bytes, &ids, attributes), expected)
    };
    check(
        TetRecord {
            patch_offset: 8,
            ..good
        },
        bytes,
        attributes,
        "exceeds patch blob",
    );
    check(
        TetRecord {
            patch_offset: u64::MAX - 7,
            ..good
        },
        bytes,
        attributes,
        "exceeds patch blob",
    );
    check(
        TetRecord {
            patch_offset: 4,
            ..good
        },
        bytes,
        attributes,
        "not a multiple of 8",
    );
    check(
        TetRecord {
            patch_bytes: good.patch_bytes + 8,
            ..good
        },
        bytes,
        attributes,
        "take",
    );
    check(
        TetRecord {
            vertex_count: u32::MAX,
            ..good
        },
        bytes,
        attributes,
        "take",
    );
    check(good, bytes, 8, "unknown attribute");
    check(good, bytes, 0, "take");
    check(
        TetRecord {
            triangle_count: 100,
            ..good
        },
        bytes,
        attributes,
        "cannot fit",
    );
    // The id stream: out of the blob, too short, too long, an id past the input.
    check(
        TetRecord {
            id_offset: 1,
            ..good
        },
        bytes,
        attributes,
        "exceeds id blob",
    );
    check(
        TetRecord {
            id_offset: u64::MAX,
            ..good
        },
        bytes,
        attributes,
        "exceeds id blob",
    );
    check(
        TetRecord {
            id_bytes: good.id_bytes - 1,
            ..good
        },
        bytes,
        attributes,
        "id stream",
    );
    let mut longer = ids.clone();
    longer.push(0);
    check_with(
        TetRecord {
            id_bytes: good.id_bytes + 1,
            ..good
        },
        source(bytes, &longer, attributes),
        "but its 5 ids take 5",
    );
    check_with(
        good,
        PatchSource {
            input_vertex_count: 29, // the last id is 29
            ..source(bytes, &ids, attributes)
        },
        "global id 4 is 29, not a vertex of the 29-vertex input",
    );
    // Strip index 5 of a 5-vertex patch.
    let mut bad = bytes.to_vec();
    let strip_at = 5 * 12;
    bad[strip_at..strip_at + 2].copy_from_slice(&5u16.to_le_bytes());
    let words = aligned(&bad);
    check(
        good,
        &bytemuck::cast_slice::<u64, u8>(&words)[..bad.len()],
        attributes,
        "strip index 0 is 5",
    );
    // A restart at position 0: the segment 1 2 3 4 starts at an odd position.
    let mut bad = bytes.to_vec();
    bad[strip_at..strip_at + 2].copy_from_slice(&RESTART_U16.to_le_bytes());
    let words = aligned(&bad);
    check(
        good,
        &bytemuck::cast_slice::<u64, u8>(&words)[..bad.len()],
        attributes,
        "segment starts at the odd position 1",
    );
    assert_eq!(
        odd_segment_start(StripIndices::U32(&[0, 1, 2, R, 3, 4, 5, R, 6, 7])),
        None
    );
    assert_eq!(
        odd_segment_start(StripIndices::U32(&[0, 1, 2, 3, R, 4, 5, 6])),
        Some(5)
    );
    // Non-zero padding (5 × 12 + 9 × 2 = 78 bytes, padded to 80).
    let mut bad = bytes.to_vec();
    bad[79] = 1;
    let words = aligned(&bad);
    check(
        good,
        &bytemuck::cast_slice::<u64, u8>(&words)[..bad.len()],
        attributes,
        "padding is not zero",
    );
    // Misaligned memory is an error, not a panic.
    let shifted: Vec<u8> = [0u8].iter().chain(bytes).copied().collect();
    let words = aligned(&shifted);
    let misaligned = &bytemuck::cast_slice::<u64, u8>(&words)[1..shifted.len()];
    check(good, misaligned, attributes, "not 8-aligned in memory");
}

#[test]
#[should_panic(expected = "strip index 1 is 9")]
fn encode_asserts_strip_range() {
    let mut patch = sample(3, 0);
    patch.strip[1] = 9;
    encode_patch(&patch, 0, &mut Vec::new(), &mut Vec::new());
}

#[test]
#[should_panic(expected = "normals are missing")]
fn encode_asserts_attributes() {
    encode_patch(
        &sample(3, 0),
        ATTR_NORMALS,
        &mut Vec::new(),
        &mut Vec::new(),
    );
}

#[test]
#[should_panic(expected = "exceeds 2097151")]
fn encode_asserts_position_range() {
    let mut patch = sample(3, 0);
    patch.positions[1][2] = POSITION_MAX + 1;
    encode_patch(&patch, 0, &mut Vec::new(), &mut Vec::new());
}
