//! The writer: lays out header, diamond table, tet table, patch blob and id blob (in that
//! order, each 8-aligned), fills the header's bookkeeping fields and checksum, and writes the file through
//! a temporary file and a rename. Mirrors `reader.rs`: whatever it writes, `Repository` opens.

use std::ffi::OsString;
use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use super::format::{
    align8, compute_checksum, DiamondRecord, Header, TetRecord, DIAMOND_RECORD_SIZE,
    FORMAT_VERSION, HEADER_SIZE, MAGIC, TET_RECORD_SIZE,
};
use super::reader::{check_header_fields, check_tables, RepositoryError};

/// Everything a repository holds.
#[derive(Clone, Debug, PartialEq)]
pub struct RepositoryContents {
    /// The caller fills dimension, attributes, root_tet_count, input counts, origin, bbox,
    /// position step and lattice; the writer fills magic, version, diamond/tet counts, offsets,
    /// blob sizes and checksum (whatever they held is ignored).
    pub header: Header,
    /// The diamond table (`Header::diamond_count` = its length).
    pub diamonds: Vec<DiamondRecord>,
    /// The tet table, roots first (`Header::tet_count` = its length).
    pub tets: Vec<TetRecord>,
    /// The patches, each at its tet's `patch_offset` (see `patch::encode_patch`).
    pub patch_blob: Vec<u8>,
    /// The global id streams, each at its tet's `id_offset` (see `patch::encode_patch`).
    pub id_blob: Vec<u8>,
}

/// Fills the writer's header fields (checksum 0) and validates the contents as the reader
/// would, so an invalid repository is never written.
fn lay_out(contents: &RepositoryContents) -> Result<Header, RepositoryError> {
    let overflow = || RepositoryError::Corrupt("tables overflow a u64 file offset".into());
    let mut h = contents.header;
    h.magic = MAGIC;
    h.version = FORMAT_VERSION;
    h.diamond_count = contents.diamonds.len() as u64;
    h.tet_count = contents.tets.len() as u64;
    h.patch_blob_bytes = contents.patch_blob.len() as u64;
    h.id_blob_bytes = contents.id_blob.len() as u64;
    h.diamond_table_offset = align8(HEADER_SIZE as u64).ok_or_else(overflow)?;
    h.tet_table_offset =
        align8(h.diamond_table_offset + h.diamond_count * DIAMOND_RECORD_SIZE as u64)
            .ok_or_else(overflow)?;
    h.patch_blob_offset =
        align8(h.tet_table_offset + h.tet_count * TET_RECORD_SIZE as u64).ok_or_else(overflow)?;
    h.id_blob_offset = h
        .patch_blob_offset
        .checked_add(h.patch_blob_bytes)
        .and_then(align8)
        .ok_or_else(overflow)?;
    h.id_blob_offset
        .checked_add(h.id_blob_bytes)
        .ok_or_else(overflow)?;
    h.checksum = 0;
    check_header_fields(&h)?;
    check_tables(&h, &contents.diamonds, &contents.tets)?;
    Ok(h)
}

/// The file, in order, as byte slices (zero padding between tables).
fn sections<'a>(header: &'a Header, contents: &'a RepositoryContents) -> [&'a [u8]; 9] {
    const ZEROS: [u8; 8] = [0; 8];
    let pad = |from: u64, to: u64| &ZEROS[..(to - from) as usize];
    let diamonds_end =
        header.diamond_table_offset + header.diamond_count * DIAMOND_RECORD_SIZE as u64;
    let tets_end = header.tet_table_offset + header.tet_count * TET_RECORD_SIZE as u64;
    let patches_end = header.patch_blob_offset + header.patch_blob_bytes;
    [
        bytemuck::bytes_of(header),
        pad(HEADER_SIZE as u64, header.diamond_table_offset),
        bytemuck::cast_slice(&contents.diamonds),
        pad(diamonds_end, header.tet_table_offset),
        bytemuck::cast_slice(&contents.tets),
        pad(tets_end, header.patch_blob_offset),
        &contents.patch_blob,
        pad(patches_end, header.id_blob_offset),
        &contents.id_blob,
    ]
}

/// Writes `header` (checksum still 0) and the contents to `w`, returning the byte count.
fn write_laid_out<W: Write>(
    mut w: W,
    mut header: Header,
    contents: &RepositoryContents,
) -> io::Result<u64> {
    let mut hasher = crc32fast::Hasher::new();
    for s in sections(&header, contents) {
        hasher.update(s);
    }
    header.checksum = hasher.finalize();
    debug_assert_eq!(
        header.checksum,
        compute_checksum(&sections(&header, contents).concat()),
        "streamed checksum vs the reader's"
    );
    let mut total = 0u64;
    for s in sections(&header, contents) {
        w.write_all(s)?;
        total += s.len() as u64;
    }
    w.flush()?;
    debug_assert_eq!(total, header.id_blob_offset + header.id_blob_bytes);
    Ok(total)
}

/// Writes a repository to `w` and returns the number of bytes written.
///
/// Fills magic, version, counts, offsets, blob sizes and the checksum, and first runs the
/// reader's header and record checks on the contents: invalid contents (an index out of range,
/// a patch outside the blob, a NaN radius, …) fail with `ErrorKind::InvalidInput` wrapping the
/// `RepositoryError`, before anything is written. Patch strips and id streams are not
/// re-checked (`encode_patch` writes them correctly by construction).
pub fn write_repository<W: Write>(w: W, contents: &RepositoryContents) -> io::Result<u64> {
    let header = lay_out(contents).map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
    write_laid_out(w, header, contents)
}

/// Writes a repository to `path` atomically: to `.{file name}.tmp-{pid}` in the same
/// directory, synced, then renamed over `path`. On any error the temporary file is removed and
/// `path` is untouched. Returns the file size.
///
/// Invalid contents fail as in `write_repository` (the `RepositoryError` itself, before any
/// file is created).
pub fn write_repository_file(
    path: &Path,
    contents: &RepositoryContents,
) -> Result<u64, RepositoryError> {
    let header = lay_out(contents)?;
    let io_error = |path: &Path, source| RepositoryError::Io {
        path: path.to_path_buf(),
        source,
    };
    let Some(file_name) = path.file_name() else {
        return Err(io_error(
            path,
            io::Error::new(
                io::ErrorKind::InvalidInput,
                "repository path has no file name",
            ),
        ));
    };
    let mut tmp_name = OsString::from(".");
    tmp_name.push(file_name);
    tmp_name.push(format!(".tmp-{}", std::process::id()));
    let tmp: PathBuf = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.join(tmp_name),
        _ => PathBuf::from(tmp_name),
    };
    let write = || -> io::Result<u64> {
        let mut out = BufWriter::new(File::create(&tmp)?);
        let bytes = write_laid_out(&mut out, header, contents)?;
        out.into_inner()
            .map_err(io::IntoInnerError::into_error)?
            .sync_all()?;
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
    Ok(bytes)
}
