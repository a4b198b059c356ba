//! Textures as pages (`tessera_core::texture`): where the renderer gets them (`PageSource`),
//! the tables the fragment shader reads (`TextureLayout`: bands, texture records) and the CPU
//! mirror of `shaders/texture.wgsl`'s arithmetic: the level a pixel wants from its UV
//! derivatives and the page and in-page coordinate that serve a UV at a level. The mirror is
//! written operation for operation as the shader does it (f32, then i32 texel indices) and is
//! tested against `core::texture`'s page numbering and gutter rule.
//!
//! A page in the GPU's pool carries its own two smaller mips (68 and 34 texels a side, made by
//! a 2 × 2 box in linear light, `tessera_core::texture_codec::page_mips`), so
//! `textureSampleGrad` filters trilinearly up to two levels coarser than the page's level
//! without leaving the page. The pool's layers are BC1 where the pages are and the adapter
//! samples BC1 (`PoolFormat`), else RGBA8 (BC1 pages decoded on the CPU as they load).

use std::borrow::Cow;

pub use tessera_core::texture::PAGE_MIPS;
use tessera_core::texture::{
    Band, PageEncoding, TextureShape, BC1_PAGE_BYTES, NO_TEXTURE, PAGE_GUTTER, PAGE_PAYLOAD,
    PAGE_SIDE,
};
pub use tessera_core::texture_codec::{halve, linear_to_srgb, page_mips, srgb_to_linear};

use super::device::GpuContext;

/// Where a textured renderer reads its pages: the textures' shapes (in texture order), the
/// bands naming them, and each page as stored in its `encoding` by global page index
/// (`first_page(t) + shape.page_index(l, x, y)`, `first_page(t)` the pages of the textures
/// before `t`). Called from the render thread as pages are needed; an error is reported by
/// the frame that asked (a missing or corrupt page).
pub trait PageSource: Send + Sync {
    fn shapes(&self) -> &[TextureShape];
    fn bands(&self) -> &[Band];
    /// The page as stored: `encoding().page_bytes()` bytes (`tessera_core::texture_codec`).
    fn page(&self, global: u32) -> Result<Cow<'_, [u8]>, String>;
    /// How every page is stored.
    fn encoding(&self) -> PageEncoding {
        PageEncoding::Rgba8
    }
}

/// Bytes one RGBA8 pool layer takes on the GPU (all three mips).
pub const LAYER_BYTES: u64 =
    (PAGE_SIDE * PAGE_SIDE + (PAGE_SIDE / 2).pow(2) + (PAGE_SIDE / 4).pow(2)) as u64 * 4;

/// The format of the pool's layers: BC1 pages stay BC1 on an adapter that samples it
/// (`wgpu::Features::TEXTURE_COMPRESSION_BC`: 12,208 bytes a layer, 7.95 times fewer);
/// otherwise every page is RGBA8 on the GPU (BC1 pages decoded as they load).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PoolFormat {
    Rgba8,
    Bc1,
}

impl PoolFormat {
    /// The pool format for pages stored in `encoding` on `ctx`'s adapter.
    pub fn for_pages(ctx: &GpuContext, encoding: PageEncoding) -> PoolFormat {
        match encoding {
            PageEncoding::Bc1 if ctx.capabilities.bc_textures => PoolFormat::Bc1,
            _ => PoolFormat::Rgba8,
        }
    }

    /// Bytes one layer (three mips) takes on the GPU.
    pub fn layer_bytes(self) -> u64 {
        match self {
            PoolFormat::Rgba8 => LAYER_BYTES,
            PoolFormat::Bc1 => BC1_PAGE_BYTES as u64,
        }
    }

    pub fn texture_format(self) -> wgpu::TextureFormat {
        match self {
            PoolFormat::Rgba8 => wgpu::TextureFormat::Rgba8UnormSrgb,
            PoolFormat::Bc1 => wgpu::TextureFormat::Bc1RgbaUnormSrgb,
        }
    }
}
/// Words of one texture record in the info buffer (texture.wgsl's `RECORD_WORDS`).
pub const RECORD_WORDS: usize = 24;
/// Words before the bands in the info buffer: band count, texture count, two pads.
pub const INFO_HEADER_WORDS: usize = 4;
/// Levels a record has room for (a `MAX_TEXTURE_SIDE` texture has 10).
const RECORD_LEVELS: usize = RECORD_WORDS - 8;

/// The textures' page numbering and the tables the shader reads.
#[derive(Clone, Debug)]
pub struct TextureLayout {
    pub shapes: Vec<TextureShape>,
    pub bands: Vec<Band>,
    /// Per texture, its first global page; then the total (one more entry than textures).
    pub first_pages: Vec<u32>,
}

/// Why a set of textures cannot be drawn.
#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    #[error("the textures' bands are invalid (overlapping, empty or naming no texture)")]
    BadBands,
    #[error("the textures hold {0} pages, more than a u32 page index numbers")]
    TooManyPages(u64),
    #[error("the model has no texture coordinates: its textures cannot be drawn")]
    NoUvs,
    #[error("the adapter cannot draw textures: it lacks {0}")]
    Missing(String),
    #[error(
        "--gpu-budget of {budget} bytes is too small for the textures: their page pool needs \
         at least {needed} bytes (a quarter of the budget goes to texture pages)"
    )]
    BudgetTooSmall { budget: u64, needed: u64 },
    #[error(
        "the texture page pool needs {needed} layers but the adapter's limit \
         max_texture_array_layers is {limit}"
    )]
    OverLayerLimit { needed: u32, limit: u32 },
    #[error("the page table of {bytes} bytes exceeds the adapter's storage binding limit {limit}")]
    OverBindingLimit { bytes: u64, limit: u64 },
    #[error("reading texture page {page}: {message}")]
    Page { page: u32, message: String },
    #[error("{0}")]
    Device(#[from] super::device::GpuFailure),
}

/// Where a UV is served at one level: the global page and the coordinate inside that page's
/// image, in page texels (gutter included: `[0, PAGE_SIDE)`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PagePoint {
    pub global: u32,
    pub page: (u32, u32),
    pub texel: [f32; 2],
}

impl TextureLayout {
    /// The layout of `shapes` named by `bands`; an error if the bands are invalid or the pages
    /// do not fit u32.
    pub fn new(shapes: &[TextureShape], bands: &[Band]) -> Result<TextureLayout, TextureError> {
        if !tessera_core::texture::bands_valid(bands, shapes.len() as u32)
            || shapes.iter().any(|s| s.levels() as usize > RECORD_LEVELS)
        {
            return Err(TextureError::BadBands);
        }
        let mut first_pages = vec![0u64];
        for s in shapes {
            first_pages.push(first_pages.last().unwrap() + s.page_count() as u64);
        }
        let total = *first_pages.last().unwrap();
        if total >= u32::MAX as u64 / 2 {
            return Err(TextureError::TooManyPages(total));
        }
        Ok(TextureLayout {
            shapes: shapes.to_vec(),
            bands: bands.to_vec(),
            first_pages: first_pages.into_iter().map(|p| p as u32).collect(),
        })
    }

    /// Pages over every texture: the page table's length.
    pub fn total_pages(&self) -> u32 {
        *self.first_pages.last().unwrap()
    }

    /// The pinned pages: each texture's last level (one page), always resident.
    pub fn pinned(&self) -> Vec<u32> {
        (0..self.shapes.len())
            .map(|t| self.first_pages[t] + self.shapes[t].page_count() - 1)
            .collect()
    }

    /// The level of a global page (for the residency's preference of coarser pages).
    pub fn level_of(&self, global: u32) -> u32 {
        let t = self.first_pages.partition_point(|&f| f <= global) - 1;
        let (level, _, _) = self.shapes[t]
            .page_coords(global - self.first_pages[t])
            .expect("a global page inside the layout");
        level
    }

    /// The info buffer's words: header, bands (start, span, shift, texture), then a record a
    /// texture (width, height, levels, wrap u | wrap v << 1, first page, 3 pads, level
    /// starts).
    pub fn info_words(&self) -> Vec<u32> {
        let mut words = vec![self.bands.len() as u32, self.shapes.len() as u32, 0, 0];
        for b in &self.bands {
            words.extend([b.start as u32, b.span, b.shift as u32, b.texture]);
        }
        for (t, s) in self.shapes.iter().enumerate() {
            let mut record = [0u32; RECORD_WORDS];
            record[..5].copy_from_slice(&[
                s.width,
                s.height,
                s.levels(),
                s.wrap_u.code() | s.wrap_v.code() << 1,
                self.first_pages[t],
            ]);
            for l in 0..s.levels() {
                record[8 + l as usize] = s.level_start(l);
            }
            words.extend(record);
        }
        words
    }

    /// The band holding `v` as the shader finds it (`floor(v)` compared in f32), the first
    /// of them; `None` outside every band.
    pub fn band_at(&self, v: f32) -> Option<&Band> {
        let f = v.floor();
        self.bands
            .iter()
            .find(|b| f >= b.start as f32 && f < b.start as f32 + b.span as f32)
    }

    /// The level a pixel wants: `floor(½ log2 ρ²)` with ρ² the larger squared length of the
    /// UV derivatives in level-0 texels, clamped to the texture's levels (texture.wgsl
    /// `desired_level`).
    pub fn desired_level(&self, texture: u32, ddx: [f32; 2], ddy: [f32; 2]) -> u32 {
        let s = &self.shapes[texture as usize];
        let (w, h) = (s.width as f32, s.height as f32);
        let a = [ddx[0] * w, ddx[1] * h];
        let b = [ddy[0] * w, ddy[1] * h];
        let rho2 = (a[0] * a[0] + a[1] * a[1]).max(b[0] * b[0] + b[1] * b[1]);
        let lod = 0.5 * rho2.log2();
        // lod < 1, and NaN (ρ² = 0 gives −∞), draw level 0; texture.wgsl: !(lod >= 1.0).
        if lod.partial_cmp(&1.0).is_none_or(|o| o.is_lt()) {
            return 0;
        }
        (lod.floor() as u32).min(s.levels() - 1)
    }

    /// The page of level `level` of `texture` that serves texture coordinate `st` (`v`
    /// already unshifted) and where in its image (texture.wgsl `page_point`): the texel
    /// holding `st` wrapped or clamped into the level, its page, and the coordinate moved by
    /// the same whole texels.
    pub fn page_point(&self, texture: u32, level: u32, st: [f32; 2]) -> PagePoint {
        let s = &self.shapes[texture as usize];
        let (lw, lh) = s.level_size(level);
        let axis = |t: f32, n: u32, repeat: bool| -> (u32, f32) {
            let p = t * n as f32;
            let i = p.floor();
            let index = i as i32;
            let n = n as i32;
            let wrapped = if repeat {
                index.wrapping_rem(n).wrapping_add(n).wrapping_rem(n)
            } else {
                index.clamp(0, n - 1)
            };
            let page = wrapped as u32 / PAGE_PAYLOAD;
            let texel =
                (p - i) + (wrapped - (page * PAGE_PAYLOAD) as i32 + PAGE_GUTTER as i32) as f32;
            (page, texel)
        };
        let repeat_u = s.wrap_u == tessera_core::texture::Wrap::Repeat;
        let repeat_v = s.wrap_v == tessera_core::texture::Wrap::Repeat;
        let (px, tx) = axis(st[0], lw, repeat_u);
        let (py, ty) = axis(st[1], lh, repeat_v);
        let global = self.first_pages[texture as usize]
            + s.page_index(level, px, py)
                .expect("a page inside the level");
        PagePoint {
            global,
            page: (px, py),
            texel: [tx, ty],
        }
    }

    /// The texture a shifted UV samples and its unshifted coordinate; `None` for a band
    /// without texture or outside every band.
    pub fn texture_at(&self, uv: [f32; 2]) -> Option<(u32, [f32; 2])> {
        let band = self.band_at(uv[1])?;
        (band.texture != NO_TEXTURE).then(|| (band.texture, [uv[0], uv[1] - band.shift as f32]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tessera_core::texture::Wrap;

    fn layout() -> TextureLayout {
        let a = TextureShape::new(300, 200, Wrap::Repeat, Wrap::Clamp).unwrap();
        let b = TextureShape::new(1000, 129, Wrap::Clamp, Wrap::Repeat).unwrap();
        let bands = [
            Band {
                start: 0,
                span: 2,
                shift: 0,
                texture: 0,
            },
            Band {
                start: 2,
                span: 1,
                shift: 2,
                texture: NO_TEXTURE,
            },
            Band {
                start: 3,
                span: 1,
                shift: 3,
                texture: 1,
            },
        ];
        TextureLayout::new(&[a, b], &bands).unwrap()
    }

    /// The mirror's page and in-page texel name the same level texel as core's numbering and
    /// gutter rule, for coordinates inside, on the edges of and far outside the texture.
    #[test]
    fn page_points_match_core_pages_and_gutters() {
        let layout = layout();
        let steps = [
            -3.3f32, -1.0, -0.001, 0.0, 0.2, 0.4999, 0.5, 0.77, 0.9999, 1.0, 1.6, 7.25,
        ];
        for texture in 0..2u32 {
            let s = layout.shapes[texture as usize];
            for level in 0..s.levels() {
                let (lw, lh) = s.level_size(level);
                for &u in &steps {
                    for &v in &steps {
                        let point = layout.page_point(texture, level, [u, v]);
                        let (px, py) = point.page;
                        let local = layout.first_pages[texture as usize];
                        assert_eq!(s.page_index(level, px, py), Some(point.global - local));
                        let (i, j) = (point.texel[0].floor() as u32, point.texel[1].floor() as u32);
                        assert!(i < PAGE_SIDE && j < PAGE_SIDE);
                        let source = s.page_texel_source(level, px, py, i, j);
                        let expect = (
                            s.wrap_u.texel((u * lw as f32).floor() as i64, lw),
                            s.wrap_v.texel((v * lh as f32).floor() as i64, lh),
                        );
                        assert_eq!(source, expect, "texture {texture} level {level} uv {u},{v}");
                        // The fraction is kept: bilinear filtering sees the same neighbours.
                        let frac = (u * lw as f32) - (u * lw as f32).floor();
                        assert!((point.texel[0].fract() - frac).abs() < 1e-4);
                    }
                }
            }
        }
    }

    #[test]
    fn levels_follow_the_derivatives_and_bands_name_textures() {
        let layout = layout();
        // 300 × 200: one texel a pixel along u is level 0, four is level 2, far beyond the
        // last level clamps.
        assert_eq!(
            layout.desired_level(0, [1.0 / 300.0, 0.0], [0.0, 1.0 / 200.0]),
            0
        );
        assert_eq!(
            layout.desired_level(0, [4.0 / 300.0, 0.0], [0.0, 1.0 / 200.0]),
            2
        );
        assert_eq!(layout.desired_level(0, [1.0, 0.0], [0.0, 1.0]), 2);
        assert_eq!(layout.desired_level(0, [0.0, 0.0], [0.0, 0.0]), 0);
        assert_eq!(layout.texture_at([0.3, 1.5]), Some((0, [0.3, 1.5])));
        assert_eq!(layout.texture_at([0.3, 2.5]), None);
        assert_eq!(layout.texture_at([0.3, 3.25]), Some((1, [0.3, 0.25])));
        assert_eq!(layout.texture_at([0.3, -0.5]), None);
        assert_eq!(
            layout.pinned(),
            vec![layout.shapes[0].page_count() - 1, layout.total_pages() - 1]
        );
        let last = layout.total_pages() - 1;
        assert_eq!(layout.level_of(last), layout.shapes[1].levels() - 1);
        assert_eq!(layout.level_of(layout.first_pages[1]), 0);
        let words = layout.info_words();
        assert_eq!(words.len(), INFO_HEADER_WORDS + 4 * 3 + 2 * RECORD_WORDS);
    }

    #[test]
    fn halving_averages_in_linear_light() {
        // Black and white average to linear 0.5, sRGB 188; an odd edge repeats.
        let texels = [0, 0, 0, 255, 255, 255, 255, 255, 0, 0, 0, 255];
        let (half, w, h) = halve(&texels, 3, 1);
        assert_eq!((w, h), (2, 1));
        assert_eq!(&half[..4], &[188, 188, 188, 255]);
        assert_eq!(&half[4..], &[0, 0, 0, 255]);
        let page = vec![200u8; tessera_core::texture::PAGE_BYTES];
        let mips = page_mips(&page);
        assert_eq!(mips[1].len(), 68 * 68 * 4);
        assert_eq!(mips[2].len(), 34 * 34 * 4);
        assert!(mips[2].iter().all(|&b| b == 200));
        assert_eq!(
            LAYER_BYTES as usize,
            mips.iter().map(Vec::len).sum::<usize>()
        );
    }
}
