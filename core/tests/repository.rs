//! Repository format: write → open round trips over dimensions and attribute masks, and a bad
//! file of every kind we can think of is an error, never a panic.

use std::path::Path;

use proptest::prelude::*;
use tessera_core::repository::format::{
    compute_checksum, patch_checksum, DiamondRecord, Header, SectionEntry, TetRecord, ATTR_ALL,
    ATTR_NORMALS, ATTR_UVS, CHECKSUM_OFFSET, FORMAT_VERSION, HEADER_SIZE, NO_INDEX,
    SECTION_DIAMONDS, SECTION_ENTRY_SIZE, SECTION_FLAG_OPTIONAL, SECTION_IDS, SECTION_PATCHES,
    SECTION_TETS, TET_RECORD_SIZE,
};
use tessera_core::repository::global_ids::encode_global_ids;
use tessera_core::repository::patch::{patch_bytes, StripIndices};
use tessera_core::repository::{
    write_repository, write_repository_file, Repository, RepositoryError,
};

mod common;
use common::{contents, unstripify, R};

fn image(dimension: u32, attributes: u32) -> Vec<u8> {
    let mut bytes = Vec::new();
    write_repository(&mut bytes, &contents(dimension, attributes, false).0).unwrap();
    bytes
}

/// Opens `repo` fully: every patch parsed and every triangle and position decoded.
fn open_all(bytes: Vec<u8>) -> Result<(), RepositoryError> {
    let repo = Repository::from_bytes(bytes)?;
    for i in 0..repo.tets().len() {
        let p = repo.patch(i)?;
        let p = p.view();
        let n = p.vertex_count() as u32;
        for t in p.triangles() {
            assert!(
                t.iter().all(|&v| v < n),
                "triangle {t:?} of a {n}-vertex patch"
            );
            let _ = t.map(|v| p.position(v as usize));
        }
    }
    repo.validate_patches()
}

fn check_round_trip(dimension: u32, attributes: u32, big: bool, dir: &Path) {
    let (contents, patches) = contents(dimension, attributes, big);
    let path = dir.join(format!("d{dimension}-a{attributes}-{big}.tsr"));
    let written = write_repository_file(&path, &contents).unwrap();
    let repo = Repository::open(&path).unwrap();
    assert_eq!(repo.file_bytes(), written);
    assert_eq!(std::fs::metadata(&path).unwrap().len(), written);

    let h = repo.header();
    let expected = Header {
        magic: *b"TESSERA\0",
        version: FORMAT_VERSION,
        section_count: 4,
        diamond_count: 2,
        tet_count: 10,
        checksum: h.checksum,
        ..contents.header
    };
    assert_eq!(*h, expected);
    let bytes = std::fs::read(&path).unwrap();
    let table_end = (HEADER_SIZE + 4 * SECTION_ENTRY_SIZE) as u64;
    let blob_bytes = contents.patch_blob.len() as u64;
    let expected_sections = [
        (SECTION_DIAMONDS, table_end, 2 * 56),
        (SECTION_TETS, table_end + 2 * 56, 10 * 88),
        (SECTION_PATCHES, table_end + 2 * 56 + 10 * 88, blob_bytes),
        (
            SECTION_IDS,
            (table_end + 2 * 56 + 10 * 88 + blob_bytes).next_multiple_of(8),
            contents.id_blob.len() as u64,
        ),
    ];
    for (entry, (kind, offset, size)) in sections_of(&bytes).iter().zip(expected_sections) {
        assert_eq!(
            (entry.kind, entry.offset, entry.bytes, entry.flags),
            (kind, offset, size, 0)
        );
    }
    assert_eq!(repo.diamonds(), &contents.diamonds[..]);
    // The writer filled the patch checksums, nothing else.
    for (stored, given) in repo.tets().iter().zip(&contents.tets) {
        let start = given.patch_offset as usize;
        let patch = &contents.patch_blob[start..start + given.patch_bytes as usize];
        assert_eq!(
            *stored,
            TetRecord {
                patch_checksum: patch_checksum(patch),
                ..*given
            }
        );
    }
    assert_eq!(repo.patch_blob(), &contents.patch_blob[..]);
    assert_eq!(repo.id_blob(), &contents.id_blob[..]);
    for (i, original) in patches.iter().enumerate() {
        let view = repo.patch(i).unwrap();
        let view = view.view();
        assert_eq!(view.to_patch_data(), *original, "tet {i}");
        assert_eq!(
            view.global_ids().collect::<Vec<_>>(),
            original.global_ids,
            "tet {i}"
        );
        assert_eq!(
            view.bytes().len(),
            patch_bytes(view.vertex_count(), original.strip.len(), attributes)
        );
        let triangles: Vec<[u32; 3]> = view.triangles().collect();
        assert_eq!(triangles, unstripify(&original.strip), "tet {i}");
        assert_eq!(triangles.len() as u32, view.triangle_count());
        assert_eq!(
            matches!(view.strip(), StripIndices::U32(_)),
            original.vertex_count() > 65_535
        );
        for (k, &s) in original.strip.iter().enumerate() {
            assert_eq!(view.strip_index(k), (s != R).then_some(s));
        }
    }
    repo.validate_patches().unwrap();

    // In memory, through the same checks.
    let mut bytes = Vec::new();
    assert_eq!(write_repository(&mut bytes, &contents).unwrap(), written);
    assert_eq!(bytes, std::fs::read(&path).unwrap());
    let again = Repository::from_bytes(bytes).unwrap();
    assert_eq!(again.tets(), repo.tets());
}

#[test]
fn round_trip_every_dimension_and_attribute_mask() {
    let dir = tempfile::tempdir().unwrap();
    for dimension in [2, 3] {
        for attributes in 0..=ATTR_ALL {
            check_round_trip(dimension, attributes, false, dir.path());
        }
    }
    check_round_trip(3, ATTR_ALL, true, dir.path());
    check_round_trip(2, 0, true, dir.path());
    // Only the repositories remain: no temporary files.
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names.len(), 18, "{names:?}");
    assert!(
        names
            .iter()
            .all(|n| n.ends_with(".tsr") && !n.starts_with('.')),
        "{names:?}"
    );
}

#[test]
fn big_patch_uses_u32_indices() {
    let (contents, patches) = contents(3, ATTR_NORMALS, true);
    let mut bytes = Vec::new();
    write_repository(&mut bytes, &contents).unwrap();
    let repo = Repository::from_bytes(bytes).unwrap();
    let view = repo.patch(9).unwrap();
    let view = view.view();
    let StripIndices::U32(strip) = view.strip() else {
        panic!("a 70,000-vertex patch needs u32 indices")
    };
    // 70,000 indices, two restarts (the second segment starts at an even position), five.
    assert_eq!(strip.len(), 70_007);
    assert_eq!(strip[70_000..70_002], [u32::MAX, u32::MAX]);
    assert_eq!(view.strip_index(69_999), Some(69_999));
    assert_eq!(view.position(69_999), [69_999, 69_999 * 7 + 9, 9]);
    assert_eq!(view.global_ids().nth(69_999), Some(969_999));
    assert_eq!(
        view.triangles().count(),
        unstripify(&patches[9].strip).len()
    );
    assert!(matches!(
        repo.patch(8).unwrap().view().strip(),
        StripIndices::U16(_)
    ));
}

// ---- Corruption: every case must be an error, never a panic. ----

fn header_of(bytes: &[u8]) -> Header {
    bytemuck::pod_read_unaligned(&bytes[..HEADER_SIZE])
}

/// The section table as far as the image holds it (at most 64 entries).
fn sections_of(bytes: &[u8]) -> Vec<SectionEntry> {
    let count = (header_of(bytes).section_count as usize).min(64);
    bytes[HEADER_SIZE..]
        .chunks_exact(SECTION_ENTRY_SIZE)
        .take(count)
        .map(bytemuck::pod_read_unaligned)
        .collect()
}

fn write_sections(bytes: &mut [u8], entries: &[SectionEntry]) {
    let raw: &[u8] = bytemuck::cast_slice(entries);
    bytes[HEADER_SIZE..HEADER_SIZE + raw.len()].copy_from_slice(raw);
}

/// The in-file byte range of the first section of `kind`, if it lies inside the image.
fn section_range(bytes: &[u8], kind: u32) -> Option<std::ops::Range<usize>> {
    let e = sections_of(bytes).into_iter().find(|e| e.kind == kind)?;
    let end = e.offset.checked_add(e.bytes)?;
    (end <= bytes.len() as u64).then_some(e.offset as usize..end as usize)
}

/// Stores the correct header checksum and the diamond and tet tables' section checksums (if
/// the image is long enough to hold them); patch checksums and the id blob's are left as
/// they are.
fn seal_directory(bytes: &mut [u8]) {
    if bytes.len() < HEADER_SIZE {
        return;
    }
    let count = (header_of(bytes).section_count as usize).min(64);
    let table_end = HEADER_SIZE + count * SECTION_ENTRY_SIZE;
    if bytes.len() < table_end {
        return;
    }
    let mut entries = sections_of(bytes);
    for e in &mut entries {
        if let Some(end) = e.offset.checked_add(e.bytes) {
            if end <= bytes.len() as u64 && matches!(e.kind, SECTION_DIAMONDS | SECTION_TETS) {
                e.checksum = crc32fast::hash(&bytes[e.offset as usize..end as usize]);
            }
        }
    }
    write_sections(bytes, &entries);
    let sum = compute_checksum(&bytes[..table_end]);
    bytes[CHECKSUM_OFFSET..CHECKSUM_OFFSET + 4].copy_from_slice(&sum.to_le_bytes());
}

/// Stores every checksum a writer would have: each patch's whose range lies in the patch blob,
/// the id blob's, then the directory's (`seal_directory`).
fn seal(bytes: &mut [u8]) {
    if bytes.len() < HEADER_SIZE
        || bytes.len() < HEADER_SIZE + (header_of(bytes).section_count as usize).min(64) * 32
    {
        return;
    }
    if let (Some(tets), Some(blob)) = (
        section_range(bytes, SECTION_TETS),
        section_range(bytes, SECTION_PATCHES),
    ) {
        for at in tets.clone().step_by(TET_RECORD_SIZE) {
            if at + TET_RECORD_SIZE > tets.end {
                break;
            }
            let mut t: TetRecord = bytemuck::pod_read_unaligned(&bytes[at..at + TET_RECORD_SIZE]);
            let end = t.patch_offset as u128 + t.patch_bytes as u128;
            if end <= blob.len() as u128 {
                let start = blob.start + t.patch_offset as usize;
                t.patch_checksum = patch_checksum(&bytes[start..start + t.patch_bytes as usize]);
                bytes[at..at + TET_RECORD_SIZE].copy_from_slice(bytemuck::bytes_of(&t));
            }
        }
    }
    if let Some(ids) = section_range(bytes, SECTION_IDS) {
        let sum = crc32fast::hash(&bytes[ids]);
        let mut entries = sections_of(bytes);
        for e in entries.iter_mut().filter(|e| e.kind == SECTION_IDS) {
            e.checksum = sum;
        }
        write_sections(bytes, &entries);
    }
    seal_directory(bytes);
}

fn edit_header(bytes: &mut [u8], f: impl FnOnce(&mut Header)) {
    let mut h = header_of(bytes);
    f(&mut h);
    bytes[..HEADER_SIZE].copy_from_slice(bytemuck::bytes_of(&h));
}

/// Edits the section entry of `kind`.
fn edit_section(bytes: &mut [u8], kind: u32, f: impl FnOnce(&mut SectionEntry)) {
    let mut entries = sections_of(bytes);
    f(entries.iter_mut().find(|e| e.kind == kind).unwrap());
    write_sections(bytes, &entries);
}

fn section_offset(bytes: &[u8], kind: u32) -> usize {
    sections_of(bytes)
        .into_iter()
        .find(|e| e.kind == kind)
        .unwrap()
        .offset as usize
}

fn edit_tet(bytes: &mut [u8], i: usize, f: impl FnOnce(&mut TetRecord)) {
    let at = section_offset(bytes, SECTION_TETS) + i * TET_RECORD_SIZE;
    let mut t: TetRecord = bytemuck::pod_read_unaligned(&bytes[at..at + TET_RECORD_SIZE]);
    f(&mut t);
    bytes[at..at + TET_RECORD_SIZE].copy_from_slice(bytemuck::bytes_of(&t));
}

fn edit_diamond(bytes: &mut [u8], i: usize, f: impl FnOnce(&mut DiamondRecord)) {
    let size = std::mem::size_of::<DiamondRecord>();
    let at = section_offset(bytes, SECTION_DIAMONDS) + i * size;
    let mut d: DiamondRecord = bytemuck::pod_read_unaligned(&bytes[at..at + size]);
    f(&mut d);
    bytes[at..at + size].copy_from_slice(bytemuck::bytes_of(&d));
}

/// Absolute byte offset of tet `i`'s patch in the image, and the tet.
fn patch_of(bytes: &[u8], i: usize) -> (usize, TetRecord) {
    let at = section_offset(bytes, SECTION_TETS) + i * TET_RECORD_SIZE;
    let tet: TetRecord = bytemuck::pod_read_unaligned(&bytes[at..at + TET_RECORD_SIZE]);
    (
        section_offset(bytes, SECTION_PATCHES) + tet.patch_offset as usize,
        tet,
    )
}

/// Applies `corrupt` to a valid image, reseals the checksum, and expects an error whose message
/// contains `expected` from `open` or, failing that, from parsing the patches.
fn check(corrupt: impl FnOnce(&mut Vec<u8>), expected: &str) {
    let mut bytes = image(3, ATTR_ALL);
    corrupt(&mut bytes);
    seal(&mut bytes);
    match open_all(bytes) {
        Ok(()) => panic!("corruption expecting {expected:?} was accepted"),
        Err(e) => {
            let message = e.to_string();
            assert!(
                message.contains(expected),
                "{message:?} should mention {expected:?}"
            );
        }
    }
}

#[test]
fn structural_corruption_is_caught_behind_a_valid_checksum() {
    // Header.
    check(
        |b| edit_header(b, |h| h.dimension = 4),
        "dimension 4 is not 2 or 3",
    );
    check(
        |b| edit_header(b, |h| h.attributes = 8),
        "unknown attribute bits 0x8",
    );
    check(
        |b| edit_header(b, |h| h.lattice_bits = 31),
        "lattice bits 31",
    );
    check(|b| edit_header(b, |h| h.lattice_unit = 0.0), "lattice unit");
    check(|b| edit_header(b, |h| h.origin[1] = f64::NAN), "origin");
    check(|b| edit_header(b, |h| h.bbox_max[2] = -5.0), "inverted");
    check(
        |b| edit_header(b, |h| h.root_tet_count = 11),
        "11 root tets but only 10",
    );
    // Absurd counts: an error, not an allocation.
    check(
        |b| edit_header(b, |h| h.diamond_count = 1 << 60),
        "tables are indexed by u32",
    );
    check(
        |b| edit_header(b, |h| h.tet_count = u64::MAX),
        "tables are indexed by u32",
    );
    check(
        |b| edit_header(b, |h| h.diamond_count = 3),
        "diamond table is 112 bytes, but 3 records take 3 × 56",
    );
    check(
        |b| edit_header(b, |h| h.tet_count = 1 << 30),
        "tet table is 880 bytes, but 1073741824 records",
    );
    check(
        |b| edit_header(b, |h| h.input_vertex_count = 1 << 40),
        "1099511627776 input vertices: global ids are u32",
    );
    check(
        |b| edit_header(b, |h| h.section_count = 3),
        "3 sections listed, not 4..=64",
    );
    check(
        |b| edit_header(b, |h| h.section_count = 1000),
        "1000 sections listed",
    );
    // Sections: sizes and offsets checked with checked arithmetic, aligned, after the
    // section table, not overlapping, the file ending with the last.
    check(
        |b| edit_section(b, SECTION_PATCHES, |e| e.bytes = 1 << 60),
        "patch blob of 1152921504606846976 bytes",
    );
    check(
        |b| edit_section(b, SECTION_PATCHES, |e| e.offset = u64::MAX - 7),
        "patch blob of",
    );
    check(
        |b| edit_section(b, SECTION_DIAMONDS, |e| e.offset = 332),
        "diamond table offset 332 is not a multiple of 8",
    );
    check(
        |b| edit_section(b, SECTION_DIAMONDS, |e| e.offset = 0),
        "overlaps the section table, which ends at 328",
    );
    check(
        |b| edit_section(b, SECTION_TETS, |e| e.offset -= 8),
        "tet table at 432..1312 overlaps diamond table at 328..440",
    );
    check(|b| b.extend_from_slice(&[0; 8]), "sections end at");
    check(
        |b| edit_section(b, SECTION_IDS, |e| e.bytes -= 1),
        "sections end at",
    );
    check(
        |b| edit_section(b, SECTION_IDS, |e| e.bytes = 1 << 60),
        "id blob of",
    );
    check(
        |b| edit_section(b, SECTION_PATCHES, |e| e.bytes += 8),
        "overlaps patch blob",
    );
    check(
        |b| edit_section(b, SECTION_IDS, |e| e.kind = SECTION_DIAMONDS),
        "section 3: a second diamond table",
    );
    check(
        |b| edit_section(b, SECTION_IDS, |e| e.kind = 10),
        "kind 10, which this build does not know and may not skip",
    );
    check(
        |b| {
            edit_section(b, SECTION_IDS, |e| {
                e.kind = 10;
                e.flags = SECTION_FLAG_OPTIONAL;
            })
        },
        "no id blob section",
    );
    check(
        |b| edit_section(b, SECTION_TETS, |e| e.flags = 2),
        "unknown flags 0x2",
    );
    check(
        |b| edit_section(b, SECTION_TETS, |e| e.reserved = 1),
        "reserved field 1",
    );

    // Diamonds.
    check(
        |b| edit_diamond(b, 1, |d| d.parents[0] = 7),
        "diamond 1: parent 0 is 7, not a diamond stored before it",
    );
    check(
        |b| edit_diamond(b, 1, |d| d.parents[0] = 1),
        "diamond 1: parent 0 is 1",
    );
    check(
        |b| {
            edit_diamond(b, 0, |d| {
                d.parents[0] = 1;
                d.parent_count = 1;
            })
        },
        "diamond 0: parent 0 is 1, not a diamond stored before it",
    );
    check(
        |b| edit_diamond(b, 1, |d| d.tet_count = 3),
        "diamond 1: 3 simplices, but 2 tets belong to it",
    );
    check(
        |b| {
            edit_diamond(b, 1, |d| {
                d.parents[0] = NO_INDEX;
                d.parent_count = 0;
            })
        },
        "tet 2: parent diamond 0 is not a parent of its diamond 1 (parents [])",
    );
    check(
        |b| edit_diamond(b, 1, |d| d.parents[2] = 0),
        "diamond 1: unused parent slot 2",
    );
    check(
        |b| edit_diamond(b, 0, |d| d.parent_count = 5),
        "diamond 0: 5 parents",
    );
    check(
        |b| edit_diamond(b, 0, |d| d.error = 0.0),
        "diamond 0: error 0",
    );
    check(
        |b| edit_diamond(b, 0, |d| d.radius = f32::NAN),
        "diamond 0: bounding sphere",
    );
    check(
        |b| edit_diamond(b, 1, |d| d.center[2] = f32::INFINITY),
        "diamond 1: bounding sphere",
    );
    check(
        |b| edit_diamond(b, 1, |d| d.phase = 0),
        "diamond 1: phase 0",
    );
    check(
        |b| edit_diamond(b, 1, |d| d.id = [17, 0, 0]),
        "diamond 1: id [17, 0, 0]",
    );

    // Tets.
    check(|b| edit_tet(b, 2, |t| t.diamond = 9), "tet 2: diamond 9");
    // A child's parent diamond is checked from its parent, which comes first.
    check(
        |b| edit_tet(b, 7, |t| t.parent_diamond = 2),
        "tet 2: child (parent diamond 2, level 2)",
    );
    check(
        |b| edit_tet(b, 0, |t| t.parent_diamond = 0),
        "tet 0: parent diamond 0 but is a root",
    );
    check(
        |b| edit_tet(b, 3, |t| t.parent_diamond = NO_INDEX),
        "tet 0: child (parent diamond 4294967295",
    );
    check(
        |b| edit_header(b, |h| h.root_tet_count = 1),
        "tet 1: parent diamond 4294967295 but is not a root",
    );
    check(
        |b| edit_tet(b, 3, |t| t.first_child = 6),
        "a tet is split iff it has a diamond",
    );
    check(
        |b| edit_tet(b, 2, |t| t.first_child = 9),
        "tet 2: children 9, 10 not after it",
    );
    check(
        |b| edit_tet(b, 2, |t| t.first_child = 2),
        "tet 2: children 2, 3 not after it",
    );
    check(
        |b| edit_tet(b, 0, |t| t.first_child = 6),
        "tet 0: child (parent diamond 1, level 2) does not come from its diamond 0",
    );
    // Shared children make a DAG, whose traversals are exponential: refused.
    check(
        |b| edit_tet(b, 4, |t| t.first_child = 6),
        "tet 4: child 6 is also another tet's child: the hierarchy must be a tree",
    );
    // A tet nobody points to.
    check(
        |b| {
            edit_tet(b, 4, |t| {
                t.first_child = NO_INDEX;
                t.diamond = NO_INDEX;
            })
        },
        "tet 8 is neither a root nor any tet's child",
    );
    check(
        |b| edit_tet(b, 0, |t| t.level = 1),
        "tet 0: level 1 differs from its diamond's 0",
    );
    check(
        |b| edit_tet(b, 4, |t| t.radius = -1.0),
        "tet 4: bounding sphere",
    );
    check(
        |b| edit_tet(b, 4, |t| t.cone_cos = 1.5),
        "tet 4: normal cone",
    );
    check(
        |b| edit_tet(b, 5, |t| t.patch_offset = 1 << 40),
        "tet 5: patch range 1099511627776..",
    );
    check(
        |b| edit_tet(b, 5, |t| t.patch_offset = u64::MAX - 7),
        "exceeds patch blob",
    );
    check(
        |b| edit_tet(b, 5, |t| t.patch_offset += 4),
        "tet 5: patch offset",
    );
    check(
        |b| edit_tet(b, 5, |t| t.patch_bytes += 8),
        "tet 5: patch is",
    );
    check(
        |b| edit_tet(b, 5, |t| t.vertex_count += 1),
        "tet 5: patch is",
    );
    check(
        |b| edit_tet(b, 5, |t| t.triangle_count = t.strip_index_count),
        "cannot fit",
    );
    // The id range: inside the id blob, at least a byte per id.
    check(
        |b| edit_tet(b, 5, |t| t.id_offset = 1 << 40),
        "tet 5: id range 1099511627776..",
    );
    check(
        |b| edit_tet(b, 5, |t| t.id_offset = u64::MAX),
        "exceeds id blob",
    );
    check(
        |b| edit_tet(b, 5, |t| t.id_bytes = t.vertex_count - 1),
        "tet 5: 13 ids cannot fit in an id stream of 12 bytes",
    );
    // A strip index past the vertex count: `open` accepts the tables, the patch parse catches it.
    let strip_index = |b: &mut Vec<u8>, value: u16| {
        // Tet 3: 9 vertices × (8 bytes of position + 16 of ATTR_ALL attributes).
        let (start, tet) = patch_of(b, 3);
        let strip = start + tet.vertex_count as usize * 24;
        b[strip + 2..strip + 4].copy_from_slice(&value.to_le_bytes());
    };
    check(
        |b| strip_index(b, 9),
        "tet 3: strip index 1 is 9, but the patch has 9 vertices",
    );
    check(|b| strip_index(b, 0xFFFE), "tet 3: strip index 1 is 65534");
    let mut bytes = image(3, ATTR_ALL);
    strip_index(&mut bytes, 9);
    seal(&mut bytes);
    let repo = Repository::from_bytes(bytes).unwrap();
    assert!(repo.patch(2).is_ok());
    assert!(matches!(repo.patch(3), Err(RepositoryError::Corrupt(_))));
    assert!(repo.validate_patches().is_err());
    assert!(matches!(
        repo.patch(10),
        Err(RepositoryError::NoSuchTet {
            index: 10,
            count: 10
        })
    ));
}

/// Byte offset of tet `i`'s id stream in the image, and the tet.
fn ids_of(bytes: &[u8], i: usize) -> (usize, TetRecord) {
    let (_, tet) = patch_of(bytes, i);
    (
        section_offset(bytes, SECTION_IDS) + tet.id_offset as usize,
        tet,
    )
}

#[test]
fn id_stream_corruption_is_caught_behind_a_valid_checksum() {
    // Tet 3 has ids 300,000..=300,008: one 3-byte varint (zigzag 600,000), then eight 2s.
    let edit_ids = |b: &mut Vec<u8>, k: usize, value: u8| {
        let (start, _) = ids_of(b, 3);
        b[start + k] = value;
    };
    // The first varint cut to 2 bytes: the 9 ids end a byte early.
    check(
        |b| edit_ids(b, 1, 0x01),
        "tet 3: id stream is 11 bytes but its 9 ids take 10",
    );
    check(
        |b| edit_ids(b, 10, 0x80),
        "tet 3: id stream ends inside the varint at byte 10",
    );
    // The first varint grown to 4 bytes: an id far past the input's 1,000,000 vertices.
    check(|b| edit_ids(b, 2, 0x80), "tet 3: global id 0 is");
    check(
        |b| {
            let (start, tet) = ids_of(b, 3);
            let mut stream = Vec::new();
            encode_global_ids(&[999_999, 1_000_000], &mut stream);
            stream.resize(tet.id_bytes as usize, 2);
            b[start..start + stream.len()].copy_from_slice(&stream);
        },
        "tet 3: global id 1 is 1000000, not a vertex of the 1000000-vertex input",
    );
    // Shrinking the input count below the ids is caught the same way.
    check(
        |b| edit_header(b, |h| h.input_vertex_count = 300_005),
        "global id 5 is 300005",
    );
    // A non-canonical varint (a trailing zero group) is refused even when its value is right.
    check(
        |b| {
            let (start, _) = ids_of(b, 3);
            b[start + 9] = 0x82;
            b[start + 10] = 0x00;
        },
        "not canonical",
    );
}

#[test]
fn wrong_magic_and_version_are_typed() {
    let mut bytes = image(2, 0);
    bytes[0] = b'X';
    assert!(
        matches!(Repository::from_bytes(bytes), Err(RepositoryError::BadMagic { found }) if found[0] == b'X')
    );

    let mut bytes = image(2, 0);
    edit_header(&mut bytes, |h| h.version = 1);
    let err = Repository::from_bytes(bytes.clone()).unwrap_err();
    assert!(
        matches!(
            err,
            RepositoryError::WrongVersion {
                found: 1,
                expected: 4
            }
        ),
        "{err:?}"
    );
    let message = err.to_string();
    assert!(
        message.contains("version 4") && message.contains("version 1"),
        "{message}"
    );
    // A version-3 file (the layout before the section table) gets the same clear error.
    let mut old = image(3, 0);
    edit_header(&mut old, |h| h.version = 3);
    let message = Repository::from_bytes(old).unwrap_err().to_string();
    assert!(
        message.contains("version 3 is not supported") && message.contains("tessera build"),
        "{message}"
    );
    // Still WrongVersion with a valid checksum.
    seal(&mut bytes);
    assert!(matches!(
        Repository::from_bytes(bytes),
        Err(RepositoryError::WrongVersion { .. })
    ));
}

#[test]
fn every_truncation_is_an_error() {
    let bytes = image(3, ATTR_ALL);
    for len in 0..bytes.len() {
        // The last section's end is the file's: every cut is caught by `open` alone.
        let result = Repository::from_bytes(bytes[..len].to_vec());
        match result {
            Err(RepositoryError::TooSmall { len: l }) => {
                assert!(len < HEADER_SIZE && l == len as u64)
            }
            Err(_) => assert!(len >= HEADER_SIZE),
            Ok(_) => panic!("truncated to {len} of {} bytes and accepted", bytes.len()),
        }
    }
    let mut big = Vec::new();
    write_repository(&mut big, &contents(3, ATTR_ALL, true).0).unwrap();
    for len in [
        0,
        1,
        199,
        200,
        201,
        327,
        328,
        1000,
        big.len() / 2,
        big.len() - 8,
        big.len() - 1,
    ] {
        assert!(
            Repository::from_bytes(big[..len].to_vec()).is_err(),
            "{len}"
        );
    }
    // Through the file system too (an empty file is not mapped at all).
    let dir = tempfile::tempdir().unwrap();
    for len in [0, 100, 200, big.len() - 1] {
        let path = dir.path().join(format!("t{len}.tsr"));
        std::fs::write(&path, &big[..len]).unwrap();
        assert!(Repository::open(&path).is_err(), "{len}");
    }
    let missing = Repository::open(dir.path().join("missing.tsr")).unwrap_err();
    assert!(
        matches!(missing, RepositoryError::Io { .. })
            && missing.to_string().contains("missing.tsr")
    );
}

#[test]
fn every_flipped_byte_is_an_error() {
    let bytes = image(2, ATTR_NORMALS | ATTR_UVS);
    let blobs = section_offset(&bytes, SECTION_PATCHES);
    let mut flipped = bytes.clone();
    for i in 0..bytes.len() {
        for bit in [0x01, 0x80] {
            flipped[i] ^= bit;
            // The directory is checked on open; a blob byte when its patch or id is read.
            let opened = Repository::from_bytes(flipped.clone());
            assert_eq!(
                opened.is_err(),
                i < blobs,
                "byte {i}, bit {bit:#x}: {opened:?}"
            );
            let result = open_all(flipped.clone());
            assert!(
                result.is_err(),
                "flipping bit {bit:#x} of byte {i} was accepted"
            );
            if i >= 16 {
                assert!(
                    matches!(
                        result,
                        Err(RepositoryError::ChecksumMismatch { .. })
                            | Err(RepositoryError::SectionChecksumMismatch { .. })
                            | Err(RepositoryError::PatchChecksumMismatch { .. })
                            | Err(RepositoryError::Corrupt(_))
                    ),
                    "byte {i}: {result:?}"
                );
            }
            flipped[i] ^= bit;
        }
    }
}

#[test]
fn a_damaged_patch_is_named_and_the_rest_stays_readable() {
    let mut bytes = image(3, ATTR_ALL);
    let (start, _) = patch_of(&bytes, 5);
    bytes[start] ^= 0x10;
    let repo = Repository::from_bytes(bytes.clone()).unwrap();
    for i in (0..10).filter(|&i| i != 5) {
        assert!(repo.patch(i).is_ok(), "tet {i}");
        assert!(repo.patch_bytes(i).is_ok(), "tet {i}");
    }
    for _ in 0..2 {
        let err = repo.patch_bytes(5).unwrap_err();
        assert!(
            matches!(err, RepositoryError::PatchChecksumMismatch { tet: 5, .. }),
            "{err:?}"
        );
        assert!(
            err.to_string().contains("patch of tet 5 is damaged"),
            "{err}"
        );
    }
    assert!(repo.validate_patches().is_err());

    // A damaged id stream: the patches still draw, the ids are refused as a whole.
    let mut bytes = image(3, ATTR_ALL);
    let (start, _) = ids_of(&bytes, 3);
    bytes[start + 4] ^= 0x01;
    let repo = Repository::from_bytes(bytes).unwrap();
    assert!((0..10).all(|i| repo.patch_bytes(i).is_ok()));
    let err = repo.patch(0).unwrap_err();
    assert!(
        err.to_string().contains("id blob checksum mismatch"),
        "{err}"
    );
    assert!(repo.verify_ids().is_err());

    // A changed directory record behind a valid header checksum.
    let mut bytes = image(3, ATTR_ALL);
    edit_tet(&mut bytes, 4, |t| t.radius = 2.0);
    let err = Repository::from_bytes(bytes).unwrap_err();
    assert!(
        err.to_string().contains("tet table checksum mismatch"),
        "{err}"
    );
}

#[test]
fn optional_sections_are_skipped_and_unknown_required_ones_refused() {
    // Insert a fifth entry (an optional section of kind 77 holding 8 bytes at the end).
    let bytes = image(3, ATTR_ALL);
    let table_end = HEADER_SIZE + 4 * SECTION_ENTRY_SIZE;
    let mut grown = bytes[..table_end].to_vec();
    grown.extend_from_slice(&[0; SECTION_ENTRY_SIZE]);
    grown.extend_from_slice(&bytes[table_end..]);
    while !grown.len().is_multiple_of(8) {
        grown.push(0);
    }
    let extra_at = grown.len() as u64;
    grown.extend_from_slice(b"future!!");
    edit_header(&mut grown, |h| h.section_count = 5);
    let mut entries = sections_of(&grown);
    for e in &mut entries[..4] {
        e.offset += SECTION_ENTRY_SIZE as u64;
    }
    entries[4] = SectionEntry {
        kind: 77,
        flags: SECTION_FLAG_OPTIONAL,
        offset: extra_at,
        bytes: 8,
        checksum: 0,
        reserved: 0,
    };
    write_sections(&mut grown, &entries);
    seal(&mut grown);
    open_all(grown.clone()).unwrap();
    // The same section without the optional flag comes from a newer writer: refused.
    let mut entries = sections_of(&grown);
    entries[4].flags = 0;
    write_sections(&mut grown, &entries);
    seal(&mut grown);
    let message = open_all(grown).unwrap_err().to_string();
    assert!(message.contains("made by a newer tessera"), "{message}");
}

#[test]
fn writer_refuses_invalid_contents() {
    let (mut bad, _) = contents(3, 0, false);
    bad.tets[4].diamond = 5;
    let err = write_repository(Vec::new(), &bad).unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::InvalidInput);
    assert!(err.to_string().contains("tet 4: diamond 5"), "{err}");

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.tsr");
    let err = write_repository_file(&path, &bad).unwrap_err();
    assert!(matches!(err, RepositoryError::Corrupt(_)), "{err:?}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);

    let (mut bad, _) = contents(3, 0, false);
    bad.patch_blob.truncate(bad.patch_blob.len() - 8);
    assert!(write_repository(Vec::new(), &bad)
        .unwrap_err()
        .to_string()
        .contains("tet 9: patch range"));
}

#[test]
fn failed_rename_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    // The target is a non-empty directory: the rename fails after the data was written.
    let target = dir.path().join("taken.tsr");
    std::fs::create_dir(&target).unwrap();
    std::fs::write(target.join("keep"), b"x").unwrap();
    let err = write_repository_file(&target, &contents(2, 0, false).0).unwrap_err();
    assert!(matches!(err, RepositoryError::Io { .. }), "{err:?}");
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["taken.tsr"]);
    assert!(target.join("keep").exists());

    // A missing directory fails cleanly too.
    let err = write_repository_file(
        &dir.path().join("no/such/dir.tsr"),
        &contents(2, 0, false).0,
    )
    .unwrap_err();
    assert!(matches!(err, RepositoryError::Io { .. }));

    // A path with no file name.
    let err = write_repository_file(Path::new("/"), &contents(2, 0, false).0).unwrap_err();
    assert!(matches!(err, RepositoryError::Io { .. }));
}

#[test]
fn stale_temporaries_of_killed_writers_are_removed() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("model.tsr");
    // Linux pids stay below 2^22: this writer is gone. Pid 1 is alive: its write is left alone.
    let dead = dir.path().join(".model.tsr.tmp-4194305");
    let live = dir.path().join(".model.tsr.tmp-1");
    let other = dir.path().join(".other.tsr.tmp-4194305");
    for p in [&dead, &live, &other] {
        std::fs::write(p, b"half a repository").unwrap();
    }
    write_repository_file(&path, &contents(3, 0, false).0).unwrap();
    assert!(!dead.exists(), "a dead writer's temporary file stays");
    assert!(live.exists() && other.exists());
    Repository::open(&path).unwrap();
    assert_eq!(
        tessera_core::repository::remove_stale_temporaries(&path).unwrap(),
        Vec::<std::path::PathBuf>::new()
    );
}

/// A mutation: overwrite one little-endian u32 at a 4-aligned offset with an interesting value
/// (hits counts, offsets and indices), or xor one byte.
#[derive(Clone, Debug)]
enum Mutation {
    Word(usize, u32),
    Xor(usize, u8),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let value = prop_oneof![
        Just(0u32),
        Just(1),
        Just(2),
        Just(7),
        Just(8),
        Just(0xFFFF),
        Just(0x1_0000),
        Just(u32::MAX),
        Just(u32::MAX - 1),
        Just(0x8000_0000),
        any::<u32>(),
    ];
    prop_oneof![
        (any::<prop::sample::Index>(), value)
            .prop_map(|(i, v)| Mutation::Word(i.index(usize::MAX / 4), v)),
        (any::<prop::sample::Index>(), 1u8..=255)
            .prop_map(|(i, x)| Mutation::Xor(i.index(usize::MAX), x)),
    ]
}

fn apply(bytes: &mut [u8], m: &Mutation) {
    match *m {
        Mutation::Word(i, v) => {
            let at = (i % (bytes.len() / 4)) * 4;
            bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
        }
        Mutation::Xor(i, x) => {
            let at = i % bytes.len();
            bytes[at] ^= x;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1024, ..ProptestConfig::default() })]

    /// Random mutations behind a recomputed checksum never panic in open + decode.
    #[test]
    fn mutations_never_panic(
        dimension in 2u32..=3,
        attributes in 0..=ATTR_ALL,
        mutations in prop::collection::vec(mutation(), 1..4),
        truncate in prop::option::of(any::<prop::sample::Index>()),
    ) {
        let mut bytes = image(dimension, attributes);
        for m in &mutations {
            apply(&mut bytes, m);
        }
        if let Some(t) = truncate {
            bytes.truncate(t.index(bytes.len() + 1));
        }
        seal(&mut bytes);
        let _ = open_all(bytes);
    }
}

#[test]
fn repository_is_shareable_across_threads() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<Repository>();
    assert_send_sync::<tessera_core::repository::PatchView<'static>>();
}
