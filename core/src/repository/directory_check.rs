//! The directory's checks: the header fields and every diamond and tet record, against each
//! other and the hierarchy's structure, in time and memory linear in the tables. Shared by the
//! reader (`Repository::open`) and the writer (nothing invalid is ever written).

use super::format::{
    DiamondRecord, Header, PatchCodec, TetRecord, ATTR_ALL, NO_INDEX, TABLE_ALIGN,
};
use super::patch::patch_bytes_checked;
use super::reader::{corrupt, RepositoryError};

/// Most bytes a packed patch may decode to per byte stored (+ 256): a reader allocates the
/// decoded size, so it must follow from the file's size. Index codecs spend at least a byte an
/// index (2 or 4 decoded), and real patches pack 2-4×; the bound leaves a wide margin.
pub const MAX_PACKING_RATIO: u64 = 32;

/// Sizes of the patch and id blobs, which every patch and id range must fit.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BlobSizes {
    pub patches: u64,
    pub ids: u64,
    /// How the patch blob stores its patches (what `patch_bytes` must be).
    pub codec: PatchCodec,
}

fn finite<const N: usize>(v: [f32; N]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Checks the header fields that the caller of the writer fills (not magic, version, offsets,
/// checksum): dimension, attribute bits, reserved, lattice and bounding box.
pub(crate) fn check_header_fields(h: &Header) -> Result<(), RepositoryError> {
    if h.dimension != 2 && h.dimension != 3 {
        return Err(corrupt(format!("dimension {} is not 2 or 3", h.dimension)));
    }
    if h.attributes & !ATTR_ALL != 0 {
        return Err(corrupt(format!(
            "unknown attribute bits {:#x} (known: {ATTR_ALL:#x})",
            h.attributes & !ATTR_ALL
        )));
    }
    if h.tet_count >= NO_INDEX as u64 || h.diamond_count >= NO_INDEX as u64 {
        return Err(corrupt(format!(
            "{} tets and {} diamonds: tables are indexed by u32, with {NO_INDEX} reserved",
            h.tet_count, h.diamond_count
        )));
    }
    if h.input_vertex_count > 1 << 32 {
        return Err(corrupt(format!(
            "{} input vertices: global ids are u32",
            h.input_vertex_count
        )));
    }
    if !(1..=30).contains(&h.lattice_bits) {
        return Err(corrupt(format!(
            "lattice bits {} not in 1..=30",
            h.lattice_bits
        )));
    }
    if !(h.lattice_unit.is_finite() && h.lattice_unit > 0.0) {
        return Err(corrupt(format!(
            "lattice unit {} is not finite and positive",
            h.lattice_unit
        )));
    }
    let vectors = [
        ("origin", h.origin),
        ("bbox_min", h.bbox_min),
        ("bbox_max", h.bbox_max),
        ("position_step", h.position_step),
        ("lattice_origin", h.lattice_origin),
    ];
    if let Some((name, v)) = vectors
        .iter()
        .find(|(_, v)| !v.iter().all(|x| x.is_finite()))
    {
        return Err(corrupt(format!("header {name} {v:?} is not finite")));
    }
    if (0..3).any(|i| h.bbox_min[i] > h.bbox_max[i] || h.position_step[i] < 0.0) {
        return Err(corrupt(format!(
            "bounding box {:?}..{:?} is inverted or position step {:?} negative",
            h.bbox_min, h.bbox_max, h.position_step
        )));
    }
    if h.root_tet_count > h.tet_count {
        return Err(corrupt(format!(
            "{} root tets but only {} tets",
            h.root_tet_count, h.tet_count
        )));
    }
    Ok(())
}

/// Checks every record against the header and the other records (patch and id ranges inside
/// their blobs; the patches' contents are checked by `PatchView::parse`), and the structure of
/// the hierarchy, in time and memory linear in the tables: diamonds' parents stored before
/// them; a diamond's simplices exactly `tet_count` tets, each created by one of the diamond's
/// parents; every non-root tet the child of exactly one tet (a tree, not a DAG: a crafted
/// table whose tets share children would make traversals exponential). `h` must have passed
/// `check_header_fields`, and its counts must match the slices.
pub(crate) fn check_tables(
    h: &Header,
    diamonds: &[DiamondRecord],
    tets: &[TetRecord],
    blobs: BlobSizes,
    release_tets: &dyn Fn(std::ops::Range<usize>),
) -> Result<(), RepositoryError> {
    debug_assert_eq!(
        (h.diamond_count, h.tet_count),
        (diamonds.len() as u64, tets.len() as u64)
    );
    let side = 1i64 << h.lattice_bits;
    for (i, d) in diamonds.iter().enumerate() {
        let fail = |what: String| Err(corrupt(format!("diamond {i}: {what}")));
        if !(finite(d.center) && d.radius.is_finite() && d.radius >= 0.0) {
            return fail(format!(
                "bounding sphere {:?} r {} is not finite",
                d.center, d.radius
            ));
        }
        if !(d.error.is_finite() && d.error > 0.0) {
            return fail(format!("error {} is not finite and positive", d.error));
        }
        if d.parent_count > 4 {
            return fail(format!("{} parents, at most 4", d.parent_count));
        }
        for (k, &p) in d.parents.iter().enumerate() {
            if k < d.parent_count as usize {
                if p as usize >= i {
                    return fail(format!("parent {k} is {p}, not a diamond stored before it"));
                }
            } else if p != NO_INDEX {
                return fail(format!("unused parent slot {k} is {p}, not NO_INDEX"));
            }
        }
        if d.phase as u32 != d.level % h.dimension || d.pad != 0 {
            return fail(format!(
                "phase {} / pad {} at level {}",
                d.phase, d.pad, d.level
            ));
        }
        let outside = |c: i32| !(0..=side).contains(&(c as i64));
        if d.id.iter().any(|&c| outside(c)) || (h.dimension == 2 && d.id[2] != 0) {
            return fail(format!(
                "id {:?} outside the {}D lattice [0, {side}]",
                d.id, h.dimension
            ));
        }
    }
    let diamond_count = diamonds.len() as u64;
    let in_table = |x: u32| x == NO_INDEX || (x as u64) < diamond_count;
    // Tets per diamond, and whether each tet was already claimed as a child.
    let mut members = vec![0u32; diamonds.len()];
    let mut is_child = vec![false; tets.len()];
    // Tets per `release_tets` call: the reader drops the pages of the tets checked, behind
    // this loop and behind the children it reads ahead (a level further on in a breadth-first
    // table: without this, up to a whole level of records stayed mapped, 25 MB on a
    // 50 M-triangle repository). A page released ahead of the loop is mapped again when the
    // loop reaches it.
    const TETS_PER_CALL: usize = (1 << 20) / super::format::TET_RECORD_SIZE;
    let mut children_read_from = 0;
    for (i, t) in tets.iter().enumerate() {
        if i % TETS_PER_CALL == 0 && i > 0 {
            release_tets(i - TETS_PER_CALL..i);
        }
        if t.first_child != NO_INDEX {
            let c = t.first_child as usize;
            if c >= children_read_from + TETS_PER_CALL {
                release_tets(children_read_from..c);
                children_read_from = c;
            }
        }
        let fail = |what: String| Err(corrupt(format!("tet {i}: {what}")));
        if !(finite(t.center) && t.radius.is_finite() && t.radius >= 0.0) {
            return fail(format!(
                "bounding sphere {:?} r {} is not finite",
                t.center, t.radius
            ));
        }
        if !(finite(t.cone_axis) && (-1.0..=1.0).contains(&t.cone_cos)) {
            return fail(format!(
                "normal cone {:?} cos {} is invalid",
                t.cone_axis, t.cone_cos
            ));
        }
        if !in_table(t.diamond) || !in_table(t.parent_diamond) {
            return fail(format!(
                "diamond {} / parent diamond {} not in the table of {diamond_count}",
                t.diamond, t.parent_diamond
            ));
        }
        let is_root = (i as u64) < h.root_tet_count;
        if is_root != (t.parent_diamond == NO_INDEX) {
            return fail(format!(
                "parent diamond {} but {} a root (roots are 0..{})",
                t.parent_diamond,
                if is_root { "is" } else { "is not" },
                h.root_tet_count
            ));
        }
        if (t.diamond == NO_INDEX) != (t.first_child == NO_INDEX) {
            return fail(format!(
                "diamond {} and first child {}: a tet is split iff it has a diamond",
                t.diamond, t.first_child
            ));
        }
        if t.diamond != NO_INDEX {
            let d = &diamonds[t.diamond as usize];
            if d.level != t.level {
                return fail(format!(
                    "level {} differs from its diamond's {}",
                    t.level, d.level
                ));
            }
            let created_by_a_parent = match t.parent_diamond {
                NO_INDEX => d.parent_count == 0,
                p => d.parents().contains(&p),
            };
            if !created_by_a_parent {
                return fail(format!(
                    "parent diamond {} is not a parent of its diamond {} (parents {:?})",
                    t.parent_diamond,
                    t.diamond,
                    d.parents()
                ));
            }
            members[t.diamond as usize] += 1;
        }
        if t.first_child != NO_INDEX {
            let c = t.first_child as usize;
            if c <= i || c as u64 + 1 >= tets.len() as u64 {
                return fail(format!(
                    "children {c}, {} not after it in the table of {}",
                    c as u64 + 1,
                    tets.len()
                ));
            }
            for k in [c, c + 1] {
                if std::mem::replace(&mut is_child[k], true) {
                    return fail(format!(
                        "child {k} is also another tet's child: the hierarchy must be a tree"
                    ));
                }
            }
            for child in &tets[c..c + 2] {
                if child.parent_diamond != t.diamond || Some(child.level) != t.level.checked_add(1)
                {
                    return fail(format!(
                        "child (parent diamond {}, level {}) does not come from its diamond {} at level {}",
                        child.parent_diamond, child.level, t.diamond, t.level
                    ));
                }
            }
        }
        if t.patch_offset & (TABLE_ALIGN - 1) != 0 {
            return fail(format!(
                "patch offset {} is not a multiple of 8",
                t.patch_offset
            ));
        }
        let end = t.patch_offset as u128 + t.patch_bytes as u128;
        if end > blobs.patches as u128 {
            return fail(format!(
                "patch range {}..{end} exceeds patch blob of {} bytes",
                t.patch_offset, blobs.patches
            ));
        }
        let expected = patch_bytes_checked(
            t.vertex_count as u64,
            t.strip_index_count as u64,
            h.attributes,
        );
        let stored_ok = match blobs.codec {
            PatchCodec::Raw => expected == Some(t.patch_bytes as u64),
            // Packed: any multiple of 8, but the decoded patch must have a size a u32 holds.
            PatchCodec::Packed | PatchCodec::PackedV1 | PatchCodec::Coded => {
                expected.is_some_and(|e| e <= MAX_PACKING_RATIO * t.patch_bytes as u64 + 256)
                    && t.patch_bytes % 8 == 0
            }
        };
        if !stored_ok {
            return fail(match blobs.codec {
                PatchCodec::Raw => format!(
                    "patch is {} bytes but {} vertices and {} strip indices take {expected:?}",
                    t.patch_bytes, t.vertex_count, t.strip_index_count
                ),
                PatchCodec::Packed | PatchCodec::PackedV1 | PatchCodec::Coded => format!(
                    "packed patch is {} bytes (not a multiple of 8), or {} vertices and {} \
                     strip indices decode to {expected:?} bytes (more than \
                     {MAX_PACKING_RATIO} × its size + 256)",
                    t.patch_bytes, t.vertex_count, t.strip_index_count
                ),
            });
        }
        let id_end = t.id_offset as u128 + t.id_bytes as u128;
        if id_end > blobs.ids as u128 {
            return fail(format!(
                "id range {}..{id_end} exceeds id blob of {} bytes",
                t.id_offset, blobs.ids
            ));
        }
        // Every id takes at least one byte: a cheap bound before the stream is decoded.
        if (t.id_bytes as u64) < t.vertex_count as u64 {
            return fail(format!(
                "{} ids cannot fit in an id stream of {} bytes",
                t.vertex_count, t.id_bytes
            ));
        }
        if t.triangle_count > t.strip_index_count.saturating_sub(2) {
            return fail(format!(
                "{} triangles cannot fit in {} strip indices",
                t.triangle_count, t.strip_index_count
            ));
        }
    }
    if let Some(i) = (h.root_tet_count as usize..tets.len()).find(|&i| !is_child[i]) {
        return Err(corrupt(format!(
            "tet {i} is neither a root nor any tet's child"
        )));
    }
    if let Some((i, d)) = diamonds
        .iter()
        .enumerate()
        .find(|&(i, d)| members[i] != d.tet_count as u32)
    {
        return Err(corrupt(format!(
            "diamond {i}: {} simplices, but {} tets belong to it",
            d.tet_count, members[i]
        )));
    }
    Ok(())
}
