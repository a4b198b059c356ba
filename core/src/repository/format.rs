//! The on-disk layout of a repository (format version 4): a header, a section table, then the
//! sections it lists.
//!
//! ```text
//! offset 0             Header (200 bytes; `section_count` entries follow it)
//! offset 200           SectionEntry × section_count                 (32 bytes each)
//! then, 8-aligned, in any order the table gives (this writer: in this order):
//!   SECTION_DIAMONDS   DiamondRecord × diamond_count                (56 bytes each)
//!   SECTION_TETS       TetRecord × tet_count                        (88 bytes each)
//!   SECTION_PATCHES    patch blob                                   (see `patch.rs`)
//!     or SECTION_PACKED_STRIPS, the same patches packed             (see `packed.rs`)
//!     or SECTION_PACKED_PATCHES, packed with the older strip coding (read, not written)
//!     or SECTION_CODED_STRIPS, the same patches entropy-coded                (see `coded.rs`)
//!   SECTION_IDS        id blob                                      (see `global_ids.rs`)
//!   SECTION_ATTRIBUTE_ERRORS, optional: 16 bytes a diamond     (see `attribute_errors.rs`)
//!   SECTION_TEXTURES, optional: tables, then the texture pages   (see `textures.rs`)
//! end of file        = the end of the last section
//! ```
//!
//! The header and the section table are the *directory's* entry; the diamond and tet tables
//! are the directory. Opening a repository reads and checks those and nothing else (O(header +
//! directory)); the blobs are verified piece by piece when first read, so a viewer of a huge
//! model never touches the patches it does not draw:
//! - `Header::checksum`: CRC-32 of the header (this field read as 0) and the section table;
//! - `SectionEntry::checksum`: CRC-32 of the section's bytes for the diamond and tet tables
//!   (checked on open) and the id blob (checked the first time an id is read); 0 and unused for
//!   the patch blob, whose patches carry their own checksum (`TetRecord::patch_checksum`,
//!   checked the first time the patch is read), so one bad patch costs only that patch.
//!
//! The section table is the format's extension point: a later version adds a section kind; a
//! section with `SECTION_FLAG_OPTIONAL` may be skipped by a reader that does not know its kind,
//! any other unknown kind is refused ("made by a newer tessera").
//!
//! The patch blob is what a renderer uploads (positions, attributes, strips); the id blob holds
//! each patch's global vertex ids, which only the CPU needs (crack checks). A repository holds
//! its patches either as they are drawn (`SECTION_PATCHES`, `build --no-compress`) or packed
//! (`SECTION_PACKED_STRIPS`, the default since commit 4fa9fc2 of 2026-12-03;
//! `SECTION_PACKED_PATCHES` before it, whose strips meshoptimizer's index-sequence codec packs): then each `TetRecord`'s `patch_offset`,
//! `patch_bytes` and `patch_checksum` describe the packed bytes, and the loader decodes them
//! into the drawn layout, whose size the record's counts give (`patch::patch_bytes`). A
//! tessera that predates packing refuses such a file as "made by a newer tessera" (an unknown
//! required section), and every tessera since reads both.
//!
//! Everything is little-endian and read zero-copy (bytemuck casts from the memory map), so the
//! records are `#[repr(C)]` with no implicit padding. Gaps between sections are zero bytes
//! written by the writer; the reader only requires sections to be 8-aligned and not to overlap.
//!
//! Positions are quantised on one global grid of 2^21 steps per axis over the bounding box, so a
//! vertex shared by several patches decodes to bit-identical coordinates in each of them
//! (`pack_position`: 63 bits in two u32 words, decoded with integer arithmetic).

use bytemuck::{Pod, Zeroable};

#[cfg(target_endian = "big")]
compile_error!(
    "the repository format is little-endian and read zero-copy: big-endian hosts are not supported"
);

/// First 8 bytes of every repository file.
pub const MAGIC: [u8; 8] = *b"TESSERA\0";

/// Version written by this build and the only one it reads (`RepositoryError::WrongVersion`
/// otherwise). Bump on any change to the layout or meaning of a field.
pub const FORMAT_VERSION: u32 = 4;

/// "No such record": unused diamond parent slots, leaf tets' `diamond` and `first_child`, root
/// tets' `parent_diamond`.
pub const NO_INDEX: u32 = u32::MAX;

/// Bits per axis of a quantised position.
pub const POSITION_BITS: u32 = 21;

/// Largest quantised coordinate, 2^21 − 1 = 2,097,151.
pub const POSITION_MAX: u32 = (1 << POSITION_BITS) - 1;

/// Attribute bit: per-vertex normal, octahedral encoding, 2 × i16 snorm (4 bytes).
pub const ATTR_NORMALS: u32 = 1;
/// Attribute bit: per-vertex colour, RGBA8 (4 bytes).
pub const ATTR_COLORS: u32 = 2;
/// Attribute bit: per-vertex texture coordinate, 2 × f32 (8 bytes).
pub const ATTR_UVS: u32 = 4;
/// Every attribute bit this version knows; a file with any other bit set is rejected.
pub const ATTR_ALL: u32 = ATTR_NORMALS | ATTR_COLORS | ATTR_UVS;

/// Section kind: the diamond table (`DiamondRecord`s).
pub const SECTION_DIAMONDS: u32 = 1;
/// Section kind: the tet table (`TetRecord`s).
pub const SECTION_TETS: u32 = 2;
/// Section kind: the patch blob.
pub const SECTION_PATCHES: u32 = 3;
/// Section kind: the global-id blob.
pub const SECTION_IDS: u32 = 4;
/// Section kind: the patch blob with every patch packed (`packed.rs`), strips by
/// meshoptimizer's index-sequence codec (`PatchCodec::PackedV1`: written before commit 4fa9fc2
/// of 2026-12-03, still read). A repository has exactly one patch blob.
pub const SECTION_PACKED_PATCHES: u32 = 5;
/// Section kind: the patch blob with every patch packed (`packed.rs`), strips by
/// `strip_codec.rs` (`PatchCodec::Packed`, the default).
pub const SECTION_PACKED_STRIPS: u32 = 6;
/// Section kind: the patch blob with every patch entropy-coded (`coded.rs`: positions
/// predicted along the strip, rANS; `PatchCodec::Coded`, the default since issue 49).
pub const SECTION_CODED_STRIPS: u32 = 7;
/// Section kind: the attribute error table (`attribute_errors.rs`), one
/// `AttributeErrorRecord` a diamond in table order, always with `SECTION_FLAG_OPTIONAL`;
/// written only for an input with colours or texture coordinates.
pub const SECTION_ATTRIBUTE_ERRORS: u32 = 8;
/// Section kind: the textures (`textures.rs`): their shapes, the bands of `v` naming them and
/// their pages (`tessera_core::texture`), always with `SECTION_FLAG_OPTIONAL`; written only
/// for an input with textures.
pub const SECTION_TEXTURES: u32 = 9;
/// The kinds of a patch blob: a repository has exactly one of them.
pub const PATCH_SECTIONS: [u32; 4] = [
    SECTION_PATCHES,
    SECTION_PACKED_PATCHES,
    SECTION_PACKED_STRIPS,
    SECTION_CODED_STRIPS,
];
/// The kinds every version-4 repository has, exactly once each, besides its one patch blob
/// (`SECTION_PATCHES` or `SECTION_PACKED_PATCHES`).
pub const REQUIRED_SECTIONS: [u32; 3] = [SECTION_DIAMONDS, SECTION_TETS, SECTION_IDS];
/// Sections a repository's writer lays out: the required ones and the patch blob.
pub const WRITTEN_SECTIONS: usize = REQUIRED_SECTIONS.len() + 1;

pub use super::attribute_errors::{AttributeErrorRecord, ATTRIBUTE_ERROR_RECORD_SIZE};
pub use super::patch_codec::PatchCodec;

/// Section flag: a reader that does not know the section's kind may ignore it.
pub const SECTION_FLAG_OPTIONAL: u32 = 1;
/// Every section flag this version knows.
pub const SECTION_FLAGS_ALL: u32 = SECTION_FLAG_OPTIONAL;
/// Most sections a file may list (bounds the work of opening a crafted file).
pub const MAX_SECTIONS: u32 = 64;

/// Size of the header on disk, in bytes.
pub const HEADER_SIZE: usize = std::mem::size_of::<Header>();
/// Size of one section table entry on disk, in bytes.
pub const SECTION_ENTRY_SIZE: usize = std::mem::size_of::<SectionEntry>();
/// Size of one diamond record on disk, in bytes.
pub const DIAMOND_RECORD_SIZE: usize = std::mem::size_of::<DiamondRecord>();
/// Size of one tet record on disk, in bytes.
pub const TET_RECORD_SIZE: usize = std::mem::size_of::<TetRecord>();
/// Byte offset of `Header::checksum` in the file.
pub const CHECKSUM_OFFSET: usize = std::mem::offset_of!(Header, checksum);
/// Alignment of the sections and of every patch inside the patch blob.
pub const TABLE_ALIGN: u64 = 8;

/// Fixed-size file header. Little-endian on disk, at offset 0; the section table follows it.
///
/// The writer fills `magic`, `version`, `section_count`, the diamond and tet counts and
/// `checksum`; the caller fills the rest.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Header {
    /// `MAGIC`, the bytes `b"TESSERA\0"`.
    pub magic: [u8; 8],
    /// u32, `FORMAT_VERSION`.
    pub version: u32,
    /// u32, 2 (height field: LEB triangles) or 3 (arbitrary mesh: LEB tetrahedra).
    pub dimension: u32,
    /// u32 bit mask of the per-vertex attributes stored in every patch (`ATTR_*`); only the
    /// attributes the input has.
    pub attributes: u32,
    /// u32, entries in the section table that follows the header, `4..=MAX_SECTIONS`.
    pub section_count: u32,
    /// u64, number of `DiamondRecord`s (diamonds the hierarchy splits).
    pub diamond_count: u64,
    /// u64, number of `TetRecord`s (simplices of the hierarchy), < 2^32.
    pub tet_count: u64,
    /// u64, roots are tets `0..root_tet_count` (≤ `tet_count`).
    pub root_tet_count: u64,
    /// u64, vertices of the input mesh; every global id is below it, ≤ 2^32.
    pub input_vertex_count: u64,
    /// u64, triangles of the input mesh (statistics).
    pub input_triangle_count: u64,
    /// 3 × f64, model-space point that every f32 centre in the tables is relative to.
    pub origin: [f64; 3],
    /// 3 × f64, model-space bounding box minimum (finite); quantised position 0.
    pub bbox_min: [f64; 3],
    /// 3 × f64, model-space bounding box maximum (finite, ≥ `bbox_min`).
    pub bbox_max: [f64; 3],
    /// 3 × f64, model units per quantisation step: `(bbox_max − bbox_min) / (2^21 − 1)` per
    /// axis, 0 on a flat axis. Position = `bbox_min + q × position_step`.
    pub position_step: [f64; 3],
    /// 3 × f64, model-space position of lattice point 0.
    pub lattice_origin: [f64; 3],
    /// f64, model units per lattice unit (finite, > 0).
    pub lattice_unit: f64,
    /// u32, the lattice cube has side 2^lattice_bits lattice units; 1..=30.
    pub lattice_bits: u32,
    /// u32, CRC-32 of the header (this field read as 0) followed by the section table
    /// (`compute_checksum`).
    pub checksum: u32,
}

/// One entry of the section table: where a section lies and how to verify it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct SectionEntry {
    /// u32, `SECTION_*`; each kind at most once.
    pub kind: u32,
    /// u32, `SECTION_FLAG_*` bits.
    pub flags: u32,
    /// u64, byte offset from the start of the file; multiple of 8, after the section table.
    pub offset: u64,
    /// u64, length in bytes; for a table, exactly its count × its record size.
    pub bytes: u64,
    /// u32, CRC-32 of the section's bytes (0 for the patch blob: per-patch checksums).
    pub checksum: u32,
    /// u32, must be 0.
    pub reserved: u32,
}

/// One diamond that the hierarchy splits. Leaf diamonds are not stored; their error is 0.
///
/// The error and sphere are saturated over the diamond DAG: a diamond's error is at least
/// each child's and its sphere contains each child's, so the cut rule is monotone.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct DiamondRecord {
    /// 3 × f32, centre of the saturated bounding sphere, relative to `Header::origin`.
    pub center: [f32; 3],
    /// f32, radius of the saturated bounding sphere, model units (finite, ≥ 0).
    pub radius: f32,
    /// f32, saturated object-space error, model units (finite, > 0).
    pub error: f32,
    /// 4 × u32, indices into the diamond table of the diamonds whose split creates this one's
    /// simplices; slots `parent_count..4` hold `NO_INDEX`.
    pub parents: [u32; 4],
    /// u8, number of used `parents` slots, 0..=4 (0 for the root diamond).
    pub parent_count: u8,
    /// u8, number of simplices in the diamond.
    pub tet_count: u8,
    /// u8, `level % dimension`: the shape class of the diamond (3D: 0 = cube diagonal,
    /// 1 = face diagonal, 2 = axis edge).
    pub phase: u8,
    /// u8, must be 0.
    pub pad: u8,
    /// u32, LEB level of the diamond's simplices.
    pub level: u32,
    /// 3 × i32, lattice midpoint of the split edge, in `[0, 2^lattice_bits]` per axis; z = 0
    /// in 2D.
    pub id: [i32; 3],
}

/// One simplex of the hierarchy: a tetrahedron in 3D, a triangle in 2D, with its patch.
///
/// Drawn iff ρ(diamond) ≤ τ < ρ(parent_diamond), with ρ = 0 when diamond = `NO_INDEX` (leaf)
/// and ρ = ∞ when parent_diamond = `NO_INDEX` (root).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TetRecord {
    /// 3 × f32, centre of the bounding sphere of this simplex's patch, relative to
    /// `Header::origin`.
    pub center: [f32; 3],
    /// f32, radius of that sphere, model units (finite, ≥ 0).
    pub radius: f32,
    /// 3 × f32, normal cone axis (unit, or anything when `cone_cos` = −1).
    pub cone_axis: [f32; 3],
    /// f32 in [−1, 1]: every triangle normal n has dot(n, cone_axis) ≥ cone_cos; −1 means no
    /// back-face culling is possible.
    pub cone_cos: f32,
    /// u32, the diamond this simplex belongs to (whose split replaces it by its children), or
    /// `NO_INDEX` for a leaf.
    pub diamond: u32,
    /// u32, the diamond whose split created this simplex, or `NO_INDEX` for a root (and only
    /// for roots).
    pub parent_diamond: u32,
    /// u32, `NO_INDEX` for leaves (exactly when `diamond` is `NO_INDEX`); otherwise the two
    /// children are tets `first_child` and `first_child + 1`, stored after this one.
    pub first_child: u32,
    /// u32, LEB level (roots 0; children one more than their parent; equals the diamond's).
    pub level: u32,
    /// u64, byte offset of the patch from the start of the patch blob; multiple of 8.
    pub patch_offset: u64,
    /// u32, size of the stored patch in bytes: exactly
    /// `patch_bytes(vertex_count, strip_index_count, attributes)` in a `SECTION_PATCHES` blob,
    /// the packed size (a multiple of 8) in a `SECTION_PACKED_PATCHES` one.
    pub patch_bytes: u32,
    /// u32, vertices in the patch; ≤ 65,535 means u16 strip indices, more means u32.
    pub vertex_count: u32,
    /// u32, strip indices in the patch, restart markers included.
    pub strip_index_count: u32,
    /// u32, triangles the builder put in the patch (statistics; at most
    /// `strip_index_count − 2`). `PatchView::triangles` yields the non-degenerate ones.
    pub triangle_count: u32,
    /// u64, byte offset of the patch's global vertex ids from the start of the id blob.
    pub id_offset: u64,
    /// u32, size of the id stream: exactly `vertex_count` canonical varints (`global_ids.rs`).
    pub id_bytes: u32,
    /// u32, CRC-32 of the patch's `patch_bytes` stored bytes at `patch_offset` (padding
    /// included; `patch_checksum`; the packed bytes when packed), checked the first time the
    /// patch is read.
    pub patch_checksum: u32,
}

const _: () = assert!(HEADER_SIZE == 200 && HEADER_SIZE & 7 == 0);
const _: () = assert!(SECTION_ENTRY_SIZE == 32);
const _: () = assert!(DIAMOND_RECORD_SIZE == 56);
const _: () = assert!(TET_RECORD_SIZE == 88);
const _: () = assert!(CHECKSUM_OFFSET == 196);

impl Header {
    /// A header with `magic` and `version` set and every other field zero.
    pub fn new(dimension: u32, attributes: u32) -> Header {
        Header {
            magic: MAGIC,
            version: FORMAT_VERSION,
            dimension,
            attributes,
            ..Zeroable::zeroed()
        }
    }
}

impl DiamondRecord {
    /// The used parent slots.
    pub fn parents(&self) -> &[u32] {
        &self.parents[..(self.parent_count as usize).min(4)]
    }
}

impl TetRecord {
    /// True for a simplex the hierarchy does not split (ρ(diamond) = 0).
    pub fn is_leaf(&self) -> bool {
        self.first_child == NO_INDEX
    }

    /// True for a root simplex (ρ(parent_diamond) = ∞).
    pub fn is_root(&self) -> bool {
        self.parent_diamond == NO_INDEX
    }
}

/// Rounds `x` up to the next multiple of 8 (`None` on overflow).
pub fn align8(x: u64) -> Option<u64> {
    x.checked_add(TABLE_ALIGN - 1)
        .map(|v| v & !(TABLE_ALIGN - 1))
}

/// CRC-32 of `bytes` with the 4 bytes at `CHECKSUM_OFFSET` read as zero: the value
/// `Header::checksum` must hold when `bytes` is the header followed by the section table.
/// Inputs shorter than the header are hashed as they are.
pub fn compute_checksum(bytes: &[u8]) -> u32 {
    let mut hasher = crc32fast::Hasher::new();
    if bytes.len() < CHECKSUM_OFFSET + 4 {
        hasher.update(bytes);
    } else {
        hasher.update(&bytes[..CHECKSUM_OFFSET]);
        hasher.update(&[0; 4]);
        hasher.update(&bytes[CHECKSUM_OFFSET + 4..]);
    }
    hasher.finalize()
}

/// The value `TetRecord::patch_checksum` holds for a patch's bytes.
pub fn patch_checksum(patch_bytes: &[u8]) -> u32 {
    crc32fast::hash(patch_bytes)
}

/// A short name of a section kind, for messages.
pub fn section_name(kind: u32) -> String {
    match kind {
        SECTION_DIAMONDS => "diamond table".into(),
        SECTION_TETS => "tet table".into(),
        SECTION_PATCHES => "patch blob".into(),
        SECTION_PACKED_PATCHES => "packed patch blob (v1)".into(),
        SECTION_PACKED_STRIPS => "packed patch blob".into(),
        SECTION_CODED_STRIPS => "coded patch blob".into(),
        SECTION_IDS => "id blob".into(),
        SECTION_ATTRIBUTE_ERRORS => "attribute error table".into(),
        SECTION_TEXTURES => "texture section".into(),
        other => format!("section kind {other}"),
    }
}

/// Model units per quantisation step on each axis: `(bbox_max − bbox_min) / (2^21 − 1)`, 0 on a
/// flat (or inverted) axis.
pub fn position_step(bbox_min: [f64; 3], bbox_max: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| {
        let extent = bbox_max[i] - bbox_min[i];
        if extent > 0.0 {
            extent / POSITION_MAX as f64
        } else {
            0.0
        }
    })
}

/// Quantises a model-space position to the global grid: `q = round((p − bbox_min) / step)`
/// clamped to `[0, 2^21 − 1]` per axis; 0 on an axis whose step is 0 (flat) or for NaN input.
pub fn quantize_position(p: [f64; 3], bbox_min: [f64; 3], step: [f64; 3]) -> [u32; 3] {
    [0, 1, 2].map(|i| {
        if step[i] > 0.0 {
            // `as` saturates and maps NaN to 0.
            ((p[i] - bbox_min[i]) / step[i])
                .round()
                .clamp(0.0, POSITION_MAX as f64) as u32
        } else {
            0
        }
    })
}

/// Model-space position of a quantised one: `bbox_min + q × step`.
pub fn dequantize_position(q: [u32; 3], bbox_min: [f64; 3], step: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| bbox_min[i] + q[i] as f64 * step[i])
}

/// Packs a quantised position into 63 bits of a u64 (x in bits 0..21, y in 21..42, z in 42..63,
/// bit 63 zero), stored as `[lo, hi]` u32s.
///
/// Each coordinate must be ≤ `POSITION_MAX` (2,097,151).
pub fn pack_position(q: [u32; 3]) -> [u32; 2] {
    assert!(
        q.iter().all(|&c| c <= POSITION_MAX),
        "quantised position {q:?} exceeds {POSITION_MAX}"
    );
    let v = q[0] as u64 | (q[1] as u64) << POSITION_BITS | (q[2] as u64) << (2 * POSITION_BITS);
    [v as u32, (v >> 32) as u32]
}

/// Inverse of `pack_position`; bit 63 is ignored, so every input decodes to an in-range point.
pub fn unpack_position(packed: [u32; 2]) -> [u32; 3] {
    let v = packed[0] as u64 | (packed[1] as u64) << 32;
    let mask = POSITION_MAX as u64;
    [
        (v & mask) as u32,
        (v >> POSITION_BITS & mask) as u32,
        (v >> (2 * POSITION_BITS) & mask) as u32,
    ]
}

// The normals' octahedral encoding lives in `normal_encoding.rs`; its names stay here too.
pub use super::normal_encoding::{
    normal_grid_max_angle, oct_decode_normal, oct_encode_normal, oct_encode_normal_grid,
    NORMAL_GRID_STEPS,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pack_round_trip() {
        for q in [
            [0, 0, 0],
            [POSITION_MAX; 3],
            [1, 2, 3],
            [POSITION_MAX, 0, 12345],
            [7, POSITION_MAX, 0],
        ] {
            let p = pack_position(q);
            assert_eq!(unpack_position(p), q);
            assert_eq!(p[1] >> 31, 0, "bit 63 stays clear");
        }
        assert_eq!(pack_position([1, 0, 0]), [1, 0]);
        assert_eq!(pack_position([0, 1, 0]), [1 << 21, 0]);
        assert_eq!(pack_position([0, 0, 1]), [0, 1 << 10]);
    }

    #[test]
    #[should_panic(expected = "exceeds")]
    fn pack_rejects_out_of_range() {
        pack_position([POSITION_MAX + 1, 0, 0]);
    }

    #[test]
    fn quantize_clamps_and_rounds() {
        let min = [-1.0, 0.0, 5.0];
        let step = position_step(min, [1.0, 0.0, 6.0]);
        assert_eq!(step[1], 0.0);
        assert_eq!(quantize_position([-1.0, 3.0, 5.0], min, step), [0, 0, 0]);
        assert_eq!(
            quantize_position([1.0, 0.0, 6.0], min, step),
            [POSITION_MAX, 0, POSITION_MAX]
        );
        assert_eq!(
            quantize_position([9.0, 0.0, -9.0], min, step),
            [POSITION_MAX, 0, 0]
        );
        assert_eq!(quantize_position([f64::NAN; 3], min, step), [0, 0, 0]);
        let p = [0.123456, 0.0, 5.5];
        let back = dequantize_position(quantize_position(p, min, step), min, step);
        for i in 0..3 {
            assert!((back[i] - p[i]).abs() <= 0.5 * step[i] + 1e-12);
        }
    }

    #[test]
    fn oct_round_trip() {
        let mut worst = 0.0f64;
        for i in 0..2000 {
            // Fibonacci sphere.
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 2000.0;
            let r = (1.0 - z * z).sqrt();
            let phi = i as f32 * 2.399_963;
            let n = [r * phi.cos(), r * phi.sin(), z];
            let d = oct_decode_normal(oct_encode_normal(n));
            // atan2(|n × d|, n · d) in f64: acos of an f32 dot is too coarse near 0.
            let (n, d) = (n.map(f64::from), d.map(f64::from));
            let cross = [
                n[1] * d[2] - n[2] * d[1],
                n[2] * d[0] - n[0] * d[2],
                n[0] * d[1] - n[1] * d[0],
            ];
            let sin = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
            worst = worst.max(sin.atan2(n[0] * d[0] + n[1] * d[1] + n[2] * d[2]));
        }
        assert!(worst < 1e-4, "worst angular error {worst}");
        for n in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
        ] {
            let d = oct_decode_normal(oct_encode_normal(n));
            for i in 0..3 {
                assert!((d[i] - n[i]).abs() < 1e-4, "{n:?} -> {d:?}");
            }
        }
        assert_eq!(oct_encode_normal([0.0; 3]), [0, 0]);
        assert_eq!(oct_encode_normal([f32::NAN, 0.0, 1.0]), [0, 0]);
        for e in [
            [i16::MIN, i16::MIN],
            [i16::MAX, i16::MIN],
            [0, i16::MIN],
            [123, -4567],
        ] {
            let d = oct_decode_normal(e);
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            assert!((l - 1.0).abs() < 1e-5 && d.iter().all(|x| x.is_finite()));
        }
    }

    #[test]
    fn checksum_ignores_its_own_field() {
        let mut bytes = vec![7u8; HEADER_SIZE + 10];
        let a = compute_checksum(&bytes);
        bytes[CHECKSUM_OFFSET..CHECKSUM_OFFSET + 4].copy_from_slice(&a.to_le_bytes());
        assert_eq!(compute_checksum(&bytes), a);
        bytes[HEADER_SIZE + 3] ^= 1;
        assert_ne!(compute_checksum(&bytes), a);
        assert_eq!(compute_checksum(&[1, 2, 3]), crc32fast::hash(&[1, 2, 3]));
    }
}
