//! Shared by the repository tests: hand-made patches and a hand-made repository.
#![allow(dead_code)]

use tessera_core::repository::format::{
    oct_encode_normal, DiamondRecord, Header, PatchCodec, TetRecord, ATTR_COLORS, ATTR_NORMALS,
    ATTR_UVS, NO_INDEX,
};
use tessera_core::repository::patch::{encode_patch, PatchData, STRIP_RESTART};
use tessera_core::repository::RepositoryContents;

pub const R: u32 = STRIP_RESTART;

/// Meshoptimizer's `meshopt_unstripify`, transcribed independently of the crate's decoder.
pub fn unstripify(indices: &[u32]) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    let mut start = 0;
    for i in 0..indices.len() {
        if indices[i] == R {
            start = i + 1;
        } else if i - start >= 2 {
            let (mut a, mut b, c) = (indices[i - 2], indices[i - 1], indices[i]);
            if (i - start) & 1 == 1 {
                std::mem::swap(&mut a, &mut b);
            }
            if a != b && a != c && b != c {
                out.push([a, b, c]);
            }
        }
    }
    out
}

/// A patch of `n` vertices: one long strip, a restart, and a short strip. Global ids are
/// `seed × 100,000 + i`.
pub fn patch(n: u32, seed: u32, attributes: u32) -> PatchData {
    let spread = if seed == 7 { 100_000 } else { 7 };
    let strip: Vec<u32> = if n < 3 {
        Vec::new()
    } else {
        // Segments start at even positions (a second restart where needed).
        let restarts = if n.is_multiple_of(2) { 2 } else { 1 };
        (0..n)
            .chain(std::iter::repeat_n(R, restarts))
            .chain([n - 1, 0, 1, 1, 2])
            .collect()
    };
    PatchData {
        global_ids: (0..n).map(|i| seed * 100_000 + i).collect(),
        positions: (0..n)
            .map(|i| [i % 2_097_152, (i * spread + seed) % 2_097_152, seed])
            .collect(),
        normals: (attributes & ATTR_NORMALS != 0).then(|| {
            (0..n)
                .map(|i| oct_encode_normal([i as f32, 1.0, -(seed as f32)]))
                .collect()
        }),
        colors: (attributes & ATTR_COLORS != 0)
            .then(|| (0..n).map(|i| [i as u8, seed as u8, 7, 255]).collect()),
        uvs: (attributes & ATTR_UVS != 0)
            .then(|| (0..n).map(|i| [i as f32 * 0.25, seed as f32]).collect()),
        triangle_count: unstripify(&strip).len() as u32,
        strip,
    }
}

/// A hand-made hierarchy: roots 0, 1 split by diamond 0 into 2..=5; tets 2 and 4 split by
/// diamond 1 into 6..=9; 3, 5 and 6..=9 are leaves. Tet 9 gets 70,000 vertices when `big`.
pub fn contents(
    dimension: u32,
    attributes: u32,
    big: bool,
) -> (RepositoryContents, Vec<PatchData>) {
    let diamond = |level: u32, error: f32, parents: &[u32], id: [i32; 3]| {
        let mut slots = [NO_INDEX; 4];
        slots[..parents.len()].copy_from_slice(parents);
        DiamondRecord {
            center: [0.5, 0.25, -1.0],
            radius: 3.0 / (level + 1) as f32,
            error,
            parents: slots,
            parent_count: parents.len() as u8,
            tet_count: 2,
            phase: (level % dimension) as u8,
            pad: 0,
            level,
            id,
        }
    };
    let diamonds = vec![
        diamond(0, 2.0, &[], [8, 8, 0]),
        diamond(1, 0.5, &[0], [8, 0, 0]),
    ];
    // (diamond, parent diamond, first child, level)
    let shape = [
        (0, NO_INDEX, 2, 0),
        (0, NO_INDEX, 4, 0),
        (1, 0, 6, 1),
        (NO_INDEX, 0, NO_INDEX, 1),
        (1, 0, 8, 1),
        (NO_INDEX, 0, NO_INDEX, 1),
        (NO_INDEX, 1, NO_INDEX, 2),
        (NO_INDEX, 1, NO_INDEX, 2),
        (NO_INDEX, 1, NO_INDEX, 2),
        (NO_INDEX, 1, NO_INDEX, 2),
    ];
    let (mut blob, mut ids) = (Vec::new(), Vec::new());
    let mut patches = Vec::new();
    let mut tets = Vec::new();
    for (i, &(diamond, parent_diamond, first_child, level)) in shape.iter().enumerate() {
        let n = match i {
            0 => 0, // an empty patch
            9 if big => 70_000,
            _ => 3 + 2 * i as u32,
        };
        let p = patch(n, i as u32, attributes);
        let placement = encode_patch(&p, attributes, &mut blob, &mut ids);
        tets.push(TetRecord {
            center: [i as f32, 0.0, 1.0],
            radius: 1.5,
            cone_axis: [0.0, 0.0, 1.0],
            cone_cos: if i % 2 == 0 { -1.0 } else { 0.5 },
            diamond,
            parent_diamond,
            first_child,
            level,
            patch_offset: placement.patch_offset,
            patch_bytes: placement.patch_bytes,
            vertex_count: n,
            strip_index_count: p.strip.len() as u32,
            triangle_count: p.triangle_count,
            id_offset: placement.id_offset,
            id_bytes: placement.id_bytes,
            // The writer fills it.
            patch_checksum: 0,
        });
        patches.push(p);
    }
    let header = Header {
        root_tet_count: 2,
        // Global ids reach 9 × 100,000 + 69,999.
        input_vertex_count: 1_000_000,
        input_triangle_count: 2000,
        origin: [1.0, 2.0, 3.0],
        bbox_min: [0.0, 1.0, 2.0],
        bbox_max: [2.0, 3.0, 4.0],
        position_step: [2.0 / 2_097_151.0; 3],
        lattice_origin: [-1.0, -1.0, -1.0],
        lattice_unit: 0.25,
        lattice_bits: 4,
        // Whatever the caller leaves in the writer's fields is overwritten.
        checksum: 77,
        diamond_count: 1 << 60,
        ..Header::new(dimension, attributes)
    };
    let contents = RepositoryContents {
        header,
        diamonds,
        tets,
        patch_blob: blob,
        id_blob: ids,
        codec: PatchCodec::Raw,
        attribute_errors: None,
    };
    (contents, patches)
}
