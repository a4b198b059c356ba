//! The writer: lays out header, section table, diamond table, tet table, patch blob, id blob
//! and, when there are, the attribute error table and the texture section (in that order, each section 8-aligned), fills the header's bookkeeping fields, the
//! section table, every patch's checksum and the checksums, and writes the file through a
//! temporary file, fsync and a rename. Mirrors `reader.rs`: whatever it writes, `Repository`
//! opens.

use std::ffi::OsString;
use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use super::attribute_errors::check_attribute_errors;
use super::directory_check::{check_header_fields, check_tables, BlobSizes};
use super::format::{
    align8, compute_checksum, patch_checksum, AttributeErrorRecord, DiamondRecord, Header,
    PatchCodec, SectionEntry, TetRecord, ATTRIBUTE_ERROR_RECORD_SIZE, DIAMOND_RECORD_SIZE,
    FORMAT_VERSION, HEADER_SIZE, MAGIC, SECTION_ATTRIBUTE_ERRORS, SECTION_DIAMONDS,
    SECTION_ENTRY_SIZE, SECTION_FLAG_OPTIONAL, SECTION_IDS, SECTION_TETS, SECTION_TEXTURES,
    TET_RECORD_SIZE, WRITTEN_SECTIONS,
};
use super::reader::RepositoryError;
use super::textures::{TextureContents, TextureDirectory};

/// Everything a repository holds.
#[derive(Clone, Debug, PartialEq)]
pub struct RepositoryContents {
    /// The caller fills dimension, attributes, root_tet_count, input counts, origin, bbox,
    /// position step and lattice; the writer fills magic, version, section count, diamond/tet
    /// counts and checksum (whatever they held is ignored).
    pub header: Header,
    /// The diamond table (`Header::diamond_count` = its length).
    pub diamonds: Vec<DiamondRecord>,
    /// The tet table, roots first (`Header::tet_count` = its length). The writer fills each
    /// `patch_checksum` (whatever it held is ignored).
    pub tets: Vec<TetRecord>,
    /// The patches, each at its tet's `patch_offset` (see `patch::encode_patch`), stored as
    /// `codec` says (packed: each `packed::pack_patch` of the encoded patch).
    pub patch_blob: Vec<u8>,
    /// How `patch_blob` stores the patches.
    pub codec: PatchCodec,
    /// The global id streams, each at its tet's `id_offset` (see `patch::encode_patch`).
    pub id_blob: Vec<u8>,
    /// The attribute error table (`attribute_errors.rs`), one record a diamond, or `None`
    /// (no section: an input without colours or texture coordinates).
    pub attribute_errors: Option<Vec<AttributeErrorRecord>>,
}

/// What `lay_out` computed: the header and section table as written, the tets with their
/// patch checksums and the texture section's bytes.
struct Laid {
    header: Header,
    entries: Vec<SectionEntry>,
    tets: Vec<TetRecord>,
    textures: Option<Vec<u8>>,
}

/// Fills the writer's header fields, the section table and the patch checksums, and validates
/// the contents as the reader would, so an invalid repository is never written.
fn lay_out(
    contents: &RepositoryContents,
    textures: Option<&TextureContents>,
) -> Result<Laid, RepositoryError> {
    let section = textures.map(TextureContents::section).transpose()?;
    let mut tets = contents.tets.clone();
    let blobs = BlobSizes {
        patches: contents.patch_blob.len() as u64,
        ids: contents.id_blob.len() as u64,
        codec: contents.codec,
    };
    // Patch ranges are checked before they are hashed.
    let attribute_errors = contents.attribute_errors.as_deref();
    let tables = |tets| Tables {
        diamonds: &contents.diamonds,
        tets,
        attribute_errors,
        textures: textures.map(|t| &t.directory),
    };
    let (header, _) = lay_out_directory(&contents.header, tables(&contents.tets), blobs, [0; 2])?;
    for t in &mut tets {
        let start = t.patch_offset as usize;
        t.patch_checksum =
            patch_checksum(&contents.patch_blob[start..start + t.patch_bytes as usize]);
    }
    let ids_checksum = crc32fast::hash(&contents.id_blob);
    // The texture section's checksum covers its tables, the bytes before its pages.
    let textures_checksum = match (&section, textures) {
        (Some(bytes), Some(t)) => {
            let pages = t.directory.page_count() as usize * t.directory.encoding.page_bytes();
            crc32fast::hash(&bytes[..bytes.len() - pages])
        }
        _ => 0,
    };
    let checksums = [ids_checksum, textures_checksum];
    let (header, entries) = lay_out_directory(&header, tables(&tets), blobs, checksums)?;
    Ok(Laid {
        header,
        entries,
        tets,
        textures: section,
    })
}

/// The directory's tables as a writer lays them out.
#[derive(Clone, Copy)]
pub(super) struct Tables<'a> {
    pub diamonds: &'a [DiamondRecord],
    /// With their patch checksums.
    pub tets: &'a [TetRecord],
    /// The optional attribute error table: a section after the id blob when present.
    pub attribute_errors: Option<&'a [AttributeErrorRecord]>,
    /// The optional texture section: the last section when present.
    pub textures: Option<&'a TextureDirectory>,
}

/// The header as written (magic, version, counts, checksum filled) and the section table for
/// these tables and blob sizes, after the reader's header and table checks; `checksums` are
/// the id blob's CRC-32 and the texture section's (of its tables; 0 without one).
pub(super) fn lay_out_directory(
    header: &Header,
    tables: Tables,
    blobs: BlobSizes,
    [ids_checksum, textures_checksum]: [u32; 2],
) -> Result<(Header, Vec<SectionEntry>), RepositoryError> {
    let Tables {
        diamonds,
        tets,
        attribute_errors,
        textures,
    } = tables;
    let overflow = || RepositoryError::Corrupt("sections overflow a u64 file offset".into());
    let section_count =
        WRITTEN_SECTIONS + attribute_errors.is_some() as usize + textures.is_some() as usize;
    let mut h = *header;
    h.magic = MAGIC;
    h.version = FORMAT_VERSION;
    h.section_count = section_count as u32;
    h.diamond_count = diamonds.len() as u64;
    h.tet_count = tets.len() as u64;
    h.checksum = 0;
    check_header_fields(&h)?;
    check_tables(&h, diamonds, tets, blobs, &|_| {})?;
    if let Some(records) = attribute_errors {
        check_attribute_errors(records, diamonds.len())?;
    }
    let mut sizes = vec![
        (
            SECTION_DIAMONDS,
            h.diamond_count * DIAMOND_RECORD_SIZE as u64,
        ),
        (SECTION_TETS, h.tet_count * TET_RECORD_SIZE as u64),
        (blobs.codec.section_kind(), blobs.patches),
        (SECTION_IDS, blobs.ids),
    ];
    if let Some(records) = attribute_errors {
        let bytes = records.len() as u64 * ATTRIBUTE_ERROR_RECORD_SIZE as u64;
        sizes.push((SECTION_ATTRIBUTE_ERRORS, bytes));
    }
    if let Some(textures) = textures {
        textures.check()?;
        sizes.push((SECTION_TEXTURES, textures.section_bytes()));
    }
    let mut at = (HEADER_SIZE + section_count * SECTION_ENTRY_SIZE) as u64;
    let mut entries = vec![SectionEntry::default(); section_count];
    for (entry, (kind, bytes)) in entries.iter_mut().zip(sizes) {
        let offset = align8(at).ok_or_else(overflow)?;
        at = offset.checked_add(bytes).ok_or_else(overflow)?;
        let checksum = match kind {
            SECTION_DIAMONDS => crc32fast::hash(bytemuck::cast_slice(diamonds)),
            SECTION_TETS => crc32fast::hash(bytemuck::cast_slice(tets)),
            SECTION_IDS => ids_checksum,
            SECTION_TEXTURES => textures_checksum,
            SECTION_ATTRIBUTE_ERRORS => {
                crc32fast::hash(bytemuck::cast_slice(attribute_errors.unwrap_or_default()))
            }
            _ => 0,
        };
        let flags = match kind {
            SECTION_ATTRIBUTE_ERRORS | SECTION_TEXTURES => SECTION_FLAG_OPTIONAL,
            _ => 0,
        };
        *entry = SectionEntry {
            kind,
            flags,
            offset,
            bytes,
            checksum,
            reserved: 0,
        };
    }
    let mut directory = bytemuck::bytes_of(&h).to_vec();
    directory.extend_from_slice(bytemuck::cast_slice(&entries));
    h.checksum = compute_checksum(&directory);
    Ok((h, entries))
}

/// Writes the laid-out file to `w`, returning the byte count.
fn write_laid_out<W: Write>(
    mut w: W,
    laid: &Laid,
    contents: &RepositoryContents,
) -> io::Result<u64> {
    const ZEROS: [u8; 8] = [0; 8];
    w.write_all(bytemuck::bytes_of(&laid.header))?;
    w.write_all(bytemuck::cast_slice(&laid.entries))?;
    let mut at = (HEADER_SIZE + laid.entries.len() * SECTION_ENTRY_SIZE) as u64;
    for entry in &laid.entries {
        let bytes: &[u8] = match entry.kind {
            SECTION_DIAMONDS => bytemuck::cast_slice(&contents.diamonds),
            SECTION_TETS => bytemuck::cast_slice(&laid.tets),
            SECTION_IDS => &contents.id_blob,
            SECTION_ATTRIBUTE_ERRORS => {
                bytemuck::cast_slice(contents.attribute_errors.as_deref().unwrap_or_default())
            }
            SECTION_TEXTURES => laid.textures.as_deref().unwrap_or_default(),
            _ => &contents.patch_blob,
        };
        w.write_all(&ZEROS[..(entry.offset - at) as usize])?;
        w.write_all(bytes)?;
        at = entry.offset + bytes.len() as u64;
    }
    w.flush()?;
    Ok(at)
}

/// Writes a repository to `w` and returns the number of bytes written.
///
/// Fills magic, version, counts, the section table, patch checksums and checksums, and first
/// runs the
/// reader's header and record checks on the contents: invalid contents (an index out of range,
/// a patch outside the blob, a NaN radius, …) fail with `ErrorKind::InvalidInput` wrapping the
/// `RepositoryError`, before anything is written. Patch strips and id streams are not
/// re-checked (`encode_patch` writes them correctly by construction).
pub fn write_repository<W: Write>(w: W, contents: &RepositoryContents) -> io::Result<u64> {
    write_repository_textured(w, contents, None)
}

/// `write_repository` with a texture section (`textures.rs`) after the other sections when
/// `textures` is given: its page checksums computed, its tables checked as the reader would
/// (shapes, page counts, bands) before anything is written. The pages are held whole: a
/// build streams them instead (`write_repository_streamed`).
pub fn write_repository_textured<W: Write>(
    w: W,
    contents: &RepositoryContents,
    textures: Option<&TextureContents>,
) -> io::Result<u64> {
    let laid =
        lay_out(contents, textures).map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
    write_laid_out(w, &laid, contents)
}

/// The temporary name a write of `path` by process `pid` uses: `.{file name}.tmp-{pid}` in the
/// same directory (hidden, and matched by the repository's `.gitignore`).
pub(super) fn temporary_path(path: &Path, pid: u32) -> io::Result<PathBuf> {
    let file_name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            "repository path has no file name",
        )
    })?;
    let mut tmp_name = OsString::from(".");
    tmp_name.push(file_name);
    tmp_name.push(format!(".tmp-{pid}"));
    Ok(match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.join(tmp_name),
        _ => PathBuf::from(tmp_name),
    })
}

/// True when process `pid` may still be running (Linux: `/proc/PID` exists; elsewhere every
/// process is assumed alive, so nothing of another writer is ever removed).
fn process_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    if cfg!(target_os = "linux") {
        Path::new("/proc").join(pid.to_string()).exists()
    } else {
        true
    }
}

/// Removes what killed writers of `path` left: temporary files `.{file name}.tmp-{pid}` whose
/// process is gone (a write killed by SIGKILL or a power cut cannot remove its own). A write in
/// progress by a live process is left alone. Returns the paths removed.
pub fn remove_stale_temporaries(path: &Path) -> io::Result<Vec<PathBuf>> {
    let probe = temporary_path(path, 0)?;
    let prefix = probe
        .file_name()
        .and_then(|n| n.to_str())
        .and_then(|n| n.strip_suffix('0'))
        .map(str::to_owned);
    let dir = match probe.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let (Some(prefix), Ok(entries)) = (prefix, fs::read_dir(&dir)) else {
        return Ok(Vec::new());
    };
    let mut removed = Vec::new();
    for entry in entries {
        let entry = entry?;
        let name = entry.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|n| n.strip_prefix(&prefix))
            .and_then(|p| p.parse::<u32>().ok())
        else {
            continue;
        };
        if !process_alive(pid) && entry.file_type()?.is_file() {
            fs::remove_file(entry.path())?;
            removed.push(entry.path());
        }
    }
    Ok(removed)
}

/// Writes a repository to `path` atomically: removes what killed writers of `path` left
/// (`remove_stale_temporaries`), writes `.{file name}.tmp-{pid}` in the same directory, syncs
/// it, renames it over `path` and syncs the directory. On any error the temporary file is
/// removed and `path` is untouched; a SIGKILL at any moment leaves nothing at `path` but a
/// complete repository (the old one or the new one). Returns the file size.
///
/// Invalid contents fail as in `write_repository` (the `RepositoryError` itself, before any
/// file is created).
pub fn write_repository_file(
    path: &Path,
    contents: &RepositoryContents,
) -> Result<u64, RepositoryError> {
    let laid = lay_out(contents, None)?;
    write_atomically(path, &mut |file| {
        let mut out = BufWriter::new(file);
        let bytes = write_laid_out(&mut out, &laid, contents)?;
        out.flush()?;
        Ok(bytes)
    })
}

/// Writes `path` through `.{file name}.tmp-{pid}` (see `write_repository_file`): removes
/// stale temporaries, lets `write` fill the new file and return its size, syncs it, renames it
/// over `path` and syncs the directory. On any error the temporary file is removed.
pub(super) fn write_atomically(
    path: &Path,
    write: &mut dyn FnMut(&mut File) -> io::Result<u64>,
) -> Result<u64, RepositoryError> {
    let io_error = |path: &Path, source| RepositoryError::Io {
        path: path.to_path_buf(),
        source,
    };
    let tmp = temporary_path(path, std::process::id()).map_err(|e| io_error(path, e))?;
    remove_stale_temporaries(path).map_err(|e| io_error(path, e))?;
    let mut write = || -> io::Result<u64> {
        let mut file = File::create(&tmp)?;
        let bytes = write(&mut file)?;
        file.sync_all()?;
        Ok(bytes)
    };
    let bytes = write().map_err(|e| {
        let _ = fs::remove_file(&tmp);
        io_error(&tmp, e)
    })?;
    fs::rename(&tmp, path).map_err(|e| {
        let _ = fs::remove_file(&tmp);
        io_error(path, e)
    })?;
    // The rename is durable once the directory is synced (best effort: not every platform
    // can open a directory).
    if let Some(dir) = tmp.parent().filter(|d| !d.as_os_str().is_empty()) {
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
    }
    Ok(bytes)
}
