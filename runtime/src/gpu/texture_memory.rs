//! A `PageSource` held in memory: level-0 images cut into the pages `core::texture` specifies
//! (the pyramid by 2 × 2 boxes in linear light, each page with its gutter wrapped or
//! clamped). For tests and small tools; a repository's pages come from its file.

use std::borrow::Cow;
use std::sync::atomic::{AtomicU64, Ordering};

use tessera_core::texture::{Band, PageEncoding, TextureShape, PAGE_BYTES, PAGE_SIDE};

use super::texture_pages::{halve, PageSource, TextureError, TextureLayout};

/// Every page of some textures, made at construction.
pub struct MemoryPages {
    shapes: Vec<TextureShape>,
    bands: Vec<Band>,
    pages: Vec<Vec<u8>>,
    encoding: PageEncoding,
    /// Pages handed out so far (`page` calls).
    reads: AtomicU64,
}

impl MemoryPages {
    /// The pages of `textures` (each a shape and its level-0 RGBA8 sRGB texels, row-major,
    /// top row first: `width × height × 4` bytes) named by `bands`; an error if the bands are
    /// invalid. Panics if an image's length does not match its shape.
    pub fn new(
        textures: &[(TextureShape, Vec<u8>)],
        bands: &[Band],
    ) -> Result<MemoryPages, TextureError> {
        let shapes: Vec<TextureShape> = textures.iter().map(|(s, _)| *s).collect();
        TextureLayout::new(&shapes, bands)?;
        let mut pages = Vec::new();
        for (shape, texels) in textures {
            let (mut level, mut w, mut h) = (texels.clone(), shape.width, shape.height);
            for l in 0..shape.levels() {
                assert_eq!((w, h), shape.level_size(l), "level {l} of the pyramid");
                let (nx, ny) = shape.pages_across(l);
                for y in 0..ny {
                    for x in 0..nx {
                        pages.push(cut_page(shape, &level, l, x, y));
                    }
                }
                if l + 1 < shape.levels() {
                    (level, w, h) = halve(&level, w, h);
                }
            }
        }
        Ok(MemoryPages {
            shapes,
            bands: bands.to_vec(),
            pages,
            encoding: PageEncoding::Rgba8,
            reads: AtomicU64::new(0),
        })
    }

    /// The same pages stored in `encoding` (`tessera_core::texture_codec::encode_page`), as a
    /// build with `--texture-encoding` would store them.
    pub fn encoded(mut self, encoding: PageEncoding) -> MemoryPages {
        assert_eq!(self.encoding, PageEncoding::Rgba8, "encoded once");
        for page in &mut self.pages {
            *page = tessera_core::texture_codec::encode_page(encoding, page);
        }
        self.encoding = encoding;
        self
    }

    /// Pages read through `page` so far.
    pub fn reads(&self) -> u64 {
        self.reads.load(Ordering::Relaxed)
    }
}

/// Page `(level, x, y)` of `shape` from its level's texels.
fn cut_page(shape: &TextureShape, level_texels: &[u8], level: u32, x: u32, y: u32) -> Vec<u8> {
    let (w, _) = shape.level_size(level);
    let mut page = Vec::with_capacity(PAGE_BYTES);
    for j in 0..PAGE_SIDE {
        for i in 0..PAGE_SIDE {
            let (sx, sy) = shape.page_texel_source(level, x, y, i, j);
            let at = ((sy * w + sx) * 4) as usize;
            page.extend_from_slice(&level_texels[at..at + 4]);
        }
    }
    page
}

impl PageSource for MemoryPages {
    fn shapes(&self) -> &[TextureShape] {
        &self.shapes
    }

    fn bands(&self) -> &[Band] {
        &self.bands
    }

    fn encoding(&self) -> PageEncoding {
        self.encoding
    }

    fn page(&self, global: u32) -> Result<Cow<'_, [u8]>, String> {
        self.reads.fetch_add(1, Ordering::Relaxed);
        self.pages
            .get(global as usize)
            .map(|p| Cow::Borrowed(p.as_slice()))
            .ok_or_else(|| format!("page {global} of {}", self.pages.len()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tessera_core::texture::{Wrap, NO_TEXTURE};

    #[test]
    fn pages_hold_their_level_texels_and_gutters() {
        // Texel (x, y) of level 0 is (x, y, 7, 255).
        let shape = TextureShape::new(200, 140, Wrap::Repeat, Wrap::Clamp).unwrap();
        let texels: Vec<u8> = (0..140u32)
            .flat_map(|y| (0..200u32).flat_map(move |x| [x as u8, y as u8, 7, 255]))
            .collect();
        let band = Band {
            start: 0,
            span: 1,
            shift: 0,
            texture: 0,
        };
        let pages = MemoryPages::new(&[(shape, texels)], &[band]).unwrap();
        assert_eq!(pages.pages.len() as u32, shape.page_count());
        let page = pages.page(shape.page_index(0, 1, 0).unwrap()).unwrap();
        let texel = |i: u32, j: u32| &page[((j * PAGE_SIDE + i) * 4) as usize..][..4];
        // Payload (4, 4) is level texel (128, 0); the top gutter clamps to row 0, the right
        // one wraps to column 0.
        assert_eq!(texel(4, 4), &[128, 0, 7, 255]);
        assert_eq!(texel(4, 0), &[128, 0, 7, 255]);
        assert_eq!(texel(4 + 72, 10), &[0, 6, 7, 255]);
        assert!(pages.page(shape.page_count()).is_err());
        assert_eq!(pages.reads(), 2);
        let bad = Band { texture: 1, ..band };
        assert!(MemoryPages::new(&[], &[bad]).is_err());
        let plain = Band {
            texture: NO_TEXTURE,
            ..band
        };
        assert!(MemoryPages::new(&[], &[plain]).is_ok());
    }
}
