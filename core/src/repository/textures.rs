//! The texture section (`SECTION_TEXTURES`, optional): a repository's textures as pages of
//! their mip pyramids, and the bands of `v` that name them (`crate::texture`).
//!
//! ```text
//! SECTION_TEXTURES   TextureSectionHeader                            (16 bytes)
//!                    TextureRecord × texture_count                   (32 bytes each)
//!                    BandRecord × band_count                         (16 bytes each)
//!                    u32 × page_count: each page's CRC-32, then zeros to a multiple of 8
//!                    page × page_count, each `encoding.page_bytes()` bytes:
//!                      encoding 0 (RGBA8): PAGE_BYTES (73,984) texels (sRGB colour, linear
//!                        alpha), row-major, top row first;
//!                      encoding 1 (BC1): BC1_PAGE_BYTES (12,208), the page's three mips as
//!                        BC1 blocks (`texture_codec`)
//! ```
//!
//! The header's last word, `encoding`, was a reserved 0 before BC1 pages existed, so older
//! repositories read as RGBA8; a tessera that predates it refuses a BC1 section as corrupt.
//!
//! Pages follow the global page index (`crate::texture`): texture by texture, level by level,
//! row by row. Every offset above is a multiple of 8, so the records are borrowed in place.
//! The section table's CRC-32 for this section covers the *tables* (everything before the
//! pages: header, records, bands, page CRCs and their padding) and is checked on open, in time
//! linear in the tables; each page's own CRC-32 is checked the first time it is read
//! (`TextureTable::page`), as a patch's is, so a viewer never touches the pages it does not draw.
//!
//! Written by a build whose input has textures, and only then, so a repository of an input
//! without them has the bytes it had before this section existed; a tessera that predates it
//! skips it (`SECTION_FLAG_OPTIONAL`).

use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};

use bytemuck::{Pod, Zeroable};

use super::format::{section_name, SECTION_TEXTURES};
use super::reader::{corrupt, RepositoryError};
use crate::texture::{bands_valid, Band, PageEncoding, TextureShape, Wrap};

/// The section's first 16 bytes: how many of each table follow.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct TextureSectionHeader {
    /// u32, `TextureRecord`s that follow.
    pub texture_count: u32,
    /// u32, `BandRecord`s after the texture records.
    pub band_count: u32,
    /// u32, pages of all textures: the sum of every record's `page_count`.
    pub page_count: u32,
    /// u32, `PageEncoding::code` of every page (0 RGBA8, 1 BC1).
    pub encoding: u32,
}

/// One texture: its shape (`TextureShape`) and where its pages start.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct TextureRecord {
    /// u32, texels across level 0, `1..=MAX_TEXTURE_SIDE`.
    pub width: u32,
    /// u32, texels down level 0, `1..=MAX_TEXTURE_SIDE`.
    pub height: u32,
    /// u32, `Wrap::code` along u (0 repeat, 1 clamp).
    pub wrap_u: u32,
    /// u32, `Wrap::code` along v.
    pub wrap_v: u32,
    /// u32, global index of the texture's first page: the sum of the earlier ones' counts.
    pub first_page: u32,
    /// u32, `TextureShape::levels` of the shape.
    pub levels: u32,
    /// u32, `TextureShape::page_count` of the shape.
    pub page_count: u32,
    /// u32, 0.
    pub reserved: u32,
}

/// One `Band` of `v`, its fields as they are.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct BandRecord {
    /// i32, `Band::start`.
    pub start: i32,
    /// u32, `Band::span`, ≥ 1.
    pub span: u32,
    /// i32, `Band::shift`.
    pub shift: i32,
    /// u32, `Band::texture`: a texture index or `NO_TEXTURE`.
    pub texture: u32,
}

const HEADER_BYTES: u64 = std::mem::size_of::<TextureSectionHeader>() as u64;
const RECORD_BYTES: u64 = std::mem::size_of::<TextureRecord>() as u64;
const BAND_BYTES: u64 = std::mem::size_of::<BandRecord>() as u64;
const _: () = assert!(HEADER_BYTES == 16 && RECORD_BYTES == 32 && BAND_BYTES == 16);
const _: () = assert!(crate::texture::PAGE_BYTES.is_multiple_of(8));
const _: () = assert!(crate::texture::BC1_PAGE_BYTES.is_multiple_of(8));

/// Bytes of the tables (everything before the pages) for these counts.
fn tables_bytes(textures: u64, bands: u64, pages: u64) -> Option<u64> {
    let crcs = pages.checked_mul(4)?.checked_add(7)? & !7;
    HEADER_BYTES
        .checked_add(textures.checked_mul(RECORD_BYTES)?)?
        .checked_add(bands.checked_mul(BAND_BYTES)?)?
        .checked_add(crcs)
}

/// Bytes of a whole section for these counts (`None` past u64).
fn section_bytes_for(textures: u64, bands: u64, pages: u64, encoding: PageEncoding) -> Option<u64> {
    tables_bytes(textures, bands, pages)?
        .checked_add(pages.checked_mul(encoding.page_bytes() as u64)?)
}

/// The value a page's CRC-32 entry holds for its bytes.
pub fn page_checksum(page: &[u8]) -> u32 {
    crc32fast::hash(page)
}

/// What a writer needs to lay the section out before its pages are made: the textures'
/// shapes, in texture order, and the bands.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TextureDirectory {
    pub shapes: Vec<TextureShape>,
    pub bands: Vec<Band>,
    /// How every page is stored.
    pub encoding: PageEncoding,
}

impl TextureDirectory {
    /// Pages of all textures.
    pub fn page_count(&self) -> u64 {
        self.shapes.iter().map(|s| u64::from(s.page_count())).sum()
    }

    /// Bytes of the section.
    pub fn section_bytes(&self) -> u64 {
        section_bytes_for(
            self.shapes.len() as u64,
            self.bands.len() as u64,
            self.page_count(),
            self.encoding,
        )
        .expect("checked by `check`: counts fit u32")
    }

    /// Checks what the reader checks of the tables: every shape valid, the page count within
    /// u32, the bands valid against the texture count.
    pub(crate) fn check(&self) -> Result<(), RepositoryError> {
        for (i, s) in self.shapes.iter().enumerate() {
            if TextureShape::new(s.width, s.height, s.wrap_u, s.wrap_v).is_none() {
                return Err(corrupt(format!(
                    "texture {i} is {} × {} texels, outside 1..=65536 a side",
                    s.width, s.height
                )));
            }
        }
        let count_fits = |n: u64| u32::try_from(n).is_ok() && n < u64::from(u32::MAX);
        let pages = self.page_count();
        if !count_fits(self.shapes.len() as u64) || !count_fits(self.bands.len() as u64) {
            return Err(corrupt("too many textures or bands for u32 counts".into()));
        }
        if !count_fits(pages) || section_bytes_for(0, 0, pages, self.encoding).is_none() {
            return Err(corrupt(format!(
                "{pages} texture pages do not fit the format"
            )));
        }
        if !bands_valid(&self.bands, self.shapes.len() as u32) {
            return Err(corrupt(format!(
                "texture bands overlap, are empty or name a texture past the {} there are",
                self.shapes.len()
            )));
        }
        Ok(())
    }

    /// The tables' bytes (everything before the pages) with these page checksums, one a page.
    pub(crate) fn tables(&self, page_checksums: &[u32]) -> Vec<u8> {
        assert_eq!(page_checksums.len() as u64, self.page_count());
        let head = TextureSectionHeader {
            texture_count: self.shapes.len() as u32,
            band_count: self.bands.len() as u32,
            page_count: page_checksums.len() as u32,
            encoding: self.encoding.code(),
        };
        let mut out = bytemuck::bytes_of(&head).to_vec();
        let mut first_page = 0u32;
        for s in &self.shapes {
            let record = TextureRecord {
                width: s.width,
                height: s.height,
                wrap_u: s.wrap_u.code(),
                wrap_v: s.wrap_v.code(),
                first_page,
                levels: s.levels(),
                page_count: s.page_count(),
                reserved: 0,
            };
            first_page += record.page_count;
            out.extend_from_slice(bytemuck::bytes_of(&record));
        }
        for b in &self.bands {
            let record = BandRecord {
                start: b.start,
                span: b.span,
                shift: b.shift,
                texture: b.texture,
            };
            out.extend_from_slice(bytemuck::bytes_of(&record));
        }
        out.extend_from_slice(bytemuck::cast_slice(page_checksums));
        out.resize(out.len().next_multiple_of(8), 0);
        out
    }
}

/// A texture section held whole in memory, for `writer::write_repository_textured`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TextureContents {
    pub directory: TextureDirectory,
    /// Every page in global order, `directory.encoding.page_bytes()` each.
    pub pages: Vec<u8>,
}

impl TextureContents {
    /// The section's bytes (tables with the pages' checksums, then the pages), checked as the
    /// reader would.
    pub(crate) fn section(&self) -> Result<Vec<u8>, RepositoryError> {
        self.directory.check()?;
        let pages = self.directory.page_count();
        let page_bytes = self.directory.encoding.page_bytes();
        if self.pages.len() as u64 != pages * page_bytes as u64 {
            return Err(corrupt(format!(
                "{} bytes of texture pages, not the {pages} pages of {page_bytes} bytes its \
                 textures have",
                self.pages.len()
            )));
        }
        let crcs: Vec<u32> = self.pages.chunks(page_bytes).map(page_checksum).collect();
        let mut out = self.directory.tables(&crcs);
        out.extend_from_slice(&self.pages);
        Ok(out)
    }
}

/// Where a file's texture section lies and what of it was checked; its pages are verified
/// once each, on first read.
#[derive(Debug)]
pub(crate) struct TextureLayout {
    /// The section's bytes in the file.
    section: Range<usize>,
    textures: usize,
    bands: usize,
    pages: u32,
    encoding: PageEncoding,
    /// One bit a page: its checksum was verified. Relaxed atomics: a race verifies twice.
    verified: Vec<AtomicU64>,
}

fn table<'a, T: Pod>(bytes: &'a [u8], what: &str) -> Result<&'a [T], RepositoryError> {
    bytemuck::try_cast_slice(bytes)
        .map_err(|e| corrupt(format!("{what} cannot be borrowed in place: {e:?}")))
}

/// Checks a texture section (`bytes`, its whole range `section` in the file, its section-table
/// CRC-32 `stored`): counts against the section's size before anything is allocated, the
/// tables' checksum, every record (shape, levels, page counts, first pages, reserved fields)
/// and the bands. Linear in the tables; the pages are not read.
pub(crate) fn check_texture_section(
    bytes: &[u8],
    section: Range<usize>,
    stored: u32,
) -> Result<TextureLayout, RepositoryError> {
    let s = &bytes[section.clone()];
    if (s.len() as u64) < HEADER_BYTES {
        return Err(corrupt(format!(
            "texture section is {} bytes, shorter than its {HEADER_BYTES}-byte header",
            s.len()
        )));
    }
    let head: TextureSectionHeader = bytemuck::pod_read_unaligned(&s[..HEADER_BYTES as usize]);
    let (t, b, p) = (
        u64::from(head.texture_count),
        u64::from(head.band_count),
        u64::from(head.page_count),
    );
    let encoding = PageEncoding::from_code(head.encoding).ok_or_else(|| {
        corrupt(format!(
            "texture section: page encoding {} is not one this tessera knows (0 RGBA8, 1 BC1)",
            head.encoding
        ))
    })?;
    if section_bytes_for(t, b, p, encoding) != Some(s.len() as u64) {
        return Err(corrupt(format!(
            "texture section is {} bytes, but {t} textures, {b} bands and {p} {} pages take {}",
            s.len(),
            encoding.name(),
            section_bytes_for(t, b, p, encoding).map_or("more than u64".into(), |n| n.to_string()),
        )));
    }
    // Within the section: its size was checked against the counts.
    let tables_end = tables_bytes(t, b, p).expect("checked above") as usize;
    let computed = crc32fast::hash(&s[..tables_end]);
    if computed != stored {
        return Err(RepositoryError::SectionChecksumMismatch {
            section: section_name(SECTION_TEXTURES),
            stored,
            computed,
        });
    }
    let records_end = (HEADER_BYTES + t * RECORD_BYTES) as usize;
    let records: &[TextureRecord] = table(&s[HEADER_BYTES as usize..records_end], "textures")?;
    let mut first_page = 0u64;
    for (i, r) in records.iter().enumerate() {
        let shape = shape_of(r).ok_or_else(|| {
            corrupt(format!(
                "texture {i}: {} × {} texels with wrap codes {} and {} is not a texture shape",
                r.width, r.height, r.wrap_u, r.wrap_v
            ))
        })?;
        if r.levels != shape.levels()
            || r.page_count != shape.page_count()
            || u64::from(r.first_page) != first_page
            || r.reserved != 0
        {
            return Err(corrupt(format!(
                "texture {i} ({} × {}): {} levels, {} pages from page {} (reserved {}); its shape \
                 has {} levels and {} pages, from page {first_page} after the textures before it",
                r.width,
                r.height,
                r.levels,
                r.page_count,
                r.first_page,
                r.reserved,
                shape.levels(),
                shape.page_count()
            )));
        }
        first_page += u64::from(r.page_count);
    }
    if first_page != p {
        return Err(corrupt(format!(
            "texture section lists {p} pages, its textures have {first_page}"
        )));
    }
    let bands_end = records_end + (b * BAND_BYTES) as usize;
    let bands: Vec<Band> = table::<BandRecord>(&s[records_end..bands_end], "bands")?
        .iter()
        .map(band_of)
        .collect();
    if !bands_valid(&bands, head.texture_count) {
        return Err(corrupt(format!(
            "texture bands overlap, are empty or name a texture past the {t} there are"
        )));
    }
    Ok(TextureLayout {
        section,
        textures: t as usize,
        bands: b as usize,
        pages: head.page_count,
        encoding,
        verified: (0..p.div_ceil(64)).map(|_| AtomicU64::new(0)).collect(),
    })
}

fn shape_of(r: &TextureRecord) -> Option<TextureShape> {
    TextureShape::new(
        r.width,
        r.height,
        Wrap::from_code(r.wrap_u)?,
        Wrap::from_code(r.wrap_v)?,
    )
}

fn band_of(r: &BandRecord) -> Band {
    Band {
        start: r.start,
        span: r.span,
        shift: r.shift,
        texture: r.texture,
    }
}

/// A repository's textures (`Repository::textures`): shapes and bands, checked on open, and
/// pages, each checked on first read.
#[derive(Clone, Copy, Debug)]
pub struct TextureTable<'a> {
    /// The section's bytes.
    section: &'a [u8],
    layout: &'a TextureLayout,
}

impl<'a> TextureTable<'a> {
    pub(crate) fn new(file: &'a [u8], layout: &'a TextureLayout) -> Self {
        TextureTable {
            section: &file[layout.section.clone()],
            layout,
        }
    }

    fn records(&self) -> &'a [TextureRecord] {
        let end = HEADER_BYTES as usize + self.layout.textures * RECORD_BYTES as usize;
        bytemuck::cast_slice(&self.section[HEADER_BYTES as usize..end])
    }

    fn tables_end(&self) -> usize {
        let l = self.layout;
        tables_bytes(l.textures as u64, l.bands as u64, u64::from(l.pages)).expect("checked")
            as usize
    }

    /// Every texture's shape, in texture order.
    pub fn shapes(&self) -> Vec<TextureShape> {
        let shape = |r| shape_of(r).expect("checked on open");
        self.records().iter().map(shape).collect()
    }

    /// The bands of `v`, as stored.
    pub fn bands(&self) -> Vec<Band> {
        let start = HEADER_BYTES as usize + self.layout.textures * RECORD_BYTES as usize;
        let end = start + self.layout.bands * BAND_BYTES as usize;
        let records: &[BandRecord] = bytemuck::cast_slice(&self.section[start..end]);
        records.iter().map(band_of).collect()
    }

    /// Global index of texture `texture`'s first page. Panics if `texture` is not below the
    /// texture count (`shapes().len()`).
    pub fn first_page(&self, texture: u32) -> u32 {
        self.records()[texture as usize].first_page
    }

    /// Pages of all textures.
    pub fn page_count(&self) -> u32 {
        self.layout.pages
    }

    /// How every page is stored.
    pub fn encoding(&self) -> PageEncoding {
        self.layout.encoding
    }

    /// Page `global` as stored (`encoding().page_bytes()` bytes; `crate::texture_codec`
    /// decodes them), its CRC-32 checked
    /// the first time it is read: a damaged page is `PageChecksumMismatch`, the rest stay
    /// readable. `NoSuchPage` past the last page.
    pub fn page(&self, global: u32) -> Result<&'a [u8], RepositoryError> {
        let count = self.layout.pages;
        if global >= count {
            return Err(RepositoryError::NoSuchPage {
                index: global,
                count,
            });
        }
        let tables_end = self.tables_end();
        let crc_at = tables_end - (u64::from(count) * 4).next_multiple_of(8) as usize;
        let crc_at = crc_at + 4 * global as usize;
        let stored = u32::from_le_bytes(self.section[crc_at..crc_at + 4].try_into().expect("4"));
        let page_bytes = self.layout.encoding.page_bytes();
        let start = tables_end + global as usize * page_bytes;
        let bytes = &self.section[start..start + page_bytes];
        let (word, bit) = (global as usize / 64, 1u64 << (global % 64));
        if self.layout.verified[word].load(Ordering::Relaxed) & bit == 0 {
            let computed = page_checksum(bytes);
            if computed != stored {
                return Err(RepositoryError::PageChecksumMismatch {
                    page: global,
                    stored,
                    computed,
                });
            }
            self.layout.verified[word].fetch_or(bit, Ordering::Relaxed);
        }
        Ok(bytes)
    }
}
