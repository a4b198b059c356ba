//! Patch encoding: the triangles of one simplex, as a triangle strip with primitive restart over
//! a small local vertex array.
//!
//! A patch starts at a multiple of 8 inside the patch blob and holds, in this order (n =
//! `vertex_count`, m = `strip_index_count`):
//!
//! ```text
//! packed positions     [u32; 2] × n          (format::pack_position)
//! normals              [i16; 2] × n          if ATTR_NORMALS (format::oct_encode_normal)
//! colours              [u8; 4] × n           if ATTR_COLORS  (RGBA8)
//! texture coordinates  [f32; 2] × n          if ATTR_UVS
//! strip indices        u16 × m, restart 0xFFFF        if n ≤ 65,535
//!                      u32 × m, restart 0xFFFF_FFFF   otherwise
//! zero padding         to a multiple of 8
//! ```
//!
//! Every array starts 4-aligned, so a view borrows them straight from the memory map, and a
//! renderer can upload the patch blob as it is. The patch's global vertex ids live in the id
//! blob (`global_ids.rs`): only the CPU needs them.
//! The strip convention is meshoptimizer's (`meshopt_stripify` / `meshopt_unstripify`): the k-th
//! triangle since the last restart is (s[k], s[k+1], s[k+2]), with the first two swapped when k
//! is odd; triangles with two equal indices are degenerate (strip joints) and not drawn.
//! Every segment of three or more indices starts at an even strip position (the encoder
//! inserts a second restart marker where needed; `odd_segment_start` finds violations): strip
//! slot k = (s[k], s[k+1], s[k+2]) then has the winding parity of k itself, which is how the
//! renderer draws a strip as independent triangles without primitive restart.

use std::ops::Range;

use super::format::{
    align8, pack_position, unpack_position, TetRecord, ATTR_ALL, ATTR_COLORS, ATTR_NORMALS,
    ATTR_UVS, POSITION_MAX, TABLE_ALIGN,
};
use super::global_ids::{check_global_ids, encode_global_ids, GlobalIds};
use super::reader::RepositoryError;

/// Restart marker in `PatchData::strip` (narrowed to `RESTART_U16` in u16 patches).
pub const STRIP_RESTART: u32 = u32::MAX;
/// Restart marker of u16 strips.
pub const RESTART_U16: u16 = u16::MAX;
/// Restart marker of u32 strips.
pub const RESTART_U32: u32 = u32::MAX;
/// Largest vertex count whose strip is stored as u16 indices.
pub const MAX_U16_PATCH_VERTICES: usize = 65_535;

/// One patch before encoding (or after `PatchView::to_patch_data`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PatchData {
    /// Global id of each local vertex (what crack checks compare across patches).
    pub global_ids: Vec<u32>,
    /// Quantised positions on the global grid (`format::quantize_position`, each coordinate
    /// ≤ `POSITION_MAX`), one per vertex; stored packed (`format::pack_position`).
    pub positions: Vec<[u32; 3]>,
    /// Octahedral normals, one per vertex; `Some` iff the attribute mask has `ATTR_NORMALS`.
    pub normals: Option<Vec<[i16; 2]>>,
    /// RGBA8 colours, one per vertex; `Some` iff the mask has `ATTR_COLORS`.
    pub colors: Option<Vec<[u8; 4]>>,
    /// Texture coordinates, one per vertex; `Some` iff the mask has `ATTR_UVS`.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Strip of local indices (< vertex count), `STRIP_RESTART` = primitive restart.
    pub strip: Vec<u32>,
    /// Triangles the strip holds (statistics), at most `strip.len() − 2`.
    pub triangle_count: u32,
}

impl PatchData {
    /// Number of local vertices.
    pub fn vertex_count(&self) -> usize {
        self.global_ids.len()
    }

    /// The strip's non-degenerate triangles as local indices, in strip order, with their
    /// winding restored (same as `PatchView::triangles`).
    pub fn triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        StripTriangles::new(StripIndices::U32(&self.strip))
    }
}

/// Byte ranges of each array inside one patch.
#[derive(Clone, Debug)]
struct PatchLayout {
    positions: Range<usize>,
    normals: Option<Range<usize>>,
    colors: Option<Range<usize>>,
    uvs: Option<Range<usize>>,
    strip: Range<usize>,
    wide: bool,
    total: u64,
}

/// Layout of a patch, `None` if its size overflows (u64 or usize).
fn locate_arrays(
    vertex_count: u64,
    strip_index_count: u64,
    attributes: u32,
) -> Option<PatchLayout> {
    let wide = vertex_count > MAX_U16_PATCH_VERTICES as u64;
    let mut at = 0u64;
    // Next array of `count` items of `bytes_per` bytes, in file order.
    let mut take = |bytes_per: u64, count: u64| -> Option<Range<usize>> {
        let start = at;
        at = at.checked_add(bytes_per.checked_mul(count)?)?;
        Some(usize::try_from(start).ok()?..usize::try_from(at).ok()?)
    };
    let positions = take(8, vertex_count)?;
    let mut optional = |bit: u32, bytes_per: u64| match attributes & bit {
        0 => Some(None),
        _ => take(bytes_per, vertex_count).map(Some),
    };
    let normals = optional(ATTR_NORMALS, 4)?;
    let colors = optional(ATTR_COLORS, 4)?;
    let uvs = optional(ATTR_UVS, 8)?;
    let strip = take(if wide { 4 } else { 2 }, strip_index_count)?;
    let total = align8(at)?;
    usize::try_from(total).ok()?;
    Some(PatchLayout {
        positions,
        normals,
        colors,
        uvs,
        strip,
        wide,
        total,
    })
}

/// Exact encoded size of a patch with `vertex_count` vertices, `strip_index_count` strip indices
/// and the `attributes` mask (unknown bits ignored): a multiple of 8.
///
/// Per vertex: 8 bytes + 4 (normals) + 4 (colours) + 8 (uvs); per strip index: 2 bytes when
/// `vertex_count` ≤ 65,535, else 4. Panics if the size overflows `usize`.
pub fn patch_bytes(vertex_count: usize, strip_index_count: usize, attributes: u32) -> usize {
    patch_bytes_checked(vertex_count as u64, strip_index_count as u64, attributes)
        .and_then(|b| usize::try_from(b).ok())
        .expect("patch size overflows usize")
}

/// Size of `tet`'s patch as drawn (decoded, when the repository is packed): what a renderer
/// uploads for it. `u64::MAX` if the counts overflow (a record `Repository::open` refuses).
pub fn drawn_patch_bytes(tet: &TetRecord, attributes: u32) -> u64 {
    patch_bytes_checked(
        tet.vertex_count as u64,
        tet.strip_index_count as u64,
        attributes,
    )
    .unwrap_or(u64::MAX)
}

/// Byte offset of the strip from the start of a patch with `vertex_count` vertices and the
/// `attributes` mask: where a renderer points its index buffer. Panics on overflow.
pub fn strip_byte_offset(vertex_count: usize, attributes: u32) -> usize {
    locate_arrays(vertex_count as u64, 0, attributes)
        .expect("patch size overflows usize")
        .strip
        .start
}

/// `patch_bytes` for untrusted counts: `None` on overflow.
pub fn patch_bytes_checked(
    vertex_count: u64,
    strip_index_count: u64,
    attributes: u32,
) -> Option<u64> {
    locate_arrays(vertex_count, strip_index_count, attributes).map(|l| l.total)
}

/// Where `encode_patch` put a patch: the fields of its `TetRecord` that locate it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PatchPlacement {
    /// Offset of the patch in the patch blob (8-aligned).
    pub patch_offset: u64,
    /// Its size, `patch_bytes(..)`.
    pub patch_bytes: u32,
    /// Offset of its id stream in the id blob.
    pub id_offset: u64,
    /// Size of the id stream.
    pub id_bytes: u32,
}

/// Appends the encoding of `patch` to `patch_blob` and its global ids to `id_blob`, and says
/// where they went.
///
/// `patch_blob` is the patch blob being built (or an empty buffer): its length must be a
/// multiple of 8, and grows by exactly `patch_bytes(..)`; `id_blob` grows by at most
/// `vertex_count × global_ids::MAX_VARINT_BYTES`. Asserts that the patch is consistent:
/// - `attributes` has only `ATTR_*` bits, and each optional array is `Some` iff its bit is set;
/// - every per-vertex array has `global_ids.len()` entries, at most 2^32 − 2;
/// - every position coordinate is ≤ `POSITION_MAX`;
/// - every strip index is < vertex count or `STRIP_RESTART`; at most 2^32 − 1 of them;
/// - `triangle_count` ≤ `strip.len() − 2`.
pub fn encode_patch(
    patch: &PatchData,
    attributes: u32,
    patch_blob: &mut Vec<u8>,
    id_blob: &mut Vec<u8>,
) -> PatchPlacement {
    let out = patch_blob;
    let n = patch.vertex_count();
    assert!(
        attributes & !ATTR_ALL == 0,
        "unknown attribute bits {attributes:#x}"
    );
    assert!(
        out.len() & (TABLE_ALIGN as usize - 1) == 0,
        "patch would start at {}, not 8-aligned",
        out.len()
    );
    assert!(
        n < u32::MAX as usize,
        "{n} vertices exceed a patch's u32 count"
    );
    assert!(
        patch.strip.len() <= u32::MAX as usize,
        "{} strip indices exceed u32",
        patch.strip.len()
    );
    assert_eq!(patch.positions.len(), n, "positions vs global ids");
    if let Some(q) = patch
        .positions
        .iter()
        .find(|q| q.iter().any(|&c| c > POSITION_MAX))
    {
        panic!("quantised position {q:?} exceeds {POSITION_MAX}");
    }
    let check = |name: &str, bit: u32, len: Option<usize>| match len {
        Some(len) => {
            assert!(
                attributes & bit != 0,
                "{name} given but attribute bit {bit} is not set"
            );
            assert_eq!(len, n, "{name} vs global ids");
        }
        None => assert!(
            attributes & bit == 0,
            "attribute bit {bit} is set but {name} are missing"
        ),
    };
    check(
        "normals",
        ATTR_NORMALS,
        patch.normals.as_ref().map(Vec::len),
    );
    check("colors", ATTR_COLORS, patch.colors.as_ref().map(Vec::len));
    check("uvs", ATTR_UVS, patch.uvs.as_ref().map(Vec::len));
    if let Some(bad) = patch
        .strip
        .iter()
        .position(|&i| i != STRIP_RESTART && i as usize >= n)
    {
        panic!(
            "strip index {bad} is {} but the patch has {n} vertices",
            patch.strip[bad]
        );
    }
    assert!(
        patch.triangle_count as usize <= patch.strip.len().saturating_sub(2),
        "{} triangles cannot fit in {} strip indices",
        patch.triangle_count,
        patch.strip.len()
    );
    if let Some(k) = odd_segment_start(StripIndices::U32(&patch.strip)) {
        panic!("a strip segment starts at the odd position {k}");
    }

    let start = out.len();
    let size = patch_bytes(n, patch.strip.len(), attributes);
    out.reserve(size);
    out.extend(
        patch
            .positions
            .iter()
            .flat_map(|&q| pack_position(q))
            .flat_map(u32::to_le_bytes),
    );
    if let Some(v) = &patch.normals {
        out.extend_from_slice(bytemuck::cast_slice(v));
    }
    if let Some(v) = &patch.colors {
        out.extend_from_slice(bytemuck::cast_slice(v));
    }
    if let Some(v) = &patch.uvs {
        out.extend_from_slice(bytemuck::cast_slice(v));
    }
    if n > MAX_U16_PATCH_VERTICES {
        out.extend(patch.strip.iter().flat_map(|i| i.to_le_bytes()));
    } else {
        // Restart narrows to 0xFFFF; real indices are ≤ 65,534.
        out.extend(patch.strip.iter().flat_map(|&i| (i as u16).to_le_bytes()));
    }
    let written = out.len() - start;
    assert!(
        written <= size && size - written < 8,
        "encoded {written} bytes vs patch_bytes {size}"
    );
    out.resize(start + size, 0);
    let id_offset = id_blob.len() as u64;
    let id_bytes = encode_global_ids(&patch.global_ids, id_blob);
    PatchPlacement {
        patch_offset: start as u64,
        patch_bytes: u32::try_from(size).expect("a patch over 4 GiB"),
        id_offset,
        id_bytes: u32::try_from(id_bytes).expect("an id stream over 4 GiB"),
    }
}

use super::strip::StripTriangles;
pub use super::strip::{odd_segment_start, StripIndices};

/// Where patches live and what validating one needs from the header.
#[derive(Clone, Copy, Debug)]
pub struct PatchSource<'a> {
    /// The whole patch blob (every `TetRecord::patch_offset` is relative to its start).
    pub patch_blob: &'a [u8],
    /// The whole id blob (every `TetRecord::id_offset` is relative to its start).
    pub id_blob: &'a [u8],
    /// `Header::attributes`.
    pub attributes: u32,
    /// `Header::input_vertex_count`: every global id is below it.
    pub input_vertex_count: u64,
}

/// A validated, zero-copy view of one encoded patch.
#[derive(Clone, Copy, Debug)]
pub struct PatchView<'a> {
    bytes: &'a [u8],
    ids: &'a [u8],
    positions: &'a [[u32; 2]],
    normals: Option<&'a [[i16; 2]]>,
    colors: Option<&'a [[u8; 4]]>,
    uvs: Option<&'a [[f32; 2]]>,
    strip: StripIndices<'a>,
    triangle_count: u32,
}

fn corrupt(message: String) -> RepositoryError {
    RepositoryError::Corrupt(message)
}

/// Borrows `bytes[range]` as `[T]`, or says why it cannot (misaligned memory).
fn cast<'a, T: bytemuck::Pod>(
    bytes: &'a [u8],
    range: Range<usize>,
    what: &str,
) -> Result<&'a [T], RepositoryError> {
    bytemuck::try_cast_slice(&bytes[range.clone()]).map_err(|e| {
        corrupt(format!(
            "patch {what} at patch bytes {range:?} cannot be borrowed in place ({e:?}): the patch is not 8-aligned in memory"
        ))
    })
}

fn cast_optional<'a, T: bytemuck::Pod>(
    bytes: &'a [u8],
    range: Option<Range<usize>>,
    what: &str,
) -> Result<Option<&'a [T]>, RepositoryError> {
    range.map(|r| cast(bytes, r, what)).transpose()
}

impl<'a> PatchView<'a> {
    /// Validates and borrows the patch of `tet` and its global ids.
    ///
    /// Checks, without panicking on any input: the attribute mask, `patch_offset` 8-aligned,
    /// the range inside the patch blob, `patch_bytes` equal to `patch_bytes(..)`, memory
    /// alignment of the blob (an error, not a copy), zero padding, every strip index
    /// < `vertex_count` or restart, every segment starting at an even position,
    /// `triangle_count` ≤ `strip_index_count − 2`, the id range
    /// inside the id blob holding exactly `vertex_count` ids below `input_vertex_count`.
    /// Cost: one pass over the strip and one over the id stream.
    pub fn parse(
        source: &PatchSource<'a>,
        tet: &TetRecord,
    ) -> Result<PatchView<'a>, RepositoryError> {
        Self::parse_checked(source, tet, true)
    }

    /// `parse` with the passes over the strip and ids (`full`) or without them (a patch that
    /// passed `parse` before: what is left is O(1)).
    pub(crate) fn parse_checked(
        source: &PatchSource<'a>,
        tet: &TetRecord,
        full: bool,
    ) -> Result<PatchView<'a>, RepositoryError> {
        let (blob, attributes) = (source.patch_blob, source.attributes);
        if attributes & !ATTR_ALL != 0 {
            return Err(corrupt(format!("unknown attribute bits {attributes:#x}")));
        }
        let (n, m) = (tet.vertex_count, tet.strip_index_count);
        let layout = locate_arrays(n as u64, m as u64, attributes).ok_or_else(|| {
            corrupt(format!(
                "a patch of {n} vertices and {m} strip indices overflows"
            ))
        })?;
        if layout.total != tet.patch_bytes as u64 {
            return Err(corrupt(format!(
                "patch is {} bytes but {n} vertices and {m} strip indices with attributes {attributes:#x} take {}",
                tet.patch_bytes, layout.total
            )));
        }
        let start = tet.patch_offset;
        if start & (TABLE_ALIGN - 1) != 0 {
            return Err(corrupt(format!(
                "patch offset {start} is not a multiple of 8"
            )));
        }
        let end = start
            .checked_add(tet.patch_bytes as u64)
            .filter(|&e| e <= blob.len() as u64)
            .ok_or_else(|| {
                corrupt(format!(
                    "patch range {start}..{} exceeds patch blob of {} bytes",
                    start as u128 + tet.patch_bytes as u128,
                    blob.len()
                ))
            })?;
        // Both fit: end ≤ blob.len().
        let bytes = &blob[start as usize..end as usize];
        if full && bytes[layout.strip.end..].iter().any(|&b| b != 0) {
            return Err(corrupt("patch padding is not zero".to_string()));
        }
        let strip = if layout.wide {
            StripIndices::U32(cast(bytes, layout.strip.clone(), "strip")?)
        } else {
            StripIndices::U16(cast(bytes, layout.strip.clone(), "strip")?)
        };
        let out_of_range = |k: usize| strip.get(k).is_some_and(|i| i >= n);
        if let Some(k) = (0..strip.len()).filter(|_| full).find(|&k| out_of_range(k)) {
            return Err(corrupt(format!(
                "strip index {k} is {}, but the patch has {n} vertices",
                strip.get(k).unwrap_or_default()
            )));
        }
        if tet.triangle_count > m.saturating_sub(2) {
            return Err(corrupt(format!(
                "{} triangles cannot fit in {m} strip indices",
                tet.triangle_count
            )));
        }
        if let Some(k) = full.then(|| odd_segment_start(strip)).flatten() {
            return Err(corrupt(format!(
                "a strip segment starts at the odd position {k} (every segment must start at an \
                 even position; a repository built before this rule must be rebuilt)"
            )));
        }
        let ids = tet
            .id_offset
            .checked_add(tet.id_bytes as u64)
            .filter(|&e| e <= source.id_blob.len() as u64)
            // Both fit: end ≤ id_blob.len().
            .map(|end| &source.id_blob[tet.id_offset as usize..end as usize])
            .ok_or_else(|| {
                corrupt(format!(
                    "id range {}..{} exceeds id blob of {} bytes",
                    tet.id_offset,
                    tet.id_offset as u128 + tet.id_bytes as u128,
                    source.id_blob.len()
                ))
            })?;
        if full {
            check_global_ids(ids, n as u64, source.input_vertex_count).map_err(corrupt)?;
        }
        Ok(PatchView {
            bytes,
            ids,
            positions: cast(bytes, layout.positions.clone(), "positions")?,
            normals: cast_optional(bytes, layout.normals.clone(), "normals")?,
            colors: cast_optional(bytes, layout.colors.clone(), "colors")?,
            uvs: cast_optional(bytes, layout.uvs.clone(), "uvs")?,
            strip,
            triangle_count: tet.triangle_count,
        })
    }

    /// The encoded patch, padding included (what a renderer uploads).
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// Number of local vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Global id of each local vertex, decoded from the id stream.
    pub fn global_ids(&self) -> GlobalIds<'a> {
        GlobalIds::new(self.ids, self.positions.len())
    }

    /// The encoded id stream (`global_ids.rs`).
    pub fn id_stream(&self) -> &'a [u8] {
        self.ids
    }

    /// Packed quantised positions (`format::unpack_position`).
    pub fn packed_positions(&self) -> &'a [[u32; 2]] {
        self.positions
    }

    /// Quantised position of local vertex `i` (each coordinate ≤ `POSITION_MAX`). Panics if
    /// `i ≥ vertex_count()`.
    pub fn position(&self, i: usize) -> [u32; 3] {
        unpack_position(self.positions[i])
    }

    /// Octahedral normals, if the repository has them.
    pub fn normals(&self) -> Option<&'a [[i16; 2]]> {
        self.normals
    }

    /// RGBA8 colours, if the repository has them.
    pub fn colors(&self) -> Option<&'a [[u8; 4]]> {
        self.colors
    }

    /// Texture coordinates, if the repository has them.
    pub fn uvs(&self) -> Option<&'a [[f32; 2]]> {
        self.uvs
    }

    /// The strip as stored (u16 or u32).
    pub fn strip(&self) -> StripIndices<'a> {
        self.strip
    }

    /// Number of strip indices, restarts included.
    pub fn strip_index_count(&self) -> usize {
        self.strip.len()
    }

    /// Strip index `i` (a local vertex index), `None` for a restart. Panics if
    /// `i ≥ strip_index_count()`.
    pub fn strip_index(&self, i: usize) -> Option<u32> {
        self.strip.get(i)
    }

    /// The record's triangle count (statistics).
    pub fn triangle_count(&self) -> u32 {
        self.triangle_count
    }

    /// The strip's non-degenerate triangles as local indices with correct winding: the k-th
    /// triangle since the last restart has its first two vertices swapped when k is odd.
    pub fn triangles(&self) -> impl Iterator<Item = [u32; 3]> + 'a {
        StripTriangles::new(self.strip)
    }

    /// Copies the patch out (restarts widened to `STRIP_RESTART`).
    pub fn to_patch_data(&self) -> PatchData {
        PatchData {
            global_ids: self.global_ids().collect(),
            positions: self.positions.iter().map(|&p| unpack_position(p)).collect(),
            normals: self.normals.map(<[_]>::to_vec),
            colors: self.colors.map(<[_]>::to_vec),
            uvs: self.uvs.map(<[_]>::to_vec),
            strip: (0..self.strip.len())
                .map(|i| self.strip.get(i).unwrap_or(STRIP_RESTART))
                .collect(),
            triangle_count: self.triangle_count,
        }
    }
}

#[cfg(test)]
#[path = "patch_tests.rs"]
mod tests;
