//! The streaming writer: the directory (header, diamond and tet tables) is in memory, the patch
//! and id blobs are fed one tet at a time, so a build never holds its repository's blobs
//! (issue 12: the out-of-core build encodes patches as they are made and keeps them on disk).
//!
//! Same layout and bytes as `write_repository_file` for the same contents. The tets' patch
//! ranges must follow each other in table order (the build lays them out so); every fed patch is
//! checked against its record's size and checksum before the file is renamed into place, so a
//! patch that does not match its directory never reaches a repository.

use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::Path;

use super::directory_check::BlobSizes;
use super::format::{
    patch_checksum, AttributeErrorRecord, DiamondRecord, Header, PatchCodec, SectionEntry,
    TetRecord, HEADER_SIZE, SECTION_ATTRIBUTE_ERRORS, SECTION_CODED_STRIPS, SECTION_DIAMONDS,
    SECTION_ENTRY_SIZE, SECTION_IDS, SECTION_PACKED_PATCHES, SECTION_PACKED_STRIPS,
    SECTION_PATCHES, SECTION_TETS, SECTION_TEXTURES,
};
use super::reader::{corrupt, RepositoryError};
use super::textures::{page_checksum, TextureDirectory};
use super::writer::{lay_out_directory, write_atomically, Tables};

/// The in-memory part of a repository written by `write_repository_streamed`.
#[derive(Clone, Debug, PartialEq)]
pub struct RepositoryDirectory {
    /// As `RepositoryContents::header`: the writer fills magic, version, counts and checksum.
    pub header: Header,
    pub diamonds: Vec<DiamondRecord>,
    /// Every tet's `patch_offset` / `id_offset` is where the previous tet's range ends (0 for
    /// the first), and `patch_checksum` is its patch's CRC-32 (`format::patch_checksum`).
    pub tets: Vec<TetRecord>,
    /// How the fed patches are stored (the fed bytes are the stored ones).
    pub codec: PatchCodec,
    /// As `RepositoryContents::attribute_errors`.
    pub attribute_errors: Option<Vec<AttributeErrorRecord>>,
    /// The textures' shapes and bands, whose pages are fed (`BlobFeed::texture_page`) into a
    /// texture section after every other section; `None`: no texture section.
    pub textures: Option<TextureDirectory>,
}

/// Gives the writer each tet's bytes, in table order.
pub trait BlobFeed {
    /// Appends tet `tet`'s patch (its `patch_bytes` bytes) to `out`.
    fn patch(&mut self, tet: usize, out: &mut Vec<u8>) -> io::Result<()>;
    /// Appends tet `tet`'s global id stream (its `id_bytes` bytes) to `out`.
    fn ids(&mut self, tet: usize, out: &mut Vec<u8>) -> io::Result<()>;
    /// Appends texture page `global` as stored (the directory's `encoding.page_bytes()` bytes)
    /// to `out`; asked in page order, once
    /// each, only of a directory with textures (a feed without pages need not say more).
    fn texture_page(&mut self, global: u32, out: &mut Vec<u8>) -> io::Result<()> {
        let _ = out;
        Err(io::Error::other(format!(
            "texture page {global} asked of a feed that has no texture pages"
        )))
    }
}

/// Writes a repository to `path` atomically (temporary name, fsync, rename, as
/// `write_repository_file`), the blobs fed by `feed`. Returns the file size.
///
/// The directory is checked as the reader would before any file is created; a fed patch or id
/// stream of the wrong size, or a patch that does not match its checksum, fails the write
/// (`RepositoryError::Corrupt` inside an I/O error) and leaves nothing at `path`.
pub fn write_repository_streamed(
    path: &Path,
    directory: &RepositoryDirectory,
    feed: &mut dyn BlobFeed,
) -> Result<u64, RepositoryError> {
    let blobs = contiguous_blobs(&directory.tets, directory.codec)?;
    let tables = Tables {
        diamonds: &directory.diamonds,
        tets: &directory.tets,
        attribute_errors: directory.attribute_errors.as_deref(),
        textures: directory.textures.as_ref(),
    };
    let (header, entries) = lay_out_directory(&directory.header, tables, blobs, [0; 2])?;
    write_atomically(path, &mut |file| {
        write_streamed(file, &header, entries.clone(), directory, feed)
    })
}

/// The blob sizes, after checking that the tets' ranges follow each other in table order.
fn contiguous_blobs(tets: &[TetRecord], codec: PatchCodec) -> Result<BlobSizes, RepositoryError> {
    let mut sizes = BlobSizes {
        patches: 0,
        ids: 0,
        codec,
    };
    for (i, t) in tets.iter().enumerate() {
        if t.patch_offset != sizes.patches || t.id_offset != sizes.ids {
            return Err(corrupt(format!(
                "tet {i}: patch at {} and ids at {}, not where tet {} ends ({} and {}): the \
                 streaming writer lays blobs out in table order",
                t.patch_offset,
                t.id_offset,
                i.wrapping_sub(1) as isize,
                sizes.patches,
                sizes.ids
            )));
        }
        sizes.patches += t.patch_bytes as u64;
        sizes.ids += t.id_bytes as u64;
    }
    Ok(sizes)
}

fn write_streamed(
    file: &mut File,
    header: &Header,
    mut entries: Vec<SectionEntry>,
    directory: &RepositoryDirectory,
    feed: &mut dyn BlobFeed,
) -> io::Result<u64> {
    const ZEROS: [u8; 8] = [0; 8];
    let mut out = BufWriter::with_capacity(1 << 20, &mut *file);
    let directory_bytes = HEADER_SIZE + entries.len() * SECTION_ENTRY_SIZE;
    // The header and section table are written last, once the id blob's checksum is known.
    out.write_all(&vec![0u8; directory_bytes])?;
    let mut at = directory_bytes as u64;
    let mut ids_hash = crc32fast::Hasher::new();
    let mut textures_checksum = 0;
    let mut buffer = Vec::new();
    for entry in &entries {
        out.write_all(&ZEROS[..(entry.offset - at) as usize])?;
        match entry.kind {
            SECTION_DIAMONDS => out.write_all(bytemuck::cast_slice(&directory.diamonds))?,
            SECTION_TETS => out.write_all(bytemuck::cast_slice(&directory.tets))?,
            SECTION_ATTRIBUTE_ERRORS => out.write_all(bytemuck::cast_slice(
                directory.attribute_errors.as_deref().unwrap_or_default(),
            ))?,
            SECTION_PATCHES
            | SECTION_PACKED_PATCHES
            | SECTION_PACKED_STRIPS
            | SECTION_CODED_STRIPS => {
                for (i, t) in directory.tets.iter().enumerate() {
                    buffer.clear();
                    feed.patch(i, &mut buffer)?;
                    if buffer.len() != t.patch_bytes as usize
                        || patch_checksum(&buffer) != t.patch_checksum
                    {
                        return Err(mismatch(format!(
                            "tet {i}: the patch fed is {} bytes with checksum {:#010x}, its \
                             record says {} bytes and {:#010x}",
                            buffer.len(),
                            patch_checksum(&buffer),
                            t.patch_bytes,
                            t.patch_checksum
                        )));
                    }
                    out.write_all(&buffer)?;
                }
            }
            SECTION_IDS => {
                for (i, t) in directory.tets.iter().enumerate() {
                    buffer.clear();
                    feed.ids(i, &mut buffer)?;
                    if buffer.len() != t.id_bytes as usize {
                        return Err(mismatch(format!(
                            "tet {i}: the id stream fed is {} bytes, its record says {}",
                            buffer.len(),
                            t.id_bytes
                        )));
                    }
                    ids_hash.update(&buffer);
                    out.write_all(&buffer)?;
                }
            }
            SECTION_TEXTURES => {
                let textures = directory.textures.as_ref().expect("laid out with textures");
                textures_checksum = write_pages(&mut out, entry.offset, textures, feed)?;
            }
            kind => unreachable!("section kind {kind} is not laid out"),
        }
        at = entry.offset + entry.bytes;
    }
    out.flush()?;
    drop(out);
    let ids_checksum = ids_hash.finalize();
    let mut header = *header;
    for e in entries.iter_mut() {
        match e.kind {
            SECTION_IDS => e.checksum = ids_checksum,
            SECTION_TEXTURES => e.checksum = textures_checksum,
            _ => {}
        }
    }
    header.checksum = 0;
    let mut head = bytemuck::bytes_of(&header).to_vec();
    head.extend_from_slice(bytemuck::cast_slice(&entries));
    header.checksum = super::format::compute_checksum(&head);
    head[..HEADER_SIZE].copy_from_slice(bytemuck::bytes_of(&header));
    file.seek(SeekFrom::Start(0))?;
    file.write_all(&head)?;
    Ok(at)
}

/// Writes the texture section at file offset `offset`: its tables with the checksums left 0,
/// each fed page, then (seeking back) the page checksums. Returns the CRC-32 of the tables.
/// One page is held at a time.
fn write_pages(
    out: &mut BufWriter<&mut File>,
    offset: u64,
    textures: &TextureDirectory,
    feed: &mut dyn BlobFeed,
) -> io::Result<u32> {
    let pages = textures.page_count() as u32;
    let mut checksums = vec![0u32; pages as usize];
    let tables = textures.tables(&checksums);
    out.write_all(&tables)?;
    let page_bytes = textures.encoding.page_bytes();
    let mut page = Vec::with_capacity(page_bytes);
    for (global, checksum) in checksums.iter_mut().enumerate() {
        page.clear();
        feed.texture_page(global as u32, &mut page)?;
        if page.len() != page_bytes {
            return Err(mismatch(format!(
                "texture page {global}: {} bytes fed, a {} page is {page_bytes}",
                page.len(),
                textures.encoding.name()
            )));
        }
        *checksum = page_checksum(&page);
        out.write_all(&page)?;
    }
    let tables = textures.tables(&checksums);
    let end = out.stream_position()?;
    out.seek(SeekFrom::Start(offset))?;
    out.write_all(&tables)?;
    out.seek(SeekFrom::Start(end))?;
    Ok(crc32fast::hash(&tables))
}

fn mismatch(what: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, corrupt(what))
}
