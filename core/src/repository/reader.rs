//! The validated reader: memory-maps a repository and checks every count, offset, index and
//! float before handing out zero-copy views of its tables and patches.
//!
//! A bad file is an error, never a panic or an out-of-bounds read: the header is checked first
//! (size, magic, version, dimension, attribute bits, table ranges with checked arithmetic,
//! alignment, order), then the checksum, then every record. Patch strips are checked when a
//! patch is parsed (`Repository::patch`), or all at once by `Repository::validate_patches`.

use std::fs::File;
use std::ops::Range;
use std::path::{Path, PathBuf};

use memmap2::Mmap;

use super::format::{
    compute_checksum, DiamondRecord, Header, TetRecord, ATTR_ALL, DIAMOND_RECORD_SIZE,
    FORMAT_VERSION, HEADER_SIZE, MAGIC, NO_INDEX, TABLE_ALIGN, TET_RECORD_SIZE,
};
use super::patch::{patch_bytes_checked, PatchSource, PatchView};

/// Why a repository cannot be read or written.
#[derive(Debug, thiserror::Error)]
pub enum RepositoryError {
    /// The file system refused (open, map, write, rename).
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Shorter than the header.
    #[error("file is {len} bytes, smaller than the {HEADER_SIZE}-byte repository header")]
    TooSmall { len: u64 },
    /// Not a repository at all.
    #[error("not a tessera repository: magic is {found:?}, expected {MAGIC:?}")]
    BadMagic { found: [u8; 8] },
    /// A repository of another format version.
    #[error(
        "repository format version {found} is not supported: this build reads version {expected}"
    )]
    WrongVersion { found: u32, expected: u32 },
    /// The bytes changed since the file was written.
    #[error("checksum mismatch: header says {stored:#010x}, contents hash to {computed:#010x}")]
    ChecksumMismatch { stored: u32, computed: u32 },
    /// Structurally invalid (the message names the record and the problem).
    #[error("corrupt repository: {0}")]
    Corrupt(String),
    /// `Repository::patch` called with an index past the tet table.
    #[error("tet {index} does not exist: the repository has {count} tets")]
    NoSuchTet { index: usize, count: usize },
}

fn corrupt(message: String) -> RepositoryError {
    RepositoryError::Corrupt(message)
}

/// The bytes behind a repository, 8-aligned at their start.
enum Storage {
    /// A memory-mapped file (page-aligned).
    Mapped(Mmap),
    /// An in-memory image; `u64` words guarantee the alignment a `Vec<u8>` does not.
    Owned { words: Vec<u64>, len: usize },
}

impl Storage {
    fn bytes(&self) -> &[u8] {
        match self {
            Storage::Mapped(map) => map,
            Storage::Owned { words, len } => &bytemuck::cast_slice(words)[..*len],
        }
    }
}

/// An open, validated repository.
pub struct Repository {
    storage: Storage,
    header: Header,
    diamonds: Range<usize>,
    tets: Range<usize>,
    patch_blob: Range<usize>,
    id_blob: Range<usize>,
}

impl std::fmt::Debug for Repository {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Repository")
            .field("header", &self.header)
            .finish_non_exhaustive()
    }
}

impl Repository {
    /// Memory-maps and validates the repository at `path` (header, checksum, every record).
    ///
    /// Cost: one CRC-32 pass over the file plus one pass over the tables; patches are checked
    /// lazily by `patch`. The file must not be modified while the repository is open (the map
    /// would change under the validated views).
    pub fn open(path: impl AsRef<Path>) -> Result<Repository, RepositoryError> {
        let path = path.as_ref();
        let io = |source| RepositoryError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = File::open(path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        if len < HEADER_SIZE as u64 {
            return Err(RepositoryError::TooSmall { len });
        }
        // SAFETY: the map is read-only and every view into it is validated first; the contract
        // above asks callers not to modify the file while it is open.
        let map = unsafe { Mmap::map(&file) }.map_err(io)?;
        Self::validate(Storage::Mapped(map))
    }

    /// Validates an in-memory image with the same checks as `open` (copies it once to get
    /// 8-byte alignment).
    pub fn from_bytes(bytes: Vec<u8>) -> Result<Repository, RepositoryError> {
        let mut words = vec![0u64; bytes.len().div_ceil(8)];
        bytemuck::cast_slice_mut::<u64, u8>(&mut words)[..bytes.len()].copy_from_slice(&bytes);
        Self::validate(Storage::Owned {
            words,
            len: bytes.len(),
        })
    }

    fn validate(storage: Storage) -> Result<Repository, RepositoryError> {
        let bytes = storage.bytes();
        let layout = check_layout(bytes)?;
        let diamonds: &[DiamondRecord] = bytemuck::try_cast_slice(&bytes[layout.diamonds.clone()])
            .map_err(|e| corrupt(format!("diamond table cannot be borrowed in place: {e:?}")))?;
        let tets: &[TetRecord] = bytemuck::try_cast_slice(&bytes[layout.tets.clone()])
            .map_err(|e| corrupt(format!("tet table cannot be borrowed in place: {e:?}")))?;
        check_tables(&layout.header, diamonds, tets)?;
        Ok(Repository {
            header: layout.header,
            diamonds: layout.diamonds,
            tets: layout.tets,
            patch_blob: layout.patch_blob,
            id_blob: layout.id_blob,
            storage,
        })
    }

    /// The header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The diamond table, borrowed from the file.
    pub fn diamonds(&self) -> &[DiamondRecord] {
        // Size and alignment were checked by `validate`.
        bytemuck::cast_slice(&self.storage.bytes()[self.diamonds.clone()])
    }

    /// The tet table, borrowed from the file.
    pub fn tets(&self) -> &[TetRecord] {
        bytemuck::cast_slice(&self.storage.bytes()[self.tets.clone()])
    }

    /// The whole patch blob (every `TetRecord::patch_offset` is relative to its start).
    pub fn patch_blob(&self) -> &[u8] {
        &self.storage.bytes()[self.patch_blob.clone()]
    }

    /// The whole id blob (every `TetRecord::id_offset` is relative to its start).
    pub fn id_blob(&self) -> &[u8] {
        &self.storage.bytes()[self.id_blob.clone()]
    }

    /// Parses and validates the patch of tet `tet_index` (one pass over its strip and one over
    /// its id stream).
    pub fn patch(&self, tet_index: usize) -> Result<PatchView<'_>, RepositoryError> {
        let tets = self.tets();
        let tet = tets.get(tet_index).ok_or(RepositoryError::NoSuchTet {
            index: tet_index,
            count: tets.len(),
        })?;
        let source = PatchSource {
            patch_blob: self.patch_blob(),
            id_blob: self.id_blob(),
            attributes: self.header.attributes,
            input_vertex_count: self.header.input_vertex_count,
        };
        PatchView::parse(&source, tet).map_err(|e| match e {
            RepositoryError::Corrupt(message) => corrupt(format!("tet {tet_index}: {message}")),
            other => other,
        })
    }

    /// Parses every patch: after this, `patch` cannot fail. Cost: one pass over both blobs.
    pub fn validate_patches(&self) -> Result<(), RepositoryError> {
        (0..self.tets().len()).try_for_each(|i| self.patch(i).map(drop))
    }

    /// Size of the file in bytes.
    pub fn file_bytes(&self) -> u64 {
        self.storage.bytes().len() as u64
    }
}

/// Where the tables lie in a file whose header was checked.
struct Layout {
    header: Header,
    diamonds: Range<usize>,
    tets: Range<usize>,
    patch_blob: Range<usize>,
    id_blob: Range<usize>,
}

/// Checks the header and the table ranges of `bytes`, then the checksum.
fn check_layout(bytes: &[u8]) -> Result<Layout, RepositoryError> {
    let len = bytes.len() as u64;
    if bytes.len() < HEADER_SIZE {
        return Err(RepositoryError::TooSmall { len });
    }
    let header: Header = bytemuck::pod_read_unaligned(&bytes[..HEADER_SIZE]);
    if header.magic != MAGIC {
        return Err(RepositoryError::BadMagic {
            found: header.magic,
        });
    }
    if header.version != FORMAT_VERSION {
        return Err(RepositoryError::WrongVersion {
            found: header.version,
            expected: FORMAT_VERSION,
        });
    }
    check_header_fields(&header)?;
    let diamonds = table_range(
        "diamond table",
        header.diamond_table_offset,
        header.diamond_count,
        DIAMOND_RECORD_SIZE,
        HEADER_SIZE as u64,
        len,
    )?;
    let tets = table_range(
        "tet table",
        header.tet_table_offset,
        header.tet_count,
        TET_RECORD_SIZE,
        diamonds.end as u64,
        len,
    )?;
    let patch_blob = table_range(
        "patch blob",
        header.patch_blob_offset,
        header.patch_blob_bytes,
        1,
        tets.end as u64,
        len,
    )?;
    let id_blob = table_range(
        "id blob",
        header.id_blob_offset,
        header.id_blob_bytes,
        1,
        patch_blob.end as u64,
        len,
    )?;
    if id_blob.end as u64 != len {
        return Err(corrupt(format!(
            "file is {len} bytes but its tables end at {}",
            id_blob.end
        )));
    }
    let computed = compute_checksum(bytes);
    if computed != header.checksum {
        return Err(RepositoryError::ChecksumMismatch {
            stored: header.checksum,
            computed,
        });
    }
    Ok(Layout {
        header,
        diamonds,
        tets,
        patch_blob,
        id_blob,
    })
}

/// Byte range of a table of `count` records at `offset`, which must be 8-aligned, at or after
/// `after` (the end of what precedes it) and end within `len`.
fn table_range(
    name: &str,
    offset: u64,
    count: u64,
    record_size: usize,
    after: u64,
    len: u64,
) -> Result<Range<usize>, RepositoryError> {
    if offset & (TABLE_ALIGN - 1) != 0 {
        return Err(corrupt(format!(
            "{name} offset {offset} is not a multiple of 8"
        )));
    }
    if offset < after {
        return Err(corrupt(format!(
            "{name} at offset {offset} overlaps what precedes it, which ends at {after}"
        )));
    }
    match count.checked_mul(record_size as u64).and_then(|b| offset.checked_add(b)) {
        // end ≤ len, and len came from a slice length, so both fit in usize.
        Some(end) if end <= len => Ok(offset as usize..end as usize),
        _ => Err(corrupt(format!(
            "{name} of {count} × {record_size} bytes at offset {offset} exceeds the file of {len} bytes"
        ))),
    }
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
    if h.reserved != 0 {
        return Err(corrupt(format!(
            "reserved header field is {}, not 0",
            h.reserved
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
/// their blobs; the patches' contents are checked by `PatchView::parse`). `h` must have passed
/// `check_header_fields`, and its counts must match the slices.
pub(crate) fn check_tables(
    h: &Header,
    diamonds: &[DiamondRecord],
    tets: &[TetRecord],
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
                if p as usize >= diamonds.len() || p as usize == i {
                    return fail(format!(
                        "parent {k} is {p}, not another of the {} diamonds",
                        diamonds.len()
                    ));
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
    for (i, t) in tets.iter().enumerate() {
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
        if t.diamond != NO_INDEX && diamonds[t.diamond as usize].level != t.level {
            return fail(format!(
                "level {} differs from its diamond's {}",
                t.level, diamonds[t.diamond as usize].level
            ));
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
        if end > h.patch_blob_bytes as u128 {
            return fail(format!(
                "patch range {}..{end} exceeds patch blob of {} bytes",
                t.patch_offset, h.patch_blob_bytes
            ));
        }
        let expected = patch_bytes_checked(
            t.vertex_count as u64,
            t.strip_index_count as u64,
            h.attributes,
        );
        if expected != Some(t.patch_bytes as u64) {
            return fail(format!(
                "patch is {} bytes but {} vertices and {} strip indices take {expected:?}",
                t.patch_bytes, t.vertex_count, t.strip_index_count
            ));
        }
        let id_end = t.id_offset as u128 + t.id_bytes as u128;
        if id_end > h.id_blob_bytes as u128 {
            return fail(format!(
                "id range {}..{id_end} exceeds id blob of {} bytes",
                t.id_offset, h.id_blob_bytes
            ));
        }
        // Every id takes at least one byte: a cheap bound before the stream is decoded.
        if (t.id_bytes as u64) < t.vertex_count as u64 {
            return fail(format!(
                "{} ids cannot fit in an id stream of {} bytes",
                t.vertex_count, t.id_bytes
            ));
        }
        if t.reserved != 0 {
            return fail(format!("reserved field is {}, not 0", t.reserved));
        }
        if t.triangle_count > t.strip_index_count.saturating_sub(2) {
            return fail(format!(
                "{} triangles cannot fit in {} strip indices",
                t.triangle_count, t.strip_index_count
            ));
        }
    }
    Ok(())
}
