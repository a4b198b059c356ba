//! Patch encoding: the triangles of one simplex, as a triangle strip with primitive restart over
//! a small local vertex array.
//!
//! A patch starts at a multiple of 8 inside the patch blob and holds, in this order (n =
//! `vertex_count`, m = `strip_index_count`):
//!
//! ```text
//! global vertex ids    u32 × n
//! position header      PositionHeader (16 bytes): base [u32; 3], position_encoding u32
//! positions            [u16; 3] × n, zero-padded to a multiple of 4   if position_encoding 0
//!                      [u32; 2] × n  (format::pack_position)          if position_encoding 1
//! normals              [i16; 2] × n          if ATTR_NORMALS (format::oct_encode_normal)
//! colours              [u8; 4] × n           if ATTR_COLORS  (RGBA8)
//! texture coordinates  [f32; 2] × n          if ATTR_UVS
//! strip indices        u16 × m, restart 0xFFFF        if n ≤ 65,535
//!                      u32 × m, restart 0xFFFF_FFFF   otherwise
//! zero padding         to a multiple of 8
//! ```
//!
//! Positions are quantised on the one global grid (`format::quantize_position`). The encoder
//! stores them as u16 offsets from `base`, the per-axis minimum over the patch, when every
//! offset fits in 16 bits, and as packed absolute 21-bit triples otherwise. Decoding is integer
//! arithmetic (q = base + offset), so a vertex shared by several patches decodes to the same
//! quantised position in each of them whatever their bases and encodings: crack-freeness
//! depends on it.
//!
//! Every array starts 4-aligned, so a view borrows them straight from the memory map.
//! The strip convention is meshoptimizer's (`meshopt_stripify` / `meshopt_unstripify`): the k-th
//! triangle since the last restart is (s[k], s[k+1], s[k+2]), with the first two swapped when k
//! is odd; triangles with two equal indices are degenerate (strip joints) and not drawn.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::format::{
    align8, pack_position, unpack_position, TetRecord, ATTR_ALL, ATTR_COLORS, ATTR_NORMALS,
    ATTR_UVS, POSITION_MAX, TABLE_ALIGN,
};
use super::reader::RepositoryError;

/// Restart marker in `PatchData::strip` (narrowed to `RESTART_U16` in u16 patches).
pub const STRIP_RESTART: u32 = u32::MAX;
/// Restart marker of u16 strips.
pub const RESTART_U16: u16 = u16::MAX;
/// Restart marker of u32 strips.
pub const RESTART_U32: u32 = u32::MAX;
/// Largest vertex count whose strip is stored as u16 indices.
pub const MAX_U16_PATCH_VERTICES: usize = 65_535;
/// Size of the position header on disk, in bytes.
pub const POSITION_HEADER_SIZE: usize = std::mem::size_of::<PositionHeader>();

/// How a patch stores its positions: the `PositionHeader::position_encoding` word.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum PositionEncoding {
    /// Word 0: `[u16; 3]` per vertex, the offset q − base on each axis; the array is
    /// zero-padded to a multiple of 4 bytes (2 bytes when n is odd).
    Offsets16 = 0,
    /// Word 1: `[u32; 2]` per vertex, the absolute q packed by `format::pack_position`.
    PackedAbsolute = 1,
}

impl PositionEncoding {
    /// The encoding a `position_encoding` word names: bit 0 selects it, bits 1..32 are reserved
    /// and must be 0 (`None` otherwise).
    pub fn from_word(word: u32) -> Option<PositionEncoding> {
        match word {
            0 => Some(PositionEncoding::Offsets16),
            1 => Some(PositionEncoding::PackedAbsolute),
            _ => None,
        }
    }

    /// Bytes the position array of `vertex_count` vertices takes, padding included (`None` on
    /// overflow).
    fn array_bytes(self, vertex_count: u64) -> Option<u64> {
        match self {
            PositionEncoding::Offsets16 => {
                vertex_count.checked_mul(6)?.checked_add(3).map(|b| b & !3)
            }
            PositionEncoding::PackedAbsolute => vertex_count.checked_mul(8),
        }
    }

    /// The header the encoder writes for `positions` (each coordinate ≤ `POSITION_MAX`): base =
    /// per-axis minimum (0 for an empty patch), u16 offsets when every q − base fits in 16 bits,
    /// packed absolute positions otherwise.
    pub fn choose(positions: &[[u32; 3]]) -> PositionHeader {
        let mut lo = [u32::MAX; 3];
        let mut hi = [0u32; 3];
        for q in positions {
            for a in 0..3 {
                lo[a] = lo[a].min(q[a]);
                hi[a] = hi[a].max(q[a]);
            }
        }
        if positions.is_empty() {
            lo = [0; 3];
        }
        let fits = (0..3).all(|a| hi[a].saturating_sub(lo[a]) <= u16::MAX as u32);
        PositionHeader {
            base: lo,
            position_encoding: if fits {
                PositionEncoding::Offsets16
            } else {
                PositionEncoding::PackedAbsolute
            } as u32,
        }
    }
}

/// The 16 bytes after a patch's global ids.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct PositionHeader {
    /// 3 × u32, the per-axis minimum quantised position over the patch's vertices (each
    /// ≤ `POSITION_MAX`; 0 for an empty patch). Offsets16 positions are relative to it; the
    /// encoder writes it for both encodings.
    pub base: [u32; 3],
    /// u32, `PositionEncoding`: bit 0 = 0 for u16 offsets from `base`, 1 for packed absolute
    /// u32 pairs; bits 1..32 reserved, must be 0.
    pub position_encoding: u32,
}

/// Reads the position header of the patch `bytes` (the patch's own range) with `vertex_count`
/// vertices, checking that it lies inside the patch and that the encoding is known. The error
/// is a message without the tet's name.
pub(crate) fn read_position_header(
    bytes: &[u8],
    vertex_count: u64,
) -> Result<(PositionHeader, PositionEncoding), String> {
    let start = vertex_count.checked_mul(4);
    let end = start.and_then(|s| s.checked_add(POSITION_HEADER_SIZE as u64));
    let (Some(start), Some(end)) = (start, end) else {
        return Err(format!("a patch of {vertex_count} vertices overflows"));
    };
    if end > bytes.len() as u64 {
        return Err(format!(
            "patch is {} bytes but {vertex_count} global ids and the position header take {end}",
            bytes.len()
        ));
    }
    // end ≤ bytes.len(), so both fit in usize.
    let header: PositionHeader = bytemuck::pod_read_unaligned(&bytes[start as usize..end as usize]);
    let encoding = PositionEncoding::from_word(header.position_encoding).ok_or_else(|| {
        format!(
            "position encoding word {:#x} is not 0 (u16 offsets) or 1 (packed absolute)",
            header.position_encoding
        )
    })?;
    if let Some(a) = (0..3).find(|&a| header.base[a] > POSITION_MAX) {
        return Err(format!(
            "position base {:?} exceeds {POSITION_MAX} on axis {a}",
            header.base
        ));
    }
    Ok((header, encoding))
}

/// One patch before encoding (or after `PatchView::to_patch_data`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PatchData {
    /// Global id of each local vertex (what crack checks compare across patches).
    pub global_ids: Vec<u32>,
    /// Quantised positions on the global grid (`format::quantize_position`, each coordinate
    /// ≤ `POSITION_MAX`), one per vertex; `encode_patch` chooses how to store them.
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

    /// The position encoding `encode_patch` uses for this patch.
    pub fn position_encoding(&self) -> PositionEncoding {
        let word = PositionEncoding::choose(&self.positions).position_encoding;
        PositionEncoding::from_word(word).expect("choose returns a known encoding")
    }

    /// Exact size of `encode_patch(self, attributes, ..)`'s output, in bytes.
    pub fn encoded_bytes(&self, attributes: u32) -> usize {
        patch_bytes(
            self.vertex_count(),
            self.strip.len(),
            attributes,
            self.position_encoding(),
        )
    }
}

/// Byte ranges of each array inside one patch.
#[derive(Clone, Debug)]
struct PatchLayout {
    global_ids: Range<usize>,
    positions: Range<usize>,
    /// Zero padding after u16 positions (empty otherwise).
    position_padding: Range<usize>,
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
    encoding: PositionEncoding,
) -> Option<PatchLayout> {
    let wide = vertex_count > MAX_U16_PATCH_VERTICES as u64;
    let mut at = 0u64;
    // Next array of `count` items of `bytes_per` bytes, in file order.
    let mut take = |bytes_per: u64, count: u64| -> Option<Range<usize>> {
        let start = at;
        at = at.checked_add(bytes_per.checked_mul(count)?)?;
        Some(usize::try_from(start).ok()?..usize::try_from(at).ok()?)
    };
    let global_ids = take(4, vertex_count)?;
    take(POSITION_HEADER_SIZE as u64, 1)?;
    let (positions, position_padding) = match encoding {
        PositionEncoding::Offsets16 => {
            let positions = take(6, vertex_count)?;
            let padded = encoding.array_bytes(vertex_count)?;
            let padding = take(1, padded - 6 * vertex_count)?;
            (positions, padding)
        }
        PositionEncoding::PackedAbsolute => {
            let positions = take(8, vertex_count)?;
            (positions.clone(), positions.end..positions.end)
        }
    };
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
        global_ids,
        positions,
        position_padding,
        normals,
        colors,
        uvs,
        strip,
        wide,
        total,
    })
}

/// Exact encoded size of a patch with `vertex_count` vertices, `strip_index_count` strip indices,
/// the `attributes` mask (unknown bits ignored) and position `encoding`: a multiple of 8.
///
/// 16 bytes of position header; per vertex: 4 bytes (global id) + 6 (u16 offsets, the array
/// padded to a multiple of 4) or 8 (packed absolute) + 4 (normals) + 4 (colours) + 8 (uvs); per
/// strip index: 2 bytes when `vertex_count` ≤ 65,535, else 4. Panics if the size overflows
/// `usize`.
pub fn patch_bytes(
    vertex_count: usize,
    strip_index_count: usize,
    attributes: u32,
    encoding: PositionEncoding,
) -> usize {
    patch_bytes_checked(
        vertex_count as u64,
        strip_index_count as u64,
        attributes,
        encoding,
    )
    .and_then(|b| usize::try_from(b).ok())
    .expect("patch size overflows usize")
}

/// An upper bound on the encoded size of any patch with these counts, whatever its positions:
/// `patch_bytes` with the larger, packed absolute encoding (for reserving buffers). Panics if
/// the size overflows `usize`.
pub fn patch_bytes_bound(vertex_count: usize, strip_index_count: usize, attributes: u32) -> usize {
    patch_bytes(
        vertex_count,
        strip_index_count,
        attributes,
        PositionEncoding::PackedAbsolute,
    )
}

/// `patch_bytes` for untrusted counts: `None` on overflow.
pub fn patch_bytes_checked(
    vertex_count: u64,
    strip_index_count: u64,
    attributes: u32,
    encoding: PositionEncoding,
) -> Option<u64> {
    locate_arrays(vertex_count, strip_index_count, attributes, encoding).map(|l| l.total)
}

/// Appends the encoding of `patch` to `out` and returns the offset it starts at.
///
/// `out` is the patch blob being built (or an empty buffer): its length must be a multiple of
/// 8, and grows by exactly `patch.encoded_bytes(attributes)` (≤ `patch_bytes_bound(..)`). The
/// position encoding is `PositionEncoding::choose(&patch.positions)`. Asserts that the patch is
/// consistent:
/// - `attributes` has only `ATTR_*` bits, and each optional array is `Some` iff its bit is set;
/// - every per-vertex array has `global_ids.len()` entries, at most 2^32 − 2;
/// - every position coordinate is ≤ `POSITION_MAX`;
/// - every strip index is < vertex count or `STRIP_RESTART`; at most 2^32 − 1 of them;
/// - `triangle_count` ≤ `strip.len() − 2`.
pub fn encode_patch(patch: &PatchData, attributes: u32, out: &mut Vec<u8>) -> u64 {
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

    let header = PositionEncoding::choose(&patch.positions);
    let encoding = PositionEncoding::from_word(header.position_encoding).expect("a known encoding");
    let start = out.len();
    let size = patch_bytes(n, patch.strip.len(), attributes, encoding);
    out.reserve(size);
    out.extend_from_slice(bytemuck::cast_slice(&patch.global_ids));
    out.extend_from_slice(bytemuck::bytes_of(&header));
    match encoding {
        PositionEncoding::Offsets16 => {
            let base = header.base;
            out.extend(
                patch
                    .positions
                    .iter()
                    .flat_map(|q| {
                        // Fits: choose checked every q − base ≤ u16::MAX.
                        [0, 1, 2].map(|a| ((q[a] - base[a]) as u16).to_le_bytes())
                    })
                    .flatten(),
            );
            if n % 2 == 1 {
                out.extend_from_slice(&[0; 2]);
            }
        }
        PositionEncoding::PackedAbsolute => {
            out.extend(
                patch
                    .positions
                    .iter()
                    .flat_map(|&q| bytemuck::cast::<[u32; 2], [u8; 8]>(pack_position(q))),
            );
        }
    }
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
    start as u64
}

/// The positions of a patch, as stored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Positions<'a> {
    /// q = base + offset on each axis (`PositionEncoding::Offsets16`).
    Offsets16 {
        /// The patch's `PositionHeader::base`.
        base: [u32; 3],
        /// One offset triple per vertex.
        offsets: &'a [[u16; 3]],
    },
    /// `format::pack_position` of q (`PositionEncoding::PackedAbsolute`).
    PackedAbsolute(&'a [[u32; 2]]),
}

impl Positions<'_> {
    /// Number of vertices.
    pub fn len(&self) -> usize {
        match self {
            Positions::Offsets16 { offsets, .. } => offsets.len(),
            Positions::PackedAbsolute(p) => p.len(),
        }
    }

    /// True when there are no vertices.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Quantised position of vertex `i`. Panics if `i ≥ len()`.
    pub fn get(&self, i: usize) -> [u32; 3] {
        match self {
            Positions::Offsets16 { base, offsets } => {
                let o = offsets[i];
                [0, 1, 2].map(|a| base[a] + o[a] as u32)
            }
            Positions::PackedAbsolute(p) => unpack_position(p[i]),
        }
    }

    /// The encoding.
    pub fn encoding(&self) -> PositionEncoding {
        match self {
            Positions::Offsets16 { .. } => PositionEncoding::Offsets16,
            Positions::PackedAbsolute(_) => PositionEncoding::PackedAbsolute,
        }
    }

    /// The raw little-endian bytes of the array, without padding (for a vertex buffer upload).
    pub fn as_bytes(&self) -> &[u8] {
        match self {
            Positions::Offsets16 { offsets, .. } => bytemuck::cast_slice(offsets),
            Positions::PackedAbsolute(p) => bytemuck::cast_slice(p),
        }
    }
}
/// The strip indices of a patch, as stored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StripIndices<'a> {
    /// Restart `RESTART_U16`; patches of ≤ 65,535 vertices.
    U16(&'a [u16]),
    /// Restart `RESTART_U32`; larger patches.
    U32(&'a [u32]),
}

impl StripIndices<'_> {
    /// Number of indices, restarts included.
    pub fn len(&self) -> usize {
        match self {
            StripIndices::U16(s) => s.len(),
            StripIndices::U32(s) => s.len(),
        }
    }

    /// True when there are no indices.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Index `i` widened to u32, `None` for a restart. Panics if `i ≥ len()`.
    pub fn get(&self, i: usize) -> Option<u32> {
        match self {
            StripIndices::U16(s) => (s[i] != RESTART_U16).then_some(s[i] as u32),
            StripIndices::U32(s) => (s[i] != RESTART_U32).then_some(s[i]),
        }
    }

    /// The raw little-endian bytes (for an index buffer upload).
    pub fn as_bytes(&self) -> &[u8] {
        match self {
            StripIndices::U16(s) => bytemuck::cast_slice(s),
            StripIndices::U32(s) => bytemuck::cast_slice(s),
        }
    }
}

/// Decodes a strip into triangles (meshoptimizer's `unstripify`).
struct StripTriangles<'a> {
    strip: StripIndices<'a>,
    next: usize,
    /// Indices seen since the last restart; its parity is the triangle's.
    run: usize,
    prev: [u32; 2],
}

impl<'a> StripTriangles<'a> {
    fn new(strip: StripIndices<'a>) -> Self {
        StripTriangles {
            strip,
            next: 0,
            run: 0,
            prev: [0; 2],
        }
    }
}

impl Iterator for StripTriangles<'_> {
    type Item = [u32; 3];

    fn next(&mut self) -> Option<[u32; 3]> {
        while self.next < self.strip.len() {
            let index = self.strip.get(self.next);
            self.next += 1;
            let Some(c) = index else {
                self.run = 0;
                continue;
            };
            let [mut a, mut b] = self.prev;
            let complete = self.run >= 2;
            if self.run & 1 == 1 {
                std::mem::swap(&mut a, &mut b);
            }
            self.prev = [self.prev[1], c];
            self.run += 1;
            if complete && a != b && b != c && a != c {
                return Some([a, b, c]);
            }
        }
        None
    }
}

/// A validated, zero-copy view of one encoded patch.
#[derive(Clone, Copy, Debug)]
pub struct PatchView<'a> {
    bytes: &'a [u8],
    global_ids: &'a [u32],
    position_header: PositionHeader,
    positions: Positions<'a>,
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
    /// Validates and borrows the patch of `tet` inside `blob` (the whole patch blob).
    ///
    /// Checks, without panicking on any input: the attribute mask, `patch_offset` 8-aligned,
    /// the range inside `blob`, the position header inside the patch with a known encoding
    /// word (reserved bits 0) and a base ≤ `POSITION_MAX`, `patch_bytes` equal to
    /// `patch_bytes(.., encoding)`, memory alignment of `blob` (an error, not a copy), zero
    /// padding, every decoded position ≤ `POSITION_MAX`, every strip index < `vertex_count` or
    /// restart, `triangle_count` ≤ `strip_index_count − 2`. Cost: one pass over the strip (and
    /// over the u16 offsets of a patch whose base lies within 65,535 of `POSITION_MAX`).
    pub fn parse(
        blob: &'a [u8],
        tet: &TetRecord,
        attributes: u32,
    ) -> Result<PatchView<'a>, RepositoryError> {
        if attributes & !ATTR_ALL != 0 {
            return Err(corrupt(format!("unknown attribute bits {attributes:#x}")));
        }
        let (n, m) = (tet.vertex_count, tet.strip_index_count);
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
        let (position_header, encoding) = read_position_header(bytes, n as u64).map_err(corrupt)?;
        let layout = locate_arrays(n as u64, m as u64, attributes, encoding).ok_or_else(|| {
            corrupt(format!(
                "a patch of {n} vertices and {m} strip indices overflows"
            ))
        })?;
        if layout.total != tet.patch_bytes as u64 {
            return Err(corrupt(format!(
                "patch is {} bytes but {n} vertices and {m} strip indices with attributes {attributes:#x} and position encoding {encoding:?} take {}",
                tet.patch_bytes, layout.total
            )));
        }
        if bytes[layout.strip.end..].iter().any(|&b| b != 0)
            || bytes[layout.position_padding.clone()]
                .iter()
                .any(|&b| b != 0)
        {
            return Err(corrupt("patch padding is not zero".to_string()));
        }
        let positions = match encoding {
            PositionEncoding::Offsets16 => Positions::Offsets16 {
                base: position_header.base,
                offsets: cast(bytes, layout.positions.clone(), "positions")?,
            },
            PositionEncoding::PackedAbsolute => {
                Positions::PackedAbsolute(cast(bytes, layout.positions.clone(), "positions")?)
            }
        };
        if let Positions::Offsets16 { base, offsets } = positions {
            // base ≤ POSITION_MAX was checked, so only an axis within 65,535 of the top can
            // overflow: scan the offsets only then.
            let room = base.map(|b| POSITION_MAX - b);
            if room.iter().any(|&r| r < u16::MAX as u32) {
                if let Some(i) = offsets
                    .iter()
                    .position(|o| (0..3).any(|a| o[a] as u32 > room[a]))
                {
                    return Err(corrupt(format!(
                        "position {i}: base {base:?} + offset {:?} exceeds {POSITION_MAX}",
                        offsets[i]
                    )));
                }
            }
        }
        let strip = if layout.wide {
            StripIndices::U32(cast(bytes, layout.strip.clone(), "strip")?)
        } else {
            StripIndices::U16(cast(bytes, layout.strip.clone(), "strip")?)
        };
        if let Some(k) = (0..strip.len()).find(|&k| strip.get(k).is_some_and(|i| i >= n)) {
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
        Ok(PatchView {
            bytes,
            global_ids: cast(bytes, layout.global_ids.clone(), "global ids")?,
            position_header,
            positions,
            normals: cast_optional(bytes, layout.normals.clone(), "normals")?,
            colors: cast_optional(bytes, layout.colors.clone(), "colors")?,
            uvs: cast_optional(bytes, layout.uvs.clone(), "uvs")?,
            strip,
            triangle_count: tet.triangle_count,
        })
    }

    /// The encoded patch, padding included.
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// Number of local vertices.
    pub fn vertex_count(&self) -> usize {
        self.global_ids.len()
    }

    /// Global id of each local vertex.
    pub fn global_ids(&self) -> &'a [u32] {
        self.global_ids
    }

    /// The position header (base and encoding word).
    pub fn position_header(&self) -> PositionHeader {
        self.position_header
    }

    /// How the positions are stored.
    pub fn position_encoding(&self) -> PositionEncoding {
        self.positions.encoding()
    }

    /// The positions as stored (u16 offsets from the base, or packed absolute).
    pub fn positions(&self) -> Positions<'a> {
        self.positions
    }

    /// Quantised position of local vertex `i` on the global grid (each coordinate
    /// ≤ `POSITION_MAX`), the same for either encoding. Panics if `i ≥ vertex_count()`.
    pub fn position(&self, i: usize) -> [u32; 3] {
        self.positions.get(i)
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

    /// Copies the patch out (positions decoded, restarts widened to `STRIP_RESTART`).
    pub fn to_patch_data(&self) -> PatchData {
        PatchData {
            global_ids: self.global_ids.to_vec(),
            positions: (0..self.positions.len())
                .map(|i| self.positions.get(i))
                .collect(),
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
mod tests {
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
        let strip: Vec<u32> = (0..n as u32)
            .chain([R])
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

    fn record(patch: &PatchData, attributes: u32, offset: u64) -> TetRecord {
        TetRecord {
            patch_offset: offset,
            patch_bytes: patch.encoded_bytes(attributes) as u32,
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

    #[test]
    fn encode_parse_round_trip() {
        for attributes in 0..=ATTR_ALL {
            for n in [0, 1, 3, 5, 65_535, 65_536, 70_000] {
                let patch = sample(n, attributes);
                let mut blob = vec![0u8; 8];
                let offset = encode_patch(&patch, attributes, &mut blob);
                assert_eq!(offset, 8);
                let tet = record(&patch, attributes, offset);
                assert_eq!(blob.len() as u64, 8 + tet.patch_bytes as u64);
                let words = aligned(&blob);
                let bytes = &bytemuck::cast_slice::<u64, u8>(&words)[..blob.len()];
                let view = PatchView::parse(bytes, &tet, attributes).unwrap();
                assert_eq!(view.to_patch_data(), patch);
                assert_eq!(matches!(view.strip(), StripIndices::U32(_)), n > 65_535);
                // x spans n − 1 grid steps: u16 offsets up to 65,536 vertices.
                let encoding = if n <= 65_536 {
                    PositionEncoding::Offsets16
                } else {
                    PositionEncoding::PackedAbsolute
                };
                assert_eq!(view.position_encoding(), encoding, "n = {n}");
                assert_eq!(patch.position_encoding(), encoding);
                assert!(
                    tet.patch_bytes as usize <= patch_bytes_bound(n, patch.strip.len(), attributes)
                );
                assert_eq!(
                    view.triangles().collect::<Vec<_>>(),
                    patch.triangles().collect::<Vec<_>>()
                );
                if n > 0 {
                    assert_eq!(
                        view.position(n - 1),
                        [(n as u32 - 1) % 2_000_000, 3, (n as u32 - 1) % 5]
                    );
                }
            }
        }
    }

    #[test]
    fn sizes_are_exact() {
        use PositionEncoding::{Offsets16 as O, PackedAbsolute as A};
        // An empty patch is its position header.
        assert_eq!(patch_bytes(0, 0, 0, O), 16);
        assert_eq!(patch_bytes(0, 0, ATTR_ALL, A), 16);
        assert_eq!(patch_bytes(1, 1, 0, O), 32); // 4 + 16 + 6 (+ 2 pad) + 2 = 30 → 32
        assert_eq!(patch_bytes(1, 1, 0, A), 32); // 4 + 16 + 8 + 2 = 30 → 32
        assert_eq!(patch_bytes(2, 1, 0, O), 40); // 8 + 16 + 12 + 2 = 38 → 40
        assert_eq!(patch_bytes(2, 1, 0, A), 48); // 8 + 16 + 16 + 2 = 42 → 48
        assert_eq!(patch_bytes(3, 4, ATTR_ALL, O), 104); // 12 + 16 + 20 + 48 + 8
        assert_eq!(patch_bytes(3, 4, ATTR_ALL, A), 112); // 12 + 16 + 24 + 48 + 8 = 108 → 112
        assert_eq!(patch_bytes_bound(3, 4, ATTR_ALL), 112);
        assert_eq!(patch_bytes(65_536, 3, 0, O), 65_536 * 10 + 32);
        assert_eq!(patch_bytes(65_536, 3, 0, A), 65_536 * 12 + 32);
        let big = u32::MAX as u64;
        assert_eq!(
            patch_bytes_checked(big, big, ATTR_ALL, A),
            Some(8 * ((big * 32 + 16).div_ceil(8)))
        );
        assert_eq!(
            patch_bytes_checked(big, big, ATTR_ALL, O),
            Some(8 * ((big * 24 + 16 + (6 * big).next_multiple_of(4)).div_ceil(8)))
        );
        for encoding in [O, A] {
            assert_eq!(patch_bytes_checked(u64::MAX, 1, 0, encoding), None);
            assert_eq!(patch_bytes_checked(u64::MAX / 6, 1, 0, encoding), None);
        }
        for n in 0..9 {
            for attributes in 0..=ATTR_ALL {
                let o = patch_bytes(n, 5, attributes, O);
                assert!(o.is_multiple_of(8) && o <= patch_bytes(n, 5, attributes, A));
            }
        }
    }

    #[test]
    fn encoding_is_chosen_by_the_offset_range() {
        let header = |positions: &[[u32; 3]]| PositionEncoding::choose(positions);
        assert_eq!(
            header(&[]),
            PositionHeader {
                base: [0; 3],
                position_encoding: 0
            }
        );
        let near = [[100, 200_000, 7], [100 + 65_535, 200_001, 7]];
        assert_eq!(
            header(&near),
            PositionHeader {
                base: [100, 200_000, 7],
                position_encoding: 0
            }
        );
        let far = [[100, 200_000, 7], [100 + 65_536, 200_001, 7]];
        assert_eq!(
            header(&far),
            PositionHeader {
                base: [100, 200_000, 7],
                position_encoding: 1
            }
        );
        let top = [[POSITION_MAX; 3], [POSITION_MAX - 65_535, POSITION_MAX, 0]];
        assert_eq!(header(&top).position_encoding, 1);
        assert_eq!(
            PositionEncoding::from_word(0),
            Some(PositionEncoding::Offsets16)
        );
        assert_eq!(
            PositionEncoding::from_word(1),
            Some(PositionEncoding::PackedAbsolute)
        );
        for word in [2, 3, 0x100, 0x8000_0000, u32::MAX] {
            assert_eq!(PositionEncoding::from_word(word), None);
        }
    }

    /// Both encodings decode every position exactly, at the corners of the grid too.
    #[test]
    fn positions_decode_exactly_in_both_encodings() {
        let cases: [&[[u32; 3]]; 4] = [
            &[[0, 0, 0], [65_535, 65_535, 65_535], [1, 2, 3]],
            &[
                [POSITION_MAX; 3],
                [POSITION_MAX - 65_535, POSITION_MAX - 1, POSITION_MAX],
                [POSITION_MAX - 7, POSITION_MAX - 65_535, POSITION_MAX - 2],
            ],
            &[[0, 0, 0], [POSITION_MAX; 3]],
            &[[12_345, 0, POSITION_MAX], [12_345 + 65_536, 3, 4]],
        ];
        for (k, positions) in cases.into_iter().enumerate() {
            let n = positions.len();
            let patch = PatchData {
                global_ids: (0..n as u32).collect(),
                positions: positions.to_vec(),
                strip: (0..n as u32).collect(),
                triangle_count: n.saturating_sub(2) as u32,
                ..PatchData::default()
            };
            let mut blob = Vec::new();
            encode_patch(&patch, 0, &mut blob);
            let tet = record(&patch, 0, 0);
            assert_eq!(blob.len(), tet.patch_bytes as usize);
            let words = aligned(&blob);
            let bytes = &bytemuck::cast_slice::<u64, u8>(&words)[..blob.len()];
            let view = PatchView::parse(bytes, &tet, 0).unwrap();
            let expected = if k < 2 {
                PositionEncoding::Offsets16
            } else {
                PositionEncoding::PackedAbsolute
            };
            assert_eq!(view.position_encoding(), expected, "case {k}");
            assert_eq!(view.positions().len(), n);
            for (i, &q) in positions.iter().enumerate() {
                assert_eq!(view.position(i), q, "case {k} vertex {i}");
            }
            assert_eq!(view.to_patch_data(), patch);
        }
    }

    #[test]
    #[should_panic(expected = "exceeds 2097151")]
    fn encode_asserts_position_range() {
        let mut patch = sample(3, 0);
        patch.positions[1][2] = POSITION_MAX + 1;
        encode_patch(&patch, 0, &mut Vec::new());
    }

    #[test]
    fn parse_rejects_bad_patches_without_panicking() {
        let attributes = ATTR_NORMALS;
        let patch = sample(5, attributes);
        let mut blob = Vec::new();
        encode_patch(&patch, attributes, &mut blob);
        let good = record(&patch, attributes, 0);
        let words = aligned(&blob);
        let bytes = &bytemuck::cast_slice::<u64, u8>(&words)[..blob.len()];
        let check = |tet: TetRecord, bytes: &[u8], attributes: u32, expected: &str| {
            let err = PatchView::parse(bytes, &tet, attributes)
                .unwrap_err()
                .to_string();
            assert!(
                err.contains(expected),
                "{err:?} should mention {expected:?}"
            );
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
        let longer: Vec<u8> = bytes.iter().copied().chain([0; 8]).collect();
        let longer_words = aligned(&longer);
        check(
            TetRecord {
                patch_bytes: good.patch_bytes + 8,
                ..good
            },
            &bytemuck::cast_slice::<u64, u8>(&longer_words)[..longer.len()],
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
        // Byte edits of the good patch: 5 ids (20 bytes), position header at 20..36, u16
        // offsets at 36..66, 2 bytes of padding, normals at 68..88, 9 strip indices at 88..106.
        assert_eq!(good.patch_bytes, 112);
        let edited = |at: usize, value: &[u8], expected: &str| {
            let mut bad = bytes.to_vec();
            bad[at..at + value.len()].copy_from_slice(value);
            let words = aligned(&bad);
            check(
                good,
                &bytemuck::cast_slice::<u64, u8>(&words)[..bad.len()],
                attributes,
                expected,
            );
        };
        // Strip index 5 of a 5-vertex patch.
        edited(88, &5u16.to_le_bytes(), "strip index 0 is 5");
        // The position header: unknown encodings and reserved bits, a size that does not
        // match the encoding, a base off the grid, offsets that overflow it.
        for word in [2u32, 3, 0x100, 0x8000_0000, u32::MAX] {
            edited(32, &word.to_le_bytes(), "position encoding word");
        }
        edited(32, &1u32.to_le_bytes(), "take");
        edited(24, &(POSITION_MAX + 1).to_le_bytes(), "position base");
        // x offsets are 0..=4: base 2^21 − 4 puts vertex 4 at 2^21.
        edited(20, &(POSITION_MAX - 3).to_le_bytes(), "position 4: base");
        let mut top = bytes.to_vec();
        top[20..24].copy_from_slice(&(POSITION_MAX - 4).to_le_bytes());
        let words = aligned(&top);
        let view = PatchView::parse(
            &bytemuck::cast_slice::<u64, u8>(&words)[..top.len()],
            &good,
            attributes,
        )
        .unwrap();
        assert_eq!(view.position(4), [POSITION_MAX, 3, 4]);
        edited(66, &[0, 1], "padding is not zero");
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
        encode_patch(&patch, 0, &mut Vec::new());
    }

    #[test]
    #[should_panic(expected = "normals are missing")]
    fn encode_asserts_attributes() {
        encode_patch(&sample(3, 0), ATTR_NORMALS, &mut Vec::new());
    }
}
