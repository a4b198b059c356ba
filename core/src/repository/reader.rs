//! The validated reader: memory-maps a repository and checks every count, offset, index and
//! float before handing out zero-copy views of its tables and patches.
//!
//! A bad file is an error, never a panic or an out-of-bounds read. Opening reads the header,
//! the section table and the directory (diamond and tet tables) and nothing else: magic,
//! version, header fields, the header checksum, section ranges with checked arithmetic
//! (8-aligned, inside the file, not overlapping), the directory's checksums, then every record
//! and the hierarchy's structure (a tree of simplices: every non-root simplex is the child of
//! exactly one, children stored after their parent; diamonds' parents stored before them), all
//! in time linear in the directory. A patch is verified the first time it is read (its
//! checksum, then its strip and ids: `Repository::patch`, `Repository::patch_bytes`), the id
//! blob's checksum the first time an id is read; `Repository::validate_patches` does it all.

use std::fs::File;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

use memmap2::Mmap;

use super::attribute_errors::check_attribute_errors;
use super::directory_check::{check_tables, BlobSizes};
use super::file_layout::check_layout;
use super::format::{
    patch_checksum, section_name, AttributeErrorRecord, DiamondRecord, Header, PatchCodec,
    SectionEntry, TetRecord, HEADER_SIZE, MAGIC, SECTION_IDS, TET_RECORD_SIZE,
};
use super::packed::{unpack_patch, StripCoding};
use super::patch::{patch_bytes_checked, PatchSource, PatchView};
use super::textures::{check_texture_section, TextureLayout, TextureTable};

/// A validated patch (`Repository::patch`): borrowed from the map, or decoded from a packed
/// repository; `view` gives its arrays.
#[derive(Clone, Debug)]
pub struct Patch<'a> {
    bytes: PatchBytes,
    tet: TetRecord,
    source: PatchSource<'a>,
}

#[derive(Clone, Debug)]
enum PatchBytes {
    /// In the map, where the tet record says.
    Mapped,
    /// Decoded into 8-aligned words (the patch at offset 0).
    Decoded(Vec<u64>),
}

impl Patch<'_> {
    /// Where `PatchView::parse` finds this patch.
    fn source(&self) -> PatchSource<'_> {
        match &self.bytes {
            PatchBytes::Mapped => self.source,
            PatchBytes::Decoded(words) => PatchSource {
                patch_blob: bytemuck::cast_slice(words),
                ..self.source
            },
        }
    }

    /// The tet record with the patch range `source` holds it at.
    fn record(&self) -> TetRecord {
        match &self.bytes {
            PatchBytes::Mapped => self.tet,
            PatchBytes::Decoded(_) => TetRecord {
                patch_offset: 0,
                patch_bytes: patch_bytes_checked(
                    self.tet.vertex_count as u64,
                    self.tet.strip_index_count as u64,
                    self.source.attributes,
                )
                .expect("checked on open") as u32,
                ..self.tet
            },
        }
    }

    /// The patch's arrays (validated when `Repository::patch` made it: O(1) here).
    pub fn view(&self) -> PatchView<'_> {
        PatchView::parse_checked(&self.source(), &self.record(), false)
            .expect("the same checks passed when the patch was read")
    }
}

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
        "repository format version {found} is not supported: this build reads version {expected} \
         (rebuild the repository from its input with `tessera build`)"
    )]
    WrongVersion { found: u32, expected: u32 },
    /// The header or section table changed since the file was written.
    #[error(
        "header checksum mismatch: header says {stored:#010x}, header and section table hash to \
         {computed:#010x}"
    )]
    ChecksumMismatch { stored: u32, computed: u32 },
    /// A checksummed section (diamond table, tet table, id blob) changed since it was written.
    #[error("{section} checksum mismatch: section table says {stored:#010x}, its bytes hash to {computed:#010x}")]
    SectionChecksumMismatch {
        section: String,
        stored: u32,
        computed: u32,
    },
    /// One patch changed since it was written; the rest of the file may still be drawn.
    #[error(
        "patch of tet {tet} is damaged: checksum {stored:#010x} stored, {computed:#010x} computed"
    )]
    PatchChecksumMismatch {
        tet: usize,
        stored: u32,
        computed: u32,
    },
    /// Structurally invalid (the message names the record and the problem).
    #[error("corrupt repository: {0}")]
    Corrupt(String),
    /// One texture page changed since it was written; the other pages may still be drawn.
    #[error(
        "texture page {page} is damaged: checksum {stored:#010x} stored, {computed:#010x} computed"
    )]
    PageChecksumMismatch {
        page: u32,
        stored: u32,
        computed: u32,
    },
    /// `TextureTable::page` called with an index past the last page.
    #[error("texture page {index} does not exist: the repository has {count} pages")]
    NoSuchPage { index: u32, count: u32 },
    /// `Repository::patch` called with an index past the tet table.
    #[error("tet {index} does not exist: the repository has {count} tets")]
    NoSuchTet { index: usize, count: usize },
}

pub(crate) fn corrupt(message: String) -> RepositoryError {
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

    /// Drops this process's mapping of the pages covering `range` (whole pages, rounded
    /// outwards; see `Repository::release_pages` for why this is safe). Linux only; a no-op
    /// for an in-memory image.
    fn release(&self, range: Range<usize>) {
        #[cfg(target_os = "linux")]
        if let Storage::Mapped(map) = self {
            const PAGE: usize = 4096;
            let start = range.start.min(map.len()) / PAGE * PAGE;
            let end = range.end.min(map.len());
            if end > start {
                // SAFETY: as in `Repository::release_pages`: a read-only shared file mapping;
                // the next access maps the same bytes in again from the page cache.
                let _ = unsafe {
                    map.unchecked_advise_range(
                        memmap2::UncheckedAdvice::DontNeed,
                        start,
                        end - start,
                    )
                };
            }
        }
        #[cfg(not(target_os = "linux"))]
        let _ = range;
    }
}

/// Bytes of the directory between two releases of its pages while it is validated: the
/// process holds at most about this much of it at a time (plus the diamond table, read at
/// random while the tets are checked).
pub(crate) const RELEASE_CHUNK: usize = 1 << 20;

/// An open repository whose directory is validated; patches are verified on first read.
pub struct Repository {
    storage: Storage,
    header: Header,
    diamonds: Range<usize>,
    tets: Range<usize>,
    patch_blob: Range<usize>,
    id_blob: Range<usize>,
    /// `SectionEntry::checksum` of the id blob, verified once by `ids_verified`.
    id_blob_checksum: u32,
    /// The section table as read.
    sections: Vec<SectionEntry>,
    /// How the patch blob stores the patches.
    codec: PatchCodec,
    /// The attribute error table (`attribute_errors.rs`), where the file has one.
    attribute_errors: Option<Range<usize>>,
    /// The texture section (`textures.rs`), its tables checked, where the file has one.
    textures: Option<TextureLayout>,
    /// Outcome of the one check of the id blob's checksum (the computed value on a mismatch).
    ids_checked: OnceLock<Result<(), u32>>,
    /// One bit per tet: its patch checksum was verified. Relaxed atomics: a race only verifies
    /// twice.
    patch_verified: Vec<AtomicU64>,
}

impl std::fmt::Debug for Repository {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Repository")
            .field("header", &self.header)
            .finish_non_exhaustive()
    }
}

impl Repository {
    /// Memory-maps the repository at `path` and validates its header, section table and
    /// directory (checksums, every record, the hierarchy's structure).
    ///
    /// Cost: linear in the directory (header, section table, diamond and tet tables); the
    /// blobs are not touched: patches are checked when first read (`patch`, `patch_bytes`). The file must not be modified while the repository is open (the map
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
        // The directory is read once for its checksums and once for its records; its pages
        // are dropped behind each pass as it goes, so opening holds about `RELEASE_CHUNK` of
        // it at a time, whatever the model's size.
        let release = |range: Range<usize>| storage.release(range);
        let layout = check_layout(bytes, &release)?;
        let diamonds: &[DiamondRecord] = bytemuck::try_cast_slice(&bytes[layout.diamonds.clone()])
            .map_err(|e| corrupt(format!("diamond table cannot be borrowed in place: {e:?}")))?;
        let tets: &[TetRecord] = bytemuck::try_cast_slice(&bytes[layout.tets.clone()])
            .map_err(|e| corrupt(format!("tet table cannot be borrowed in place: {e:?}")))?;
        let blobs = BlobSizes {
            patches: layout.patch_blob.len() as u64,
            ids: layout.id_blob.len() as u64,
            codec: layout.codec,
        };
        let tets_start = layout.tets.start;
        let release_tets = |r: Range<usize>| {
            release(tets_start + r.start * TET_RECORD_SIZE..tets_start + r.end * TET_RECORD_SIZE)
        };
        check_tables(&layout.header, diamonds, tets, blobs, &release_tets)?;
        if let Some(range) = &layout.attribute_errors {
            let records: &[AttributeErrorRecord] = bytemuck::try_cast_slice(&bytes[range.clone()])
                .map_err(|e| {
                    corrupt(format!(
                        "attribute error table cannot be borrowed in place: {e:?}"
                    ))
                })?;
            check_attribute_errors(records, diamonds.len())?;
        }
        let textures = match layout.textures {
            Some((range, checksum)) => Some(check_texture_section(bytes, range, checksum)?),
            None => None,
        };
        let patch_verified = (0..tets.len().div_ceil(64))
            .map(|_| AtomicU64::new(0))
            .collect();
        let repository = Repository {
            header: layout.header,
            diamonds: layout.diamonds,
            tets: layout.tets,
            patch_blob: layout.patch_blob,
            id_blob: layout.id_blob,
            id_blob_checksum: layout.id_blob_checksum,
            sections: layout.sections,
            codec: layout.codec,
            attribute_errors: layout.attribute_errors,
            textures,
            ids_checked: OnceLock::new(),
            patch_verified,
            storage,
        };
        // Validation read the whole directory through the map: those pages would stay in the
        // process's resident set (RssFile), which would then grow with the model.
        repository.release_pages();
        Ok(repository)
    }

    /// Visits every tet record in order, dropping the pages of those visited from the
    /// resident set every `RELEASE_CHUNK` bytes (as opening does), so a pass over the whole
    /// directory holds about that much of it at a time whatever the model's size.
    pub fn scan_tets(&self, visit: impl FnMut(usize, &TetRecord)) {
        self.scan_released(self.tets(), self.tets.start, visit);
    }

    /// Visits every diamond record in order, dropping each `RELEASE_CHUNK` of the table from
    /// the resident set behind the visit, as `scan_tets` does for the tet table.
    pub fn scan_diamonds(&self, visit: impl FnMut(usize, &DiamondRecord)) {
        self.scan_released(self.diamonds(), self.diamonds.start, visit);
    }

    /// Visits `table` (at byte `start` of the file) in order, releasing each `RELEASE_CHUNK`
    /// of its pages behind the visit.
    fn scan_released<T>(&self, table: &[T], start: usize, mut visit: impl FnMut(usize, &T)) {
        let per_chunk = (RELEASE_CHUNK / std::mem::size_of::<T>()).max(1);
        for (k, chunk) in table.chunks(per_chunk).enumerate() {
            for (j, record) in chunk.iter().enumerate() {
                visit(k * per_chunk + j, record);
            }
            let at = start + k * per_chunk * std::mem::size_of::<T>();
            self.storage.release(at..at + std::mem::size_of_val(chunk));
        }
    }

    /// Drops this process's mapping of every page of the file it has touched (the page cache
    /// keeps them; the next read maps them again), so the map's share of the resident set
    /// (RssFile) goes back to zero. Opening calls it after validating the directory, and a
    /// caller that scans the whole directory (a streamer sizing its pools) may call it after.
    /// Linux `madvise(MADV_DONTNEED)`; a no-op for an in-memory image and elsewhere.
    pub fn release_pages(&self) {
        #[cfg(target_os = "linux")]
        if let Storage::Mapped(map) = &self.storage {
            if !map.is_empty() {
                // SAFETY: the map is a read-only, shared mapping of a file this process does
                // not write, and the caller contract of `open` says no one modifies it while it
                // is open. For such a mapping MADV_DONTNEED only removes the page-table
                // entries: the next access faults the same bytes back in from the page cache,
                // so every borrow of the map keeps reading the bytes that were validated.
                // (memmap2 calls the advice unchecked because for private or anonymous
                // mappings it would discard content; none here.) A failure only leaves the
                // pages resident.
                let _ = unsafe {
                    map.unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, 0, map.len())
                };
            }
        }
    }

    /// The header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The section table, as the file lists it.
    pub fn sections(&self) -> &[SectionEntry] {
        &self.sections
    }

    /// The diamond table, borrowed from the file.
    pub fn diamonds(&self) -> &[DiamondRecord] {
        // Size and alignment were checked by `validate`.
        bytemuck::cast_slice(&self.storage.bytes()[self.diamonds.clone()])
    }

    /// The attribute error table (one record a diamond, in table order, saturated: see
    /// `attribute_errors.rs`), borrowed from the file; `None` where the repository has none
    /// (an input without colours or texture coordinates, or a repository older than the
    /// table).
    pub fn attribute_errors(&self) -> Option<&[AttributeErrorRecord]> {
        let range = self.attribute_errors.clone()?;
        // Size and alignment were checked by `validate`.
        Some(bytemuck::cast_slice(&self.storage.bytes()[range]))
    }

    /// The tet table, borrowed from the file.
    pub fn tets(&self) -> &[TetRecord] {
        bytemuck::cast_slice(&self.storage.bytes()[self.tets.clone()])
    }

    /// The whole patch blob (every `TetRecord::patch_offset` is relative to its start), *not
    /// verified*: readers of single patches use `patch_bytes` or `patch`.
    pub fn patch_blob(&self) -> &[u8] {
        &self.storage.bytes()[self.patch_blob.clone()]
    }

    /// The whole id blob (every `TetRecord::id_offset` is relative to its start), *not
    /// verified*: see `verify_ids`.
    pub fn id_blob(&self) -> &[u8] {
        &self.storage.bytes()[self.id_blob.clone()]
    }

    /// Checks the id blob's checksum (once per open repository; later calls return the first
    /// outcome). Cost: one pass over the id blob, which only the CPU's checks read.
    pub fn verify_ids(&self) -> Result<(), RepositoryError> {
        let outcome = *self.ids_checked.get_or_init(|| {
            let computed = crc32fast::hash(self.id_blob());
            if computed == self.id_blob_checksum {
                Ok(())
            } else {
                Err(computed)
            }
        });
        outcome.map_err(|computed| RepositoryError::SectionChecksumMismatch {
            section: section_name(SECTION_IDS),
            stored: self.id_blob_checksum,
            computed,
        })
    }

    fn tet(&self, tet_index: usize) -> Result<&TetRecord, RepositoryError> {
        let tets = self.tets();
        tets.get(tet_index).ok_or(RepositoryError::NoSuchTet {
            index: tet_index,
            count: tets.len(),
        })
    }

    /// How the patch blob stores the patches (packed by default, `build --no-compress` raw).
    pub fn codec(&self) -> PatchCodec {
        self.codec
    }

    /// The stored patch of tet `tet_index` (raw: what a renderer uploads; packed: what
    /// `read_patch` decodes), its checksum verified the first time it is read: one damaged
    /// patch is `PatchChecksumMismatch` naming the tet, and the rest of the repository stays
    /// readable. Its strip is not parsed (`patch` does).
    pub fn patch_bytes(&self, tet_index: usize) -> Result<&[u8], RepositoryError> {
        let tet = self.tet(tet_index)?;
        // In range: `check_tables` checked every patch range against the blob.
        let start = tet.patch_offset as usize;
        let bytes = &self.patch_blob()[start..start + tet.patch_bytes as usize];
        let (word, bit) = (tet_index / 64, 1u64 << (tet_index % 64));
        if self.patch_verified[word].load(Ordering::Relaxed) & bit == 0 {
            let computed = patch_checksum(bytes);
            if computed != tet.patch_checksum {
                return Err(RepositoryError::PatchChecksumMismatch {
                    tet: tet_index,
                    stored: tet.patch_checksum,
                    computed,
                });
            }
            self.patch_verified[word].fetch_or(bit, Ordering::Relaxed);
        }
        Ok(bytes)
    }

    /// Size of tet `tet_index`'s patch as drawn (decoded), `patch::patch_bytes` of its counts:
    /// what `read_patch` writes. Checked on open to fit a u32.
    pub fn decoded_patch_bytes(&self, tet_index: usize) -> Result<usize, RepositoryError> {
        let t = self.tet(tet_index)?;
        Ok(patch_bytes_checked(
            t.vertex_count as u64,
            t.strip_index_count as u64,
            self.header.attributes,
        )
        .expect("checked on open") as usize)
    }

    /// Writes tet `tet_index`'s patch as drawn into `out` (exactly `decoded_patch_bytes`
    /// long): a copy from the map, or the packed patch decoded (`packed::unpack_patch`, which
    /// checks every index and coordinate it writes). The checksum is verified as in
    /// `patch_bytes`; a patch that does not decode is `Corrupt` naming the tet.
    pub fn read_patch(&self, tet_index: usize, out: &mut [u8]) -> Result<(), RepositoryError> {
        let stored = self.patch_bytes(tet_index)?;
        let expected = self.decoded_patch_bytes(tet_index)?;
        if out.len() != expected {
            return Err(corrupt(format!(
                "tet {tet_index}: its patch is {expected} bytes, not the {} given",
                out.len()
            )));
        }
        match self.codec {
            PatchCodec::Raw => {
                out.copy_from_slice(stored);
                Ok(())
            }
            PatchCodec::Packed | PatchCodec::PackedV1 | PatchCodec::Coded => {
                let t = self.tet(tet_index)?;
                unpack_patch(
                    stored,
                    t.vertex_count as usize,
                    t.strip_index_count as usize,
                    self.header.attributes,
                    StripCoding::of(self.codec).expect("packed"),
                    out,
                )
                .map_err(|e| corrupt(format!("tet {tet_index}: {e}")))
            }
        }
    }

    /// Parses and validates the patch of tet `tet_index`: its checksum (first read only), its
    /// decoding when packed, then one pass over its strip and one over its id stream (the id
    /// blob's checksum is verified on the first call, see `verify_ids`). The patch borrows the
    /// map when the repository is raw and owns its decoded bytes when packed.
    pub fn patch(&self, tet_index: usize) -> Result<Patch<'_>, RepositoryError> {
        self.verify_ids()?;
        let tet = *self.tet(tet_index)?;
        let bytes = match self.codec {
            PatchCodec::Raw => {
                self.patch_bytes(tet_index)?;
                PatchBytes::Mapped
            }
            PatchCodec::Packed | PatchCodec::PackedV1 | PatchCodec::Coded => {
                let len = self.decoded_patch_bytes(tet_index)?;
                let mut words = vec![0u64; len.div_ceil(8)];
                self.read_patch(tet_index, &mut bytemuck::cast_slice_mut(&mut words)[..len])?;
                PatchBytes::Decoded(words)
            }
        };
        let patch = Patch {
            bytes,
            tet,
            source: PatchSource {
                patch_blob: self.patch_blob(),
                id_blob: self.id_blob(),
                attributes: self.header.attributes,
                input_vertex_count: self.header.input_vertex_count,
            },
        };
        PatchView::parse(&patch.source(), &patch.record()).map_err(|e| match e {
            RepositoryError::Corrupt(message) => corrupt(format!("tet {tet_index}: {message}")),
            other => other,
        })?;
        Ok(patch)
    }

    /// Verifies and parses every patch: after this, `patch` cannot fail. Cost: one pass over
    /// both blobs.
    pub fn validate_patches(&self) -> Result<(), RepositoryError> {
        (0..self.tets().len()).try_for_each(|i| self.patch(i).map(drop))
    }

    /// The repository's textures (`textures.rs`): shapes and bands checked on open, each page
    /// checked on first read; `None` where the repository has no texture section.
    pub fn textures(&self) -> Option<TextureTable<'_>> {
        let layout = self.textures.as_ref()?;
        Some(TextureTable::new(self.storage.bytes(), layout))
    }

    /// Size of the file in bytes.
    pub fn file_bytes(&self) -> u64 {
        self.storage.bytes().len() as u64
    }
}
