//! The input's textures made into the repository's texture section (`tessera_core::texture`,
//! `tessera_core::repository::textures`): each image decoded (`decode.rs`), its mip levels made
//! in linear light (`pyramid.rs`) and cut into pages with their gutters (`pages.rs`).
//!
//! Textures are independent of the geometry: `plan` checks them all before the build's
//! expensive work (every image decodes, sides within `MAX_TEXTURE_SIDE`, the bands valid, each
//! texture within `--memory`), and the pages are made while the writer writes the section, the
//! last of the file, a texture at a time and a level at a time: one texture's level 0 and the
//! level after it are held, never all pages. Pages are made on one thread in global order, so
//! the bytes do not depend on `--threads`.

pub mod decode;
pub mod pages;
pub mod pyramid;

use std::io;

use std::collections::VecDeque;
use tessera_core::repository::{BlobFeed, TextureDirectory};

use rayon::prelude::*;
use tessera_core::texture::{
    bands_valid, Band, PageEncoding, TextureShape, BC1_PAGE_BYTES, PAGE_BYTES,
};
use tessera_core::texture_codec::{colour_squared_error, decode_page, encode_page, psnr_db};

use crate::build_config::{BuildError, MemoryBudget, TexturePagesSummary};
use crate::texture_input::{MeshTextures, TextureInput};
use pyramid::Level;

/// Bytes a texture may hold while its pages are made: its pyramid (a level and the next are
/// held at once, at most that) and its decoded image once more (the decoder's own buffer
/// while it is made RGBA8). A texture needing more than `--memory` is refused.
pub fn texture_memory_bytes(shape: &TextureShape) -> u64 {
    pyramid::pyramid_bytes(shape)
        + 4 * u64::from(shape.width) * u64::from(shape.height)
        + ENCODE_BATCH as u64 * (PAGE_BYTES + BC1_PAGE_BYTES) as u64
}

/// Pages cut at a time and encoded in parallel (in the build's thread pool), then handed to
/// the writer in order: the bytes do not depend on the threads.
const ENCODE_BATCH: usize = 64;

/// The textures' shapes and bands, every image checked to decode.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TexturePlan {
    pub directory: TextureDirectory,
}

/// Checks every texture of `textures` before the build's expensive work: its bytes read, its
/// format PNG or JPEG, its sides in `1..=MAX_TEXTURE_SIDE`, its image decoding, and, under a
/// memory budget, its pages made within it (`texture_memory_bytes`); then the bands. A failure
/// is `BuildError::Texture` naming the texture (or the bands). Cost: one decode a texture.
pub fn plan(
    textures: &MeshTextures,
    memory: Option<&MemoryBudget>,
    encoding: PageEncoding,
) -> Result<TexturePlan, BuildError> {
    let mut shapes = Vec::with_capacity(textures.textures.len());
    for t in &textures.textures {
        let fail = |reason| BuildError::Texture {
            name: t.name.clone(),
            reason,
        };
        let bytes = decode::encoded_bytes(t).map_err(fail)?;
        let (w, h) = decode::dimensions(&bytes).map_err(fail)?;
        let shape = TextureShape::new(w, h, t.wrap_u, t.wrap_v).expect("sides checked");
        let need = texture_memory_bytes(&shape);
        if let Some(m) = memory.filter(|m| need > m.bytes) {
            return Err(fail(format!(
                "{w} × {h} texels need {need} bytes while its pages are made, more than the \
                 memory budget of {} bytes",
                m.bytes
            )));
        }
        decode::decode(&bytes, need).map_err(fail)?;
        shapes.push(shape);
    }
    let pages: u64 = shapes.iter().map(|s| u64::from(s.page_count())).sum();
    if pages >= u64::from(u32::MAX) || shapes.len() >= u32::MAX as usize {
        return Err(BuildError::Config(format!(
            "{} textures of {pages} pages in all: at most 2^32 − 2 pages",
            shapes.len()
        )));
    }
    if !bands_valid(&textures.bands, shapes.len() as u32) {
        return Err(BuildError::Texture {
            name: "(bands)".into(),
            reason: format!(
                "the {} bands of v overlap, are empty or name a texture past the {} there are",
                textures.bands.len(),
                shapes.len()
            ),
        });
    }
    Ok(TexturePlan {
        directory: TextureDirectory {
            shapes,
            bands: textures.bands.clone(),
            encoding,
        },
    })
}

/// Checks that every wedge's `v` lies in one of `bands` (the invariant `MeshTextures` states),
/// `uvs` being the wedges' coordinates in order (`None`: the input has none, which textures
/// cannot be sampled without). The first wedge outside every band stops the build. Cost: one
/// pass, a binary search a wedge.
pub fn check_wedges_in_bands(
    uvs: Option<&mut dyn Iterator<Item = io::Result<[f32; 2]>>>,
    bands: &[Band],
) -> Result<(), BuildError> {
    let bands_error = |reason: String| BuildError::Texture {
        name: "(bands)".into(),
        reason,
    };
    let Some(uvs) = uvs else {
        return Err(bands_error(
            "the input has textures but no texture coordinates".into(),
        ));
    };
    // Disjoint (checked by `plan`): sorted by start, the candidate is the last starting at or
    // before floor(v).
    let mut sorted = bands.to_vec();
    sorted.sort_unstable_by_key(|b| b.start);
    for (wedge, uv) in uvs.enumerate() {
        let v = uv.map_err(|e| bands_error(format!("reading the texture coordinates: {e}")))?[1];
        let floor = f64::from(v).floor();
        let at = sorted.partition_point(|b| f64::from(b.start) <= floor);
        if at == 0 || !sorted[at - 1].contains(v) {
            return Err(bands_error(format!(
                "wedge {wedge} has v = {v}, in none of the {} bands",
                bands.len()
            )));
        }
    }
    Ok(())
}

/// Makes the pages of planned textures in global order, a texture's levels one after the
/// other from its decoded image.
pub struct PageMaker<'a> {
    inputs: &'a [TextureInput],
    shapes: Vec<TextureShape>,
    /// Global index of each texture's first page.
    first_pages: Vec<u32>,
    /// The page the next call must ask for.
    next: u32,
    /// (texture, level index, that level's texels) being cut.
    current: Option<(usize, u32, Level)>,
    encoding: PageEncoding,
    /// Pages from `next` on, encoded (at most `ENCODE_BATCH`).
    ready: VecDeque<Vec<u8>>,
    /// The encoding's loss so far: squared error and channels (`TexturePagesSummary`).
    squared_error: f64,
    channels: u64,
}

impl<'a> PageMaker<'a> {
    /// The pages of `textures` as `plan` planned them.
    pub fn new(textures: &'a MeshTextures, plan: &TexturePlan) -> Self {
        let shapes = plan.directory.shapes.clone();
        let first_pages = shapes
            .iter()
            .scan(0u32, |at, s| {
                let first = *at;
                *at += s.page_count();
                Some(first)
            })
            .collect();
        PageMaker {
            inputs: &textures.textures,
            shapes,
            first_pages,
            next: 0,
            current: None,
            encoding: plan.directory.encoding,
            ready: VecDeque::new(),
            squared_error: 0.0,
            channels: 0,
        }
    }

    /// The pages made so far: their count, bytes and the encoding's PSNR.
    pub fn summary(&self) -> TexturePagesSummary {
        TexturePagesSummary {
            encoding: self.encoding,
            pages: self.next,
            page_bytes: u64::from(self.next) * self.encoding.page_bytes() as u64,
            psnr_db: psnr_db(self.squared_error, self.channels),
        }
    }

    /// Appends page `global` to `out`, encoded as planned. Pages are asked in order, each once;
    /// a texture whose file no longer decodes to its planned size fails naming it. Pages are
    /// cut `ENCODE_BATCH` at a time (within one texture) and encoded in parallel.
    pub fn page(&mut self, global: u32, out: &mut Vec<u8>) -> Result<(), BuildError> {
        if global != self.next {
            return Err(BuildError::Config(format!(
                "texture page {global} asked for, page {} is next: pages are made in order",
                self.next
            )));
        }
        if self.ready.is_empty() {
            let texture = self.first_pages.partition_point(|&f| f <= global) - 1;
            let texture_end = self.first_pages[texture] + self.shapes[texture].page_count();
            let end = texture_end.min(global + ENCODE_BATCH as u32);
            let mut cut = Vec::with_capacity((end - global) as usize);
            for g in global..end {
                let mut page = Vec::with_capacity(PAGE_BYTES);
                self.cut(g, &mut page)?;
                cut.push(page);
            }
            let encoding = self.encoding;
            let encoded: Vec<(Vec<u8>, f64, u64)> = cut
                .par_iter()
                .map(|page| match encoding {
                    PageEncoding::Rgba8 => (page.clone(), 0.0, page.len() as u64 / 4 * 3),
                    encoding => {
                        let stored = encode_page(encoding, page);
                        let decoded = decode_page(encoding, &stored).expect("a page just encoded");
                        let (error, channels) = colour_squared_error(&decoded, page);
                        (stored, error, channels)
                    }
                })
                .collect();
            // Summed in page order: the same total whatever the threads.
            for (stored, error, channels) in encoded {
                self.squared_error += error;
                self.channels += channels;
                self.ready.push_back(stored);
            }
        }
        out.extend_from_slice(&self.ready.pop_front().expect("a batch was made"));
        self.next += 1;
        Ok(())
    }

    /// Appends page `global`'s texels as cut (`PAGE_BYTES`) to `out`, decoding its texture
    /// and advancing its pyramid as needed (pages come in global order).
    fn cut(&mut self, global: u32, out: &mut Vec<u8>) -> Result<(), BuildError> {
        let texture = self.first_pages.partition_point(|&f| f <= global) - 1;
        let shape = self.shapes[texture];
        let (l, x, y) = shape
            .page_coords(global - self.first_pages[texture])
            .expect("a page of the texture");
        let input = &self.inputs[texture];
        if self.current.as_ref().is_none_or(|c| c.0 != texture) {
            let fail = |reason| BuildError::Texture {
                name: input.name.clone(),
                reason,
            };
            let bytes = decode::encoded_bytes(input).map_err(fail)?;
            let level0 = decode::decode(&bytes, texture_memory_bytes(&shape)).map_err(fail)?;
            if (level0.width, level0.height) != (shape.width, shape.height) {
                return Err(fail(format!(
                    "changed during the build: {} × {} texels, {} × {} when it began",
                    level0.width, level0.height, shape.width, shape.height
                )));
            }
            // The texture before it is dropped first.
            self.current = None;
            self.current = Some((texture, 0, level0));
        }
        let (_, at, level) = self.current.as_mut().expect("decoded");
        while *at < l {
            *level = pyramid::next_level(level);
            *at += 1;
        }
        pages::cut_page(level, &shape, l, x, y, out);
        Ok(())
    }
}

/// A writer's feed: the build's patches and ids, and the texture pages where there are.
pub struct WithPages<'a, F> {
    pub blobs: F,
    pub pages: Option<PageMaker<'a>>,
}

impl<F: BlobFeed> BlobFeed for WithPages<'_, F> {
    fn patch(&mut self, tet: usize, out: &mut Vec<u8>) -> io::Result<()> {
        self.blobs.patch(tet, out)
    }

    fn ids(&mut self, tet: usize, out: &mut Vec<u8>) -> io::Result<()> {
        self.blobs.ids(tet, out)
    }

    fn texture_page(&mut self, global: u32, out: &mut Vec<u8>) -> io::Result<()> {
        match &mut self.pages {
            Some(pages) => pages
                .page(global, out)
                .map_err(|e| io::Error::other(e.to_string())),
            None => self.blobs.texture_page(global, out),
        }
    }
}

/// What identifies the textures for a checkpoint's manifest: each one's name, wrap, size and
/// CRC-32 of its encoded bytes (an unreadable one says so), and the bands. A resume whose
/// textures differ from those its checkpoint was made with is refused.
pub fn fingerprint(textures: &MeshTextures) -> String {
    let mut parts: Vec<String> = textures
        .textures
        .iter()
        .map(|t| {
            let content = match decode::encoded_bytes(t) {
                Ok(bytes) => format!(
                    "{} bytes, CRC-32 {:08x}",
                    bytes.len(),
                    crc32fast::hash(&bytes)
                ),
                Err(e) => format!("unreadable ({e})"),
            };
            format!("{} ({:?}, {:?}): {content}", t.name, t.wrap_u, t.wrap_v)
        })
        .collect();
    parts.push(format!("bands {:?}", textures.bands));
    parts.join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture_input::TextureSource;
    use tessera_core::texture::{Wrap, NO_TEXTURE};

    fn png(width: u32, height: u32) -> Vec<u8> {
        let texels: Vec<u8> = (0..width * height * 4)
            .map(|i| (i * 31 % 256) as u8)
            .collect();
        let image = image::RgbaImage::from_raw(width, height, texels).unwrap();
        let mut bytes = Vec::new();
        image
            .write_to(
                &mut std::io::Cursor::new(&mut bytes),
                image::ImageFormat::Png,
            )
            .unwrap();
        bytes
    }

    fn textures(bytes: Vec<u8>) -> MeshTextures {
        MeshTextures {
            textures: vec![TextureInput {
                name: "wood.png".into(),
                source: TextureSource::Encoded { bytes, mime: None },
                wrap_u: Wrap::Repeat,
                wrap_v: Wrap::Repeat,
            }],
            bands: vec![Band::covering(0, 0.0, 0.5, 0).unwrap()],
        }
    }

    fn refusal(textures: &MeshTextures, memory: Option<&MemoryBudget>) -> String {
        plan(textures, memory, PageEncoding::Bc1)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn bad_textures_are_refused_naming_them() {
        let good = png(40, 30);
        assert_eq!(
            plan(&textures(good.clone()), None, PageEncoding::Bc1)
                .unwrap()
                .directory
                .shapes[0],
            TextureShape::new(40, 30, Wrap::Repeat, Wrap::Repeat).unwrap()
        );
        let message = refusal(&textures(b"GIF89a not really".to_vec()), None);
        assert!(
            message.contains("wood.png") && message.contains("format"),
            "{message}"
        );
        let message = refusal(&textures(good[..good.len() / 2].to_vec()), None);
        assert!(
            message.contains("wood.png") && message.contains("corrupt"),
            "{message}"
        );
        let mut missing = textures(good.clone());
        missing.textures[0].source = TextureSource::File("/nonexistent/wood.png".into());
        let message = refusal(&missing, None);
        assert!(
            message.contains("cannot read /nonexistent/wood.png"),
            "{message}"
        );
        let mut bands = textures(good.clone());
        bands.bands[0].texture = 1;
        assert!(refusal(&bands, None).contains("bands"));
        let budget = MemoryBudget {
            bytes: 1000,
            temp_dir: std::env::temp_dir(),
        };
        let message = refusal(&textures(good), Some(&budget));
        assert!(message.contains("memory budget of 1000 bytes"), "{message}");
    }

    #[test]
    fn every_wedge_lies_in_a_band() {
        let bands = [
            Band::covering(3, 0.0, 0.5, 0).unwrap(),
            Band::covering(0, -1.0, 1.5, NO_TEXTURE).unwrap(),
        ];
        let check = |vs: &[f32]| {
            let mut uvs = vs.iter().map(|&v| Ok([0.25, v]));
            check_wedges_in_bands(Some(&mut uvs), &bands)
        };
        check(&[0.0, 1.99, 2.5, 3.0, 3.999]).unwrap();
        let message = check(&[0.5, 4.0]).unwrap_err().to_string();
        assert!(message.contains("wedge 1 has v = 4"), "{message}");
        assert!(check(&[-0.1]).is_err());
        assert!(check(&[f32::NAN]).is_err());
        let message = check_wedges_in_bands(None, &bands).unwrap_err().to_string();
        assert!(message.contains("no texture coordinates"), "{message}");
    }

    #[test]
    fn pages_are_made_in_order_only_in_their_encoding() {
        let t = textures(png(300, 10));
        for encoding in [PageEncoding::Rgba8, PageEncoding::Bc1] {
            let planned = plan(&t, None, encoding).unwrap();
            let mut maker = PageMaker::new(&t, &planned);
            let mut out = Vec::new();
            assert!(maker.page(1, &mut out).is_err());
            for g in 0..planned.directory.page_count() as u32 {
                maker.page(g, &mut out).unwrap();
            }
            assert_eq!(out.len(), 6 * encoding.page_bytes());
            let summary = maker.summary();
            assert_eq!((summary.pages, summary.page_bytes), (6, out.len() as u64));
            match encoding {
                PageEncoding::Rgba8 => assert!(summary.psnr_db.is_infinite()),
                // A noise texture: BC1's worst case, still a finite, positive PSNR.
                PageEncoding::Bc1 => assert!(summary.psnr_db > 5.0 && summary.psnr_db < 60.0),
            }
        }
    }
}
