//! The attribute error table (`SECTION_ATTRIBUTE_ERRORS`): written by both writers, read back
//! as written, absent from repositories without it (which open as before), and a damaged or
//! crafted table is an error naming it, never a panic.

use tessera_core::repository::format::{
    compute_checksum, AttributeErrorRecord, Header, SectionEntry, ATTRIBUTE_ERROR_RECORD_SIZE,
    ATTR_ALL, CHECKSUM_OFFSET, HEADER_SIZE, SECTION_ATTRIBUTE_ERRORS, SECTION_ENTRY_SIZE,
    SECTION_FLAG_OPTIONAL,
};
use tessera_core::repository::{
    write_repository, write_repository_file, write_repository_streamed, BlobFeed, Repository,
    RepositoryContents, RepositoryDirectory,
};

mod common;
use common::contents;

/// Errors that differ from diamond to diamond, as a build's would.
fn records(n: usize) -> Vec<AttributeErrorRecord> {
    (0..n)
        .map(|i| AttributeErrorRecord {
            colour: 3.5 * i as f32,
            normal_degrees: (i % 7) as f32,
            uv: 0.001 * i as f32,
            reserved: 0.0,
        })
        .collect()
}

fn with_table() -> RepositoryContents {
    let (mut c, _) = contents(3, ATTR_ALL, false);
    c.attribute_errors = Some(records(c.diamonds.len()));
    c
}

fn image(contents: &RepositoryContents) -> Vec<u8> {
    let mut bytes = Vec::new();
    write_repository(&mut bytes, contents).unwrap();
    bytes
}

fn sections_of(bytes: &[u8]) -> Vec<SectionEntry> {
    let h: Header = bytemuck::pod_read_unaligned(&bytes[..HEADER_SIZE]);
    bytes[HEADER_SIZE..HEADER_SIZE + h.section_count as usize * SECTION_ENTRY_SIZE]
        .chunks_exact(SECTION_ENTRY_SIZE)
        .map(bytemuck::pod_read_unaligned)
        .collect()
}

/// The table's entry, and its index in the section table.
fn table_entry(bytes: &[u8]) -> (usize, SectionEntry) {
    let entries = sections_of(bytes);
    let i = entries
        .iter()
        .position(|e| e.kind == SECTION_ATTRIBUTE_ERRORS)
        .expect("an attribute error table");
    (i, entries[i])
}

/// Stores the table's checksum (over `bytes` as they are) and the header's, so only the
/// record checks can refuse an edit.
fn reseal(bytes: &mut [u8], entry: SectionEntry) {
    let (i, _) = table_entry(bytes);
    let end = (entry.offset + entry.bytes).min(bytes.len() as u64);
    let entry = SectionEntry {
        checksum: crc32fast::hash(&bytes[entry.offset as usize..end as usize]),
        ..entry
    };
    let at = HEADER_SIZE + i * SECTION_ENTRY_SIZE;
    bytes[at..at + SECTION_ENTRY_SIZE].copy_from_slice(bytemuck::bytes_of(&entry));
    let h: Header = bytemuck::pod_read_unaligned(&bytes[..HEADER_SIZE]);
    let table_end = HEADER_SIZE + h.section_count as usize * SECTION_ENTRY_SIZE;
    let sum = compute_checksum(&bytes[..table_end]);
    bytes[CHECKSUM_OFFSET..CHECKSUM_OFFSET + 4].copy_from_slice(&sum.to_le_bytes());
}

/// Edits the table's record 1 and reseals; the open must fail mentioning `expected`.
fn check_record(edit: impl FnOnce(&mut AttributeErrorRecord), expected: &str) {
    let mut bytes = image(&with_table());
    let (_, entry) = table_entry(&bytes);
    let at = entry.offset as usize + ATTRIBUTE_ERROR_RECORD_SIZE;
    let mut r: AttributeErrorRecord =
        bytemuck::pod_read_unaligned(&bytes[at..at + ATTRIBUTE_ERROR_RECORD_SIZE]);
    edit(&mut r);
    bytes[at..at + ATTRIBUTE_ERROR_RECORD_SIZE].copy_from_slice(bytemuck::bytes_of(&r));
    reseal(&mut bytes, entry);
    let message = Repository::from_bytes(bytes).unwrap_err().to_string();
    assert!(
        message.contains(expected),
        "{message:?} should mention {expected:?}"
    );
}

struct Feed<'a>(&'a RepositoryContents);

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
}

#[test]
fn the_table_round_trips_through_both_writers() {
    let c = with_table();
    let bytes = image(&c);
    let repo = Repository::from_bytes(bytes.clone()).unwrap();
    assert_eq!(repo.attribute_errors(), c.attribute_errors.as_deref());
    let (_, entry) = table_entry(&bytes);
    assert_eq!(
        entry.flags, SECTION_FLAG_OPTIONAL,
        "older readers must skip it"
    );
    assert_eq!(
        entry.bytes,
        (c.diamonds.len() * ATTRIBUTE_ERROR_RECORD_SIZE) as u64
    );
    // The streaming writer (the build's) writes the same bytes.
    let dir = tempfile::tempdir().unwrap();
    let mut tets = c.tets.clone();
    for t in &mut tets {
        let at = t.patch_offset as usize;
        t.patch_checksum = tessera_core::repository::format::patch_checksum(
            &c.patch_blob[at..at + t.patch_bytes as usize],
        );
    }
    let directory = RepositoryDirectory {
        header: c.header,
        diamonds: c.diamonds.clone(),
        tets,
        codec: c.codec,
        attribute_errors: c.attribute_errors.clone(),
        textures: None,
    };
    let streamed = dir.path().join("streamed.tsr");
    write_repository_streamed(&streamed, &directory, &mut Feed(&c)).unwrap();
    assert_eq!(std::fs::read(&streamed).unwrap(), bytes);
    let opened = Repository::open(&streamed).unwrap();
    assert_eq!(opened.attribute_errors(), c.attribute_errors.as_deref());
    opened.validate_patches().unwrap();
}

#[test]
fn a_repository_without_the_table_opens_as_before() {
    let (without, _) = contents(3, ATTR_ALL, false);
    let bytes = image(&without);
    assert!(sections_of(&bytes)
        .iter()
        .all(|e| e.kind != SECTION_ATTRIBUTE_ERRORS));
    let repo = Repository::from_bytes(bytes.clone()).unwrap();
    assert!(repo.attribute_errors().is_none());
    repo.validate_patches().unwrap();
    // The table adds its entry, the padding to 8 bytes before it, and its records.
    let with = image(&with_table());
    let added = SECTION_ENTRY_SIZE + without.diamonds.len() * ATTRIBUTE_ERROR_RECORD_SIZE;
    assert!(
        (added..added + 8).contains(&(with.len() - bytes.len())),
        "{} bytes more",
        with.len() - bytes.len()
    );
}

#[test]
fn crafted_records_are_refused_naming_the_table() {
    check_record(|r| r.colour = f32::NAN, "not all finite");
    check_record(|r| r.normal_degrees = f32::INFINITY, "not all finite");
    check_record(|r| r.uv = -0.5, "non-negative");
    check_record(|r| r.reserved = 1.0, "reserved field 1");
    // A record short: the section's length is checked against the diamond count.
    let mut bytes = image(&with_table());
    let (_, entry) = table_entry(&bytes);
    let short = SectionEntry {
        bytes: entry.bytes - ATTRIBUTE_ERROR_RECORD_SIZE as u64,
        ..entry
    };
    bytes.truncate(bytes.len() - ATTRIBUTE_ERROR_RECORD_SIZE);
    reseal(&mut bytes, short);
    let message = Repository::from_bytes(bytes).unwrap_err().to_string();
    assert!(
        message.contains("attribute error table is") && message.contains("records take"),
        "{message}"
    );
    // A flipped bit without the checksum resealed: the table's checksum catches it.
    let mut bytes = image(&with_table());
    let (_, entry) = table_entry(&bytes);
    bytes[entry.offset as usize + 5] ^= 0x10;
    let message = Repository::from_bytes(bytes).unwrap_err().to_string();
    assert!(
        message.contains("attribute error table checksum mismatch"),
        "{message}"
    );
}

#[test]
fn every_truncation_and_flipped_table_byte_is_an_error() {
    let bytes = image(&with_table());
    let (_, entry) = table_entry(&bytes);
    let table = entry.offset as usize..(entry.offset + entry.bytes) as usize;
    // The table ends the file: cutting anywhere in it, or before it, is refused on open.
    for len in (0..bytes.len()).step_by(7).chain(table.clone()) {
        assert!(
            Repository::from_bytes(bytes[..len].to_vec()).is_err(),
            "truncated to {len} of {} bytes and accepted",
            bytes.len()
        );
    }
    for i in table {
        let mut flipped = bytes.clone();
        flipped[i] ^= 0x01;
        assert!(Repository::from_bytes(flipped).is_err(), "byte {i} flipped");
    }
    // Through the file system too.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.tsr");
    write_repository_file(&path, &with_table()).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), bytes);
}

#[test]
fn the_writers_refuse_a_bad_table() {
    let mut c = with_table();
    c.attribute_errors.as_mut().unwrap().pop();
    let err = write_repository(Vec::new(), &c).unwrap_err().to_string();
    assert!(err.contains("records for"), "{err}");
    let mut c = with_table();
    c.attribute_errors.as_mut().unwrap()[1].colour = f32::NAN;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.tsr");
    assert!(write_repository_file(&path, &c).is_err());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}
