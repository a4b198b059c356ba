//! Rewriting a repository with its patches stored another way (`tessera repack`): a raw
//! repository made before packing, or with `build --no-compress`, becomes a packed one without
//! a rebuild, and back. Everything but the patch blob's bytes and the records' patch
//! placement stays as it is — except on `repack_on_grid`, which also moves every position to a
//! coarser grid (`grid.rs`: what `build` does with the grid it chooses from the error).
//!
//! Two passes over the patches, neither holding more than one: the first validates each patch
//! and computes its new size and checksum (the streaming writer lays the directory out before
//! any blob byte), the second feeds the same bytes to the writer, which checks each against
//! its record. Memory: the directory.

use std::io;
use std::path::Path;

use super::format::{patch_checksum, PatchCodec, TetRecord};
use super::grid::{coarsen_patch, coarsened_directory};
use super::packed::{pack_patch, StripCoding};
use super::reader::{Repository, RepositoryError};
use super::streamed_writer::{write_repository_streamed, BlobFeed, RepositoryDirectory};
use super::textures::TextureDirectory;

/// The stored bytes of tet `i`'s patch under `codec`, its positions on the grid `shifts`
/// coarser (`grid.rs`), appended to `out`.
fn stored(
    source: &Repository,
    i: usize,
    codec: PatchCodec,
    shifts: [u32; 3],
    scratch: &mut Vec<u8>,
    out: &mut Vec<u8>,
) -> Result<(), RepositoryError> {
    let size = source.decoded_patch_bytes(i)?;
    let t = &source.tets()[i];
    match codec {
        PatchCodec::Raw => {
            let at = out.len();
            out.resize(at + size, 0);
            source.read_patch(i, &mut out[at..])?;
            if shifts != [0; 3] {
                coarsen_patch(&mut out[at..], t.vertex_count as usize, shifts);
            }
            Ok(())
        }
        PatchCodec::Packed | PatchCodec::PackedV1 | PatchCodec::Coded => {
            scratch.resize(size, 0);
            source.read_patch(i, scratch)?;
            if shifts != [0; 3] {
                coarsen_patch(scratch, t.vertex_count as usize, shifts);
            }
            pack_patch(
                scratch,
                t.vertex_count as usize,
                t.strip_index_count as usize,
                source.header().attributes,
                StripCoding::of(codec).expect("packed"),
                out,
            );
            Ok(())
        }
    }
}

/// Writes `source` to `path` (atomically, as every writer) with its patches stored as `codec`
/// says; returns the file's size. Every patch is validated first (`Repository::patch`): a
/// damaged source is an error naming the tet, and nothing is written.
pub fn repack(source: &Repository, codec: PatchCodec, path: &Path) -> Result<u64, RepositoryError> {
    repack_on_grid(source, codec, [0; 3], path)
}

/// `repack`, with every position moved to the grid `shifts` coarser per axis and the
/// directory with it (`grid::coarsened_directory`); `[0; 3]` is `repack`.
pub fn repack_on_grid(
    source: &Repository,
    codec: PatchCodec,
    shifts: [u32; 3],
    path: &Path,
) -> Result<u64, RepositoryError> {
    let (header, diamonds, source_tets) = match shifts {
        [0, 0, 0] => (
            *source.header(),
            source.diamonds().to_vec(),
            source.tets().to_vec(),
        ),
        shifts => coarsened_directory(source, shifts),
    };
    let (mut scratch, mut bytes) = (Vec::new(), Vec::new());
    let (mut patch_at, mut id_at) = (0u64, 0u64);
    let mut tets: Vec<TetRecord> = Vec::with_capacity(source.tets().len());
    for (i, t) in source_tets.iter().enumerate() {
        source.patch(i)?;
        bytes.clear();
        stored(source, i, codec, shifts, &mut scratch, &mut bytes)?;
        tets.push(TetRecord {
            patch_offset: patch_at,
            patch_bytes: bytes.len() as u32,
            patch_checksum: patch_checksum(&bytes),
            id_offset: id_at,
            ..*t
        });
        patch_at += bytes.len() as u64;
        id_at += t.id_bytes as u64;
    }
    let directory = RepositoryDirectory {
        header,
        diamonds,
        tets,
        codec,
        attribute_errors: source.attribute_errors().map(<[_]>::to_vec),
        // The textures are carried as they are, each page checked as it is copied.
        textures: source.textures().map(|t| TextureDirectory {
            shapes: t.shapes(),
            bands: t.bands(),
            encoding: t.encoding(),
        }),
    };
    let mut feed = Feed {
        source,
        codec,
        shifts,
        scratch: Vec::new(),
    };
    write_repository_streamed(path, &directory, &mut feed)
}

struct Feed<'a> {
    source: &'a Repository,
    codec: PatchCodec,
    shifts: [u32; 3],
    scratch: Vec<u8>,
}

impl BlobFeed for Feed<'_> {
    fn patch(&mut self, tet: usize, out: &mut Vec<u8>) -> io::Result<()> {
        stored(
            self.source,
            tet,
            self.codec,
            self.shifts,
            &mut self.scratch,
            out,
        )
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))
    }

    fn ids(&mut self, tet: usize, out: &mut Vec<u8>) -> io::Result<()> {
        let t = &self.source.tets()[tet];
        // In range: the reader checked every id range against the id blob.
        let start = t.id_offset as usize;
        out.extend_from_slice(&self.source.id_blob()[start..start + t.id_bytes as usize]);
        Ok(())
    }

    fn texture_page(&mut self, global: u32, out: &mut Vec<u8>) -> io::Result<()> {
        let textures = self.source.textures().ok_or_else(|| {
            io::Error::other("texture page asked of a repository without textures")
        })?;
        let page = textures
            .page(global)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))?;
        out.extend_from_slice(page);
        Ok(())
    }
}
