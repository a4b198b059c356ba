//! The texture section (`SECTION_TEXTURES`): written by both writers, read back as written,
//! absent from repositories without textures (whose bytes are what they were), and a damaged,
//! crafted or truncated section is an error naming what is wrong, never a panic or an
//! allocation sized by a count the file claims.

use tessera_core::repository::format::{
    compute_checksum, Header, SectionEntry, ATTR_ALL, CHECKSUM_OFFSET, HEADER_SIZE,
    SECTION_ENTRY_SIZE, SECTION_FLAG_OPTIONAL, SECTION_TEXTURES,
};
use tessera_core::repository::textures::{BandRecord, TextureRecord, TextureSectionHeader};
use tessera_core::repository::writer::write_repository_textured;
use tessera_core::repository::{
    write_repository, write_repository_streamed, BlobFeed, Repository, RepositoryContents,
    RepositoryDirectory, RepositoryError, TextureContents, TextureDirectory,
};
use tessera_core::texture::{Band, PageEncoding, TextureShape, Wrap, NO_TEXTURE, PAGE_BYTES};
use tessera_core::texture_codec::{decode_page, encode_page};

mod common;
use common::contents;

/// Two textures (5 pages and 1) and three bands, one of them untextured.
fn texture_directory() -> TextureDirectory {
    TextureDirectory {
        shapes: vec![
            TextureShape::new(200, 150, Wrap::Repeat, Wrap::Clamp).unwrap(),
            TextureShape::new(1, 1, Wrap::Clamp, Wrap::Repeat).unwrap(),
        ],
        bands: vec![
            Band::covering(0, 0.0, 0.9, 0).unwrap(),
            Band::covering(1, -2.5, 0.5, 1).unwrap(),
            Band::covering(5, 0.0, 0.5, NO_TEXTURE).unwrap(),
        ],
        encoding: PageEncoding::Rgba8,
    }
}

/// Page bytes that differ from page to page.
fn textures() -> TextureContents {
    let directory = texture_directory();
    let n = directory.page_count() as usize * PAGE_BYTES;
    let pages = (0..n)
        .map(|i| (i * 7 + i / PAGE_BYTES * 13) as u8)
        .collect();
    TextureContents { directory, pages }
}

fn geometry() -> RepositoryContents {
    contents(3, ATTR_ALL, false).0
}

fn image(textures: Option<&TextureContents>) -> Vec<u8> {
    let mut bytes = Vec::new();
    write_repository_textured(&mut bytes, &geometry(), textures).unwrap();
    bytes
}

/// The texture section's entry and its index in the section table.
fn texture_entry(bytes: &[u8]) -> (usize, SectionEntry) {
    let h: Header = bytemuck::pod_read_unaligned(&bytes[..HEADER_SIZE]);
    let entries: Vec<SectionEntry> = bytes
        [HEADER_SIZE..HEADER_SIZE + h.section_count as usize * SECTION_ENTRY_SIZE]
        .chunks_exact(SECTION_ENTRY_SIZE)
        .map(bytemuck::pod_read_unaligned)
        .collect();
    let i = entries
        .iter()
        .position(|e| e.kind == SECTION_TEXTURES)
        .expect("a texture section");
    (i, entries[i])
}

/// Bytes of the tables of `textures()`: header, 2 records, 3 bands, 6 CRCs (24 bytes).
const TABLES: usize = 16 + 2 * 32 + 3 * 16 + 24;

/// Stores `entry` with the checksum of the first `TABLES` bytes of the section as they are,
/// and the header's, so only the section's own checks can refuse an edit.
fn reseal(bytes: &mut [u8], entry: SectionEntry) {
    let (i, _) = texture_entry(bytes);
    let start = (entry.offset as usize).min(bytes.len());
    let end = (start + TABLES).min(bytes.len());
    let entry = SectionEntry {
        checksum: crc32fast::hash(&bytes[start..end]),
        ..entry
    };
    let at = HEADER_SIZE + i * SECTION_ENTRY_SIZE;
    bytes[at..at + SECTION_ENTRY_SIZE].copy_from_slice(bytemuck::bytes_of(&entry));
    let h: Header = bytemuck::pod_read_unaligned(&bytes[..HEADER_SIZE]);
    let table_end = HEADER_SIZE + h.section_count as usize * SECTION_ENTRY_SIZE;
    let sum = compute_checksum(&bytes[..table_end]);
    bytes[CHECKSUM_OFFSET..CHECKSUM_OFFSET + 4].copy_from_slice(&sum.to_le_bytes());
}

/// Edits the `T` at byte `at` of the texture section, reseals, and requires the open to fail
/// with a message mentioning `expected`.
fn check_edit<T: bytemuck::Pod>(at: usize, edit: impl FnOnce(&mut T), expected: &str) {
    let mut bytes = image(Some(&textures()));
    let (_, entry) = texture_entry(&bytes);
    let at = entry.offset as usize + at;
    let size = std::mem::size_of::<T>();
    let mut value: T = bytemuck::pod_read_unaligned(&bytes[at..at + size]);
    edit(&mut value);
    bytes[at..at + size].copy_from_slice(bytemuck::bytes_of(&value));
    reseal(&mut bytes, entry);
    let message = match Repository::from_bytes(bytes) {
        Ok(_) => panic!("an edit the reader should refuse ({expected}) was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        message.contains(expected),
        "{message:?} should mention {expected:?}"
    );
}

struct Feed<'a>(&'a RepositoryContents, &'a TextureContents);

impl BlobFeed for Feed<'_> {
    fn patch(&mut self, tet: usize, out: &mut Vec<u8>) -> std::io::Result<()> {
        let t = &self.0.tets[tet];
        let at = t.patch_offset as usize;
        out.extend_from_slice(&self.0.patch_blob[at..at + t.patch_bytes as usize]);
        Ok(())
    }

    fn ids(&mut self, tet: usize, out: &mut Vec<u8>) -> std::io::Result<()> {
        let t = &self.0.tets[tet];
        let at = t.id_offset as usize;
        out.extend_from_slice(&self.0.id_blob[at..at + t.id_bytes as usize]);
        Ok(())
    }

    fn texture_page(&mut self, global: u32, out: &mut Vec<u8>) -> std::io::Result<()> {
        let n = self.1.directory.encoding.page_bytes();
        out.extend_from_slice(&self.1.pages[global as usize * n..][..n]);
        Ok(())
    }
}

/// The geometry (its tets with the offsets a write gives them) and the directory that the
/// streaming writer is given for it with `t`.
fn streamed_parts(t: &TextureContents) -> (RepositoryContents, RepositoryDirectory) {
    let mut c = geometry();
    let mut plain = Vec::new();
    write_repository(&mut plain, &c).unwrap();
    c.tets = Repository::from_bytes(plain).unwrap().tets().to_vec();
    let directory = RepositoryDirectory {
        header: c.header,
        diamonds: c.diamonds.clone(),
        tets: c.tets.clone(),
        codec: c.codec,
        attribute_errors: None,
        textures: Some(t.directory.clone()),
    };
    (c, directory)
}

/// The geometry with `t` as the streaming writer (the build's) writes it, a page at a time.
fn streamed_bytes(t: &TextureContents) -> Vec<u8> {
    let (c, directory) = streamed_parts(t);
    let dir = tempfile::tempdir().unwrap();
    let streamed = dir.path().join("streamed.tsr");
    write_repository_streamed(&streamed, &directory, &mut Feed(&c, t)).unwrap();
    std::fs::read(&streamed).unwrap()
}

#[test]
fn the_section_round_trips_through_both_writers() {
    let t = textures();
    let bytes = image(Some(&t));
    let repo = Repository::from_bytes(bytes.clone()).unwrap();
    let table = repo.textures().expect("a texture section");
    assert_eq!(table.shapes(), t.directory.shapes);
    assert_eq!(table.bands(), t.directory.bands);
    assert_eq!(table.page_count(), 6);
    assert_eq!((table.first_page(0), table.first_page(1)), (0, 5));
    for g in 0..6 {
        let at = g as usize * PAGE_BYTES;
        assert_eq!(table.page(g).unwrap(), &t.pages[at..at + PAGE_BYTES]);
    }
    assert!(matches!(
        table.page(6),
        Err(RepositoryError::NoSuchPage { index: 6, count: 6 })
    ));
    let (_, entry) = texture_entry(&bytes);
    assert_eq!(entry.flags, SECTION_FLAG_OPTIONAL, "older readers skip it");
    assert_eq!(entry.bytes as usize, TABLES + 6 * PAGE_BYTES);
    assert_eq!(entry.offset % 8, 0);

    // The streaming writer (the build's) writes the same bytes, a page at a time.
    let streamed = streamed_bytes(&t);
    assert_eq!(streamed, bytes);
    let opened = Repository::from_bytes(streamed).unwrap();
    assert_eq!(
        opened.textures().unwrap().page(5).unwrap(),
        table.page(5).unwrap()
    );
}

/// BC1 pages: the encoding is recorded, pages are `BC1_PAGE_BYTES` and decode to close to
/// the texels they were made from, through both writers.
#[test]
fn bc1_pages_round_trip_through_both_writers() {
    let raw = textures();
    let mut directory = raw.directory.clone();
    directory.encoding = PageEncoding::Bc1;
    let pages: Vec<u8> = raw
        .pages
        .chunks(PAGE_BYTES)
        .flat_map(|p| encode_page(PageEncoding::Bc1, p))
        .collect();
    let t = TextureContents { directory, pages };
    let bytes = image(Some(&t));
    let repo = Repository::from_bytes(bytes.clone()).unwrap();
    let table = repo.textures().unwrap();
    assert_eq!(table.encoding(), PageEncoding::Bc1);
    let page_bytes = PageEncoding::Bc1.page_bytes();
    for g in 0..6 {
        let stored = table.page(g).unwrap();
        assert_eq!(stored, &t.pages[g as usize * page_bytes..][..page_bytes]);
        assert_eq!(
            decode_page(PageEncoding::Bc1, stored).unwrap().len(),
            PAGE_BYTES
        );
    }
    let (_, entry) = texture_entry(&bytes);
    assert_eq!(entry.bytes as usize, TABLES + 6 * page_bytes);
    assert_eq!(streamed_bytes(&t), bytes);
}

#[test]
fn without_textures_nothing_changes() {
    let bytes = image(None);
    let mut plain = Vec::new();
    write_repository(&mut plain, &geometry()).unwrap();
    assert_eq!(bytes, plain);
    let repo = Repository::from_bytes(bytes).unwrap();
    assert!(repo.textures().is_none());
    assert!(repo.sections().iter().all(|s| s.kind != SECTION_TEXTURES));
}

#[test]
fn a_damaged_page_is_an_error_for_that_page_only() {
    let mut bytes = image(Some(&textures()));
    let (_, entry) = texture_entry(&bytes);
    bytes[entry.offset as usize + TABLES + 2 * PAGE_BYTES + 1000] ^= 0x10;
    // Opening reads no page.
    let repo = Repository::from_bytes(bytes).unwrap();
    let table = repo.textures().unwrap();
    let err = table.page(2).unwrap_err();
    assert!(
        matches!(err, RepositoryError::PageChecksumMismatch { page: 2, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("texture page 2 is damaged"));
    assert!(table.page(1).is_ok() && table.page(3).is_ok());
    // Still refused when asked again.
    assert!(table.page(2).is_err());
}

#[test]
fn damaged_tables_fail_their_checksum() {
    let mut bytes = image(Some(&textures()));
    let (_, entry) = texture_entry(&bytes);
    bytes[entry.offset as usize + 16 + 32 + 8] ^= 1;
    let err = Repository::from_bytes(bytes).unwrap_err();
    assert!(
        matches!(&err, RepositoryError::SectionChecksumMismatch { section, .. } if section == "texture section"),
        "{err}"
    );
}

#[test]
fn every_header_field_is_checked_against_the_section_size() {
    type H = TextureSectionHeader;
    let size = "take";
    check_edit::<H>(0, |h| h.texture_count += 1, size);
    check_edit::<H>(0, |h| h.texture_count = u32::MAX, size);
    check_edit::<H>(0, |h| h.band_count = u32::MAX, size);
    check_edit::<H>(0, |h| h.band_count -= 1, size);
    check_edit::<H>(0, |h| h.page_count = u32::MAX, size);
    check_edit::<H>(0, |h| h.page_count += 1, size);
    check_edit::<H>(0, |h| h.encoding = 7, "page encoding 7 is not one");
    // BC1 pages are smaller: the same section read as BC1 is too long.
    check_edit::<H>(0, |h| h.encoding = 1, "bc1 pages take");
}

#[test]
fn every_texture_record_field_is_checked() {
    type R = TextureRecord;
    let (first, second) = (16, 16 + 32);
    check_edit::<R>(first, |r| r.width = 0, "not a texture shape");
    check_edit::<R>(first, |r| r.height = 70_000, "not a texture shape");
    check_edit::<R>(first, |r| r.wrap_u = 2, "not a texture shape");
    check_edit::<R>(second, |r| r.wrap_v = 7, "not a texture shape");
    check_edit::<R>(first, |r| r.levels += 1, "texture 0 (200 × 150)");
    check_edit::<R>(first, |r| r.page_count -= 1, "texture 0");
    check_edit::<R>(second, |r| r.first_page = 4, "from page 5 after");
    check_edit::<R>(second, |r| r.reserved = 3, "reserved 3");
    // A texture larger than its pages: its shape asks for more pages than the section holds.
    check_edit::<R>(
        second,
        |r| {
            (r.width, r.height, r.levels, r.page_count) = (256, 1, 2, 3);
        },
        "lists 6 pages, its textures have 8",
    );
}

#[test]
fn every_band_field_is_checked() {
    type B = BandRecord;
    let band = |i: usize| 16 + 2 * 32 + 16 * i;
    let expected = "texture bands overlap";
    check_edit::<B>(band(0), |b| b.span = 0, expected);
    check_edit::<B>(band(1), |b| b.texture = 2, expected);
    check_edit::<B>(band(2), |b| b.start = 2, expected);
    check_edit::<B>(band(0), |b| b.span = u32::MAX, expected);
}

#[test]
fn truncated_and_resized_sections_are_refused() {
    let bytes = image(Some(&textures()));
    let (_, entry) = texture_entry(&bytes);
    // Cut anywhere inside the section: the section table says more than the file holds.
    for cut in [
        1,
        8,
        16,
        TABLES - 4,
        TABLES + 3,
        TABLES + PAGE_BYTES,
        6 * PAGE_BYTES,
    ] {
        let len = entry.offset as usize + TABLES + 6 * PAGE_BYTES - cut;
        let message = Repository::from_bytes(bytes[..len].to_vec())
            .unwrap_err()
            .to_string();
        assert!(message.contains("exceeds the file"), "{message}");
    }
    // The section's entry shrunk with the file: its own size check refuses it.
    for keep in [0usize, 8, 16, TABLES, TABLES + 5 * PAGE_BYTES] {
        let mut cut = bytes[..entry.offset as usize + keep].to_vec();
        let shrunk = SectionEntry {
            bytes: keep as u64,
            ..entry
        };
        reseal(&mut cut, shrunk);
        let message = Repository::from_bytes(cut).unwrap_err().to_string();
        assert!(message.contains("texture section is"), "{message}");
    }
}

#[test]
fn writers_refuse_invalid_textures() {
    let mut t = textures();
    t.pages.truncate(PAGE_BYTES);
    let err = write_repository_textured(Vec::new(), &geometry(), Some(&t)).unwrap_err();
    assert!(err.to_string().contains("pages"), "{err}");
    let mut t = textures();
    t.directory.bands[1].texture = 9;
    let err = write_repository_textured(Vec::new(), &geometry(), Some(&t)).unwrap_err();
    assert!(err.to_string().contains("bands"), "{err}");
    let mut t = textures();
    t.directory.shapes[0].width = 0;
    let err = write_repository_textured(Vec::new(), &geometry(), Some(&t)).unwrap_err();
    assert!(err.to_string().contains("texture 0"), "{err}");
    // A streamed write fed a short page leaves no file.
    struct Short<'a>(Feed<'a>);
    impl BlobFeed for Short<'_> {
        fn patch(&mut self, tet: usize, out: &mut Vec<u8>) -> std::io::Result<()> {
            self.0.patch(tet, out)
        }
        fn ids(&mut self, tet: usize, out: &mut Vec<u8>) -> std::io::Result<()> {
            self.0.ids(tet, out)
        }
        fn texture_page(&mut self, _: u32, out: &mut Vec<u8>) -> std::io::Result<()> {
            out.push(0);
            Ok(())
        }
    }
    let t = textures();
    let (c, directory) = streamed_parts(&t);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("short.tsr");
    let err = write_repository_streamed(&path, &directory, &mut Short(Feed(&c, &t))).unwrap_err();
    assert!(err.to_string().contains("texture page 0"), "{err}");
    assert!(!path.exists());
}
