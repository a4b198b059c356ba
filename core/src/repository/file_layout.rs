//! The first checks of a repository file: its header, the header's checksum, the section
//! table (kinds, flags, ranges, overlaps, the file's end) and the directory's checksums — what
//! `Repository::open` runs before it reads any record.

use std::ops::Range;

use super::directory_check::check_header_fields;
use super::format::{
    compute_checksum, section_name, Header, PatchCodec, SectionEntry, ATTRIBUTE_ERROR_RECORD_SIZE,
    DIAMOND_RECORD_SIZE, FORMAT_VERSION, HEADER_SIZE, MAGIC, MAX_SECTIONS, PATCH_SECTIONS,
    REQUIRED_SECTIONS, SECTION_ATTRIBUTE_ERRORS, SECTION_CODED_STRIPS, SECTION_DIAMONDS,
    SECTION_ENTRY_SIZE, SECTION_FLAGS_ALL, SECTION_FLAG_OPTIONAL, SECTION_IDS,
    SECTION_PACKED_PATCHES, SECTION_PACKED_STRIPS, SECTION_PATCHES, SECTION_TETS, SECTION_TEXTURES,
    TABLE_ALIGN, TET_RECORD_SIZE, WRITTEN_SECTIONS,
};
use super::reader::{corrupt, RepositoryError, RELEASE_CHUNK};

/// Where the sections lie in a file whose header and section table were checked.
pub(crate) struct Layout {
    pub header: Header,
    pub diamonds: Range<usize>,
    pub tets: Range<usize>,
    pub patch_blob: Range<usize>,
    pub id_blob: Range<usize>,
    pub id_blob_checksum: u32,
    pub sections: Vec<SectionEntry>,
    pub codec: PatchCodec,
    /// The attribute error table, where the file has one (its checksum checked).
    pub attribute_errors: Option<Range<usize>>,
    /// The texture section and its section-table checksum (of its tables: `textures.rs`
    /// checks it), where the file has one.
    pub textures: Option<(Range<usize>, u32)>,
}

/// Checks the header, its checksum and the section table of `bytes`, then the directory's
/// checksums (the diamond and tet tables; not the blobs).
pub(crate) fn check_layout(
    bytes: &[u8],
    release: &dyn Fn(Range<usize>),
) -> Result<Layout, RepositoryError> {
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
    let required = WRITTEN_SECTIONS as u32;
    if !(required..=MAX_SECTIONS).contains(&header.section_count) {
        return Err(corrupt(format!(
            "{} sections listed, not {required}..={MAX_SECTIONS}",
            header.section_count
        )));
    }
    let table_end = HEADER_SIZE + header.section_count as usize * SECTION_ENTRY_SIZE;
    if bytes.len() < table_end {
        return Err(corrupt(format!(
            "file is {len} bytes, too short for the header and its {}-entry section table \
             ({table_end} bytes)",
            header.section_count
        )));
    }
    let computed = compute_checksum(&bytes[..table_end]);
    if computed != header.checksum {
        return Err(RepositoryError::ChecksumMismatch {
            stored: header.checksum,
            computed,
        });
    }
    check_header_fields(&header)?;
    let entries: Vec<SectionEntry> = bytes[HEADER_SIZE..table_end]
        .chunks_exact(SECTION_ENTRY_SIZE)
        .map(bytemuck::pod_read_unaligned)
        .collect();
    let ranges = section_ranges(&header, &entries, table_end as u64, len)?;
    let find = |kind: u32| {
        let i = entries.iter().position(|e| e.kind == kind);
        // Present: `section_ranges` requires every required kind.
        let i = i.expect("required section checked");
        (ranges[i].clone(), entries[i].checksum)
    };
    let (diamonds, diamond_sum) = find(SECTION_DIAMONDS);
    let (tets, tet_sum) = find(SECTION_TETS);
    // Present: `section_ranges` requires exactly one patch blob.
    let codec = entries
        .iter()
        .find_map(|e| PatchCodec::of_section(e.kind))
        .expect("patch blob checked");
    let (patch_blob, _) = find(codec.section_kind());
    let (id_blob, id_blob_checksum) = find(SECTION_IDS);
    let attribute_errors = entries
        .iter()
        .position(|e| e.kind == SECTION_ATTRIBUTE_ERRORS)
        .map(|i| (ranges[i].clone(), entries[i].checksum));
    let textures = entries
        .iter()
        .position(|e| e.kind == SECTION_TEXTURES)
        .map(|i| (ranges[i].clone(), entries[i].checksum));
    let mut checksummed = vec![
        (SECTION_DIAMONDS, &diamonds, diamond_sum),
        (SECTION_TETS, &tets, tet_sum),
    ];
    if let Some((range, sum)) = &attribute_errors {
        checksummed.push((SECTION_ATTRIBUTE_ERRORS, range, *sum));
    }
    for (kind, range, stored) in checksummed {
        let mut hasher = crc32fast::Hasher::new();
        for start in range.clone().step_by(RELEASE_CHUNK) {
            let chunk = start..(start + RELEASE_CHUNK).min(range.end);
            hasher.update(&bytes[chunk.clone()]);
            release(chunk);
        }
        let computed = hasher.finalize();
        if computed != stored {
            return Err(RepositoryError::SectionChecksumMismatch {
                section: section_name(kind),
                stored,
                computed,
            });
        }
    }
    Ok(Layout {
        header,
        diamonds,
        tets,
        patch_blob,
        id_blob,
        id_blob_checksum,
        sections: entries,
        codec,
        attribute_errors: attribute_errors.map(|(range, _)| range),
        textures,
    })
}

/// The byte range of every section entry, checked: known flags, zero reserved field, each
/// kind at most once, every required kind present, unknown kinds only when optional, tables
/// exactly their count × record size, 8-aligned, after the section table, inside the file, no
/// two overlapping, and the file ending where the last section ends.
fn section_ranges(
    h: &Header,
    entries: &[SectionEntry],
    table_end: u64,
    len: u64,
) -> Result<Vec<Range<usize>>, RepositoryError> {
    let mut ranges = Vec::with_capacity(entries.len());
    for (i, e) in entries.iter().enumerate() {
        let name = section_name(e.kind);
        if e.flags & !SECTION_FLAGS_ALL != 0 || e.reserved != 0 {
            return Err(corrupt(format!(
                "section {i} ({name}): unknown flags {:#x} or reserved field {}",
                e.flags, e.reserved
            )));
        }
        if entries[..i].iter().any(|o| o.kind == e.kind) {
            return Err(corrupt(format!("section {i}: a second {name}")));
        }
        let record = match e.kind {
            SECTION_DIAMONDS => Some((h.diamond_count, DIAMOND_RECORD_SIZE)),
            SECTION_TETS => Some((h.tet_count, TET_RECORD_SIZE)),
            SECTION_ATTRIBUTE_ERRORS => Some((h.diamond_count, ATTRIBUTE_ERROR_RECORD_SIZE)),
            SECTION_PATCHES
            | SECTION_PACKED_PATCHES
            | SECTION_PACKED_STRIPS
            | SECTION_CODED_STRIPS
            | SECTION_IDS
            | SECTION_TEXTURES => None,
            _ if e.flags & SECTION_FLAG_OPTIONAL != 0 => None,
            _ => {
                return Err(corrupt(format!(
                    "section {i} is of kind {}, which this build does not know and may not \
                     skip: the repository was made by a newer tessera",
                    e.kind
                )))
            }
        };
        if let Some((count, size)) = record {
            if count.checked_mul(size as u64) != Some(e.bytes) {
                return Err(corrupt(format!(
                    "{name} is {} bytes, but {count} records take {count} × {size}",
                    e.bytes
                )));
            }
        }
        ranges.push(table_range(&name, e.offset, e.bytes, table_end, len)?);
    }
    if let Some(kind) = REQUIRED_SECTIONS
        .iter()
        .find(|&&k| !entries.iter().any(|e| e.kind == k))
    {
        return Err(corrupt(format!("no {} section", section_name(*kind))));
    }
    let patch_blobs = entries
        .iter()
        .filter(|e| PATCH_SECTIONS.contains(&e.kind))
        .count();
    if patch_blobs != 1 {
        return Err(corrupt(format!(
            "{patch_blobs} patch blob sections (a patch blob or a packed patch blob), not one"
        )));
    }
    let mut order: Vec<usize> = (0..ranges.len()).collect();
    order.sort_by_key(|&i| (ranges[i].start, ranges[i].end));
    for pair in order.windows(2) {
        let (a, b) = (&ranges[pair[0]], &ranges[pair[1]]);
        if b.start < a.end {
            return Err(corrupt(format!(
                "{} at {}..{} overlaps {} at {}..{}",
                section_name(entries[pair[1]].kind),
                b.start,
                b.end,
                section_name(entries[pair[0]].kind),
                a.start,
                a.end
            )));
        }
    }
    let end = ranges
        .iter()
        .map(|r| r.end as u64)
        .max()
        .unwrap_or(table_end);
    if end != len {
        return Err(corrupt(format!(
            "file is {len} bytes but its sections end at {end}"
        )));
    }
    Ok(ranges)
}

/// Byte range of a section of `bytes` at `offset`, which must be 8-aligned, at or after `after`
/// (the end of the section table) and end within `len`.
fn table_range(
    name: &str,
    offset: u64,
    bytes: u64,
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
            "{name} at offset {offset} overlaps the section table, which ends at {after}"
        )));
    }
    match offset.checked_add(bytes) {
        // end ≤ len, and len came from a slice length, so both fit in usize.
        Some(end) if end <= len => Ok(offset as usize..end as usize),
        _ => Err(corrupt(format!(
            "{name} of {bytes} bytes at offset {offset} exceeds the file of {len} bytes"
        ))),
    }
}
