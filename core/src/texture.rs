//! Texture space: how a repository's textures are cut into pages and how a wedge's texture
//! coordinate names its texture. Pure arithmetic, shared by the build (which cuts the pages),
//! the reader (which checks them) and the renderer (whose fragment shader, `draw.wgsl`,
//! mirrors it operation for operation).
//!
//! ## Pages
//! A texture is stored as a mip pyramid cut into square *pages*: `PAGE_PAYLOAD` texels a side
//! plus a gutter of `PAGE_GUTTER` texels on every side (`PAGE_SIDE` in all), RGBA8 with the
//! colour channels sRGB-encoded. Level `l` of a `w × h` texture is
//! `max(1, ceil(w / 2^l)) × max(1, ceil(h / 2^l))`, made from level `l − 1` by a 2 × 2 box
//! filter in linear light (an odd edge repeats its last texel); the last level is the first
//! that fits one page. Page `(l, x, y)` holds level-`l` texels
//! `[x·P − G, x·P + P + G) × [y·P − G, y·P + P + G)` (P payload, G gutter); a texel outside the
//! level is wrapped (`Wrap::Repeat`) or clamped (`Wrap::Clamp`) axis by axis, so bilinear
//! filtering inside a page, and its own two smaller mips (a 2-texel and a 1-texel gutter),
//! never reads across a chart or page border it should not.
//!
//! Pages are numbered texture by texture, level by level, row by row: the *global page index*
//! `first_page(t) + level_start(l) + y · pages_x(l) + x`, one entry of the renderer's page table.
//!
//! ## Bands: which texture a wedge samples
//! A patch stores one `(u, v)` a wedge and no material. A textured build shifts each
//! material's `v` by an integer so that materials occupy disjoint integer intervals of `v`,
//! its *band*: band `b` covers `floor(v) ∈ [start, start + span)` and names one texture (or
//! none: the material is its colour alone). The texture is sampled at `(u, v − shift)`; the
//! shift is an integer, so `Wrap::Repeat` sees the input's own fractions. A triangle's corners
//! share a material, so any point of it interpolates a `v` inside their band. A model with a
//! single texture and `v` in `[0, 1)` has one band with shift 0: its coordinates are unchanged.

/// Texels a page side holds for its own level region.
pub const PAGE_PAYLOAD: u32 = 128;
/// Texels of neighbouring content on each side of a page's payload.
pub const PAGE_GUTTER: u32 = 4;
/// Texels a stored page side: payload and both gutters.
pub const PAGE_SIDE: u32 = PAGE_PAYLOAD + 2 * PAGE_GUTTER;
/// Bytes of one page's texels: `PAGE_SIDE²` RGBA8 texels, row-major, top row first (a page
/// as `PageEncoding::Rgba8` stores it, and as every encoding decodes).
pub const PAGE_BYTES: usize = (PAGE_SIDE * PAGE_SIDE * 4) as usize;
/// Mips a page carries for filtering inside it: the page and its two halvings (136, 68 and 34
/// texels a side), made by `texture_codec::page_mips`.
pub const PAGE_MIPS: u32 = 3;
/// Bytes of one `PageEncoding::Bc1` page: its three mips as BC1 blocks (8 bytes a 4 × 4
/// block; 34², 17² and 9² blocks, the last mip's edge blocks half used).
pub const BC1_PAGE_BYTES: usize = 8 * (34 * 34 + 17 * 17 + 9 * 9);
const _: () = assert!(PAGE_SIDE == 136, "BC1_PAGE_BYTES counts 136-texel pages");
/// Largest texture side a build accepts (texels), so every index below fits u32 with room.
pub const MAX_TEXTURE_SIDE: u32 = 1 << 16;
/// `Band::texture` of a band drawn with its colour alone.
pub const NO_TEXTURE: u32 = u32::MAX;

/// How a repository stores its pages (`texture_codec` encodes and decodes them). Every page
/// of a repository has the same encoding, so page `g` lies at `g · page_bytes()`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PageEncoding {
    /// `PAGE_BYTES` of RGBA8 texels as cut, lossless; the renderer makes the two smaller mips
    /// as it loads a page. What a section without an encoding field (code 0) holds.
    #[default]
    Rgba8,
    /// `BC1_PAGE_BYTES`: the page's three mips (alpha made opaque), each as BC1 (DXT1) blocks
    /// of sRGB colour, row-major, top row first; lossy (4 bits a texel), 6.06 times smaller,
    /// uploaded to the GPU as they are where the adapter samples BC1, else decoded. What a
    /// build writes unless told otherwise.
    Bc1,
}

impl PageEncoding {
    /// The texture section header's code: 0 RGBA8, 1 BC1.
    pub fn code(self) -> u32 {
        match self {
            PageEncoding::Rgba8 => 0,
            PageEncoding::Bc1 => 1,
        }
    }

    pub fn from_code(code: u32) -> Option<PageEncoding> {
        match code {
            0 => Some(PageEncoding::Rgba8),
            1 => Some(PageEncoding::Bc1),
            _ => None,
        }
    }

    /// Bytes of one stored page.
    pub fn page_bytes(self) -> usize {
        match self {
            PageEncoding::Rgba8 => PAGE_BYTES,
            PageEncoding::Bc1 => BC1_PAGE_BYTES,
        }
    }

    /// `rgba8` or `bc1`, as the CLI and reports spell it.
    pub fn name(self) -> &'static str {
        match self {
            PageEncoding::Rgba8 => "rgba8",
            PageEncoding::Bc1 => "bc1",
        }
    }
}

/// What a texture coordinate outside `[0, 1)` samples, along one axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Wrap {
    /// The texture tiles: `t` samples `t − floor(t)` (glTF `REPEAT`, OBJ and PLY's default).
    Repeat,
    /// The edge texel extends (glTF `CLAMP_TO_EDGE`).
    Clamp,
}

impl Wrap {
    /// Stored code (0 repeat, 1 clamp).
    pub fn code(self) -> u32 {
        match self {
            Wrap::Repeat => 0,
            Wrap::Clamp => 1,
        }
    }

    /// The wrap a stored code names, `None` for an unknown code.
    pub fn from_code(code: u32) -> Option<Wrap> {
        match code {
            0 => Some(Wrap::Repeat),
            1 => Some(Wrap::Clamp),
            _ => None,
        }
    }

    /// Texel index `i` of a level `n` texels long, brought inside `[0, n)`.
    pub fn texel(self, i: i64, n: u32) -> u32 {
        let n = i64::from(n.max(1));
        match self {
            Wrap::Repeat => i.rem_euclid(n) as u32,
            Wrap::Clamp => i.clamp(0, n - 1) as u32,
        }
    }
}

/// A texture's size and wrap: everything its page layout follows from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TextureShape {
    pub width: u32,
    pub height: u32,
    pub wrap_u: Wrap,
    pub wrap_v: Wrap,
}

impl TextureShape {
    /// `None` unless both sides are in `1..=MAX_TEXTURE_SIDE`.
    pub fn new(width: u32, height: u32, wrap_u: Wrap, wrap_v: Wrap) -> Option<Self> {
        let ok = |s: u32| (1..=MAX_TEXTURE_SIDE).contains(&s);
        (ok(width) && ok(height)).then_some(TextureShape {
            width,
            height,
            wrap_u,
            wrap_v,
        })
    }

    /// Texels of level `l`: `(max(1, ceil(w / 2^l)), max(1, ceil(h / 2^l)))`.
    pub fn level_size(&self, level: u32) -> (u32, u32) {
        let side = |s: u32| {
            if level >= 32 {
                1
            } else {
                s.div_ceil(1 << level).max(1)
            }
        };
        (side(self.width), side(self.height))
    }

    /// Levels stored: up to and including the first that fits one page.
    pub fn levels(&self) -> u32 {
        let mut level = 0;
        loop {
            let (w, h) = self.level_size(level);
            if w <= PAGE_PAYLOAD && h <= PAGE_PAYLOAD {
                return level + 1;
            }
            level += 1;
        }
    }

    /// Pages across and down level `l`.
    pub fn pages_across(&self, level: u32) -> (u32, u32) {
        let (w, h) = self.level_size(level);
        (w.div_ceil(PAGE_PAYLOAD), h.div_ceil(PAGE_PAYLOAD))
    }

    /// Index of level `l`'s first page among the texture's pages.
    pub fn level_start(&self, level: u32) -> u32 {
        (0..level)
            .map(|l| {
                let (x, y) = self.pages_across(l);
                x * y
            })
            .sum()
    }

    /// Pages over all levels.
    pub fn page_count(&self) -> u32 {
        self.level_start(self.levels())
    }

    /// Index of page `(level, x, y)` among the texture's pages (`None` outside the pyramid).
    pub fn page_index(&self, level: u32, x: u32, y: u32) -> Option<u32> {
        if level >= self.levels() {
            return None;
        }
        let (nx, ny) = self.pages_across(level);
        (x < nx && y < ny).then(|| self.level_start(level) + y * nx + x)
    }

    /// The page `(level, x, y)` an index among the texture's pages names.
    pub fn page_coords(&self, index: u32) -> Option<(u32, u32, u32)> {
        let mut start = 0;
        for level in 0..self.levels() {
            let (nx, ny) = self.pages_across(level);
            if index < start + nx * ny {
                let i = index - start;
                return Some((level, i % nx, i / nx));
            }
            start += nx * ny;
        }
        None
    }

    /// Level-`l` texel that texel `(i, j)` of page `(x, y)` holds (`i`, `j` < `PAGE_SIDE`,
    /// gutters included), wrapped or clamped into the level.
    pub fn page_texel_source(&self, level: u32, x: u32, y: u32, i: u32, j: u32) -> (u32, u32) {
        let (w, h) = self.level_size(level);
        let origin = |p: u32, t: u32| {
            i64::from(p) * i64::from(PAGE_PAYLOAD) + i64::from(t) - i64::from(PAGE_GUTTER)
        };
        (
            self.wrap_u.texel(origin(x, i), w),
            self.wrap_v.texel(origin(y, j), h),
        )
    }
}

/// One band of `v`: the materials' coordinates shifted into disjoint integer intervals.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Band {
    /// First integer of the band: `floor(v) ≥ start`.
    pub start: i32,
    /// Integers the band covers, ≥ 1: `floor(v) < start + span`.
    pub span: u32,
    /// Added to the input's `v` by the build; the texture is sampled at `v − shift`.
    pub shift: i32,
    /// Index of the texture sampled, or `NO_TEXTURE`.
    pub texture: u32,
}

impl Band {
    /// The band for a material whose input `v` lies in `[v_min, v_max]`, starting at `start`:
    /// its shift moves `floor(v_min)` to `start`. `None` if a bound is not finite or the band
    /// does not fit i32.
    pub fn covering(start: i32, v_min: f32, v_max: f32, texture: u32) -> Option<Band> {
        if !(v_min.is_finite() && v_max.is_finite()) || v_min > v_max {
            return None;
        }
        let low = v_min.floor() as i64;
        let high = v_max.floor() as i64;
        let span = u32::try_from(high - low + 1).ok()?;
        let shift = i32::try_from(i64::from(start) - low).ok()?;
        i32::try_from(i64::from(start) + i64::from(span)).ok()?;
        Some(Band {
            start,
            span,
            shift,
            texture,
        })
    }

    /// Whether a shifted `v` lies in the band.
    pub fn contains(&self, v: f32) -> bool {
        let f = f64::from(v).floor();
        f >= f64::from(self.start) && f < f64::from(self.start) + f64::from(self.span)
    }
}

/// The band a shifted `v` lies in (the first, bands being disjoint), `None` outside all.
pub fn band_of(bands: &[Band], v: f32) -> Option<&Band> {
    bands.iter().find(|b| b.contains(v))
}

/// Whether bands are valid together: each span ≥ 1, intervals disjoint, texture indices
/// `< texture_count` or `NO_TEXTURE`.
pub fn bands_valid(bands: &[Band], texture_count: u32) -> bool {
    let mut intervals: Vec<(i64, i64)> = Vec::with_capacity(bands.len());
    for b in bands {
        if b.span == 0 || !(b.texture < texture_count || b.texture == NO_TEXTURE) {
            return false;
        }
        intervals.push((i64::from(b.start), i64::from(b.start) + i64::from(b.span)));
    }
    intervals.sort_unstable();
    intervals.windows(2).all(|w| w[0].1 <= w[1].0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_4096_texture_has_six_levels_and_1365_pages() {
        let t = TextureShape::new(4096, 4096, Wrap::Repeat, Wrap::Repeat).unwrap();
        assert_eq!(t.levels(), 6);
        assert_eq!(t.pages_across(0), (32, 32));
        assert_eq!(t.pages_across(5), (1, 1));
        assert_eq!(t.page_count(), 1024 + 256 + 64 + 16 + 4 + 1);
        assert_eq!(t.page_index(5, 0, 0), Some(1364));
        assert_eq!(t.page_index(5, 1, 0), None);
        assert_eq!(t.page_index(6, 0, 0), None);
    }

    #[test]
    fn odd_sizes_round_up_and_small_textures_are_one_page() {
        let t = TextureShape::new(300, 129, Wrap::Clamp, Wrap::Repeat).unwrap();
        assert_eq!(t.level_size(1), (150, 65));
        assert_eq!(t.level_size(2), (75, 33));
        assert_eq!(t.levels(), 3);
        assert_eq!(t.pages_across(0), (3, 2));
        let one = TextureShape::new(1, 1, Wrap::Repeat, Wrap::Repeat).unwrap();
        assert_eq!((one.levels(), one.page_count()), (1, 1));
        assert!(TextureShape::new(0, 4, Wrap::Repeat, Wrap::Repeat).is_none());
        assert!(TextureShape::new(MAX_TEXTURE_SIDE + 1, 4, Wrap::Repeat, Wrap::Repeat).is_none());
    }

    #[test]
    fn page_coords_invert_page_index() {
        let t = TextureShape::new(1000, 700, Wrap::Repeat, Wrap::Clamp).unwrap();
        for index in 0..t.page_count() {
            let (l, x, y) = t.page_coords(index).unwrap();
            assert_eq!(t.page_index(l, x, y), Some(index));
        }
        assert_eq!(t.page_coords(t.page_count()), None);
    }

    #[test]
    fn gutters_wrap_or_clamp() {
        let t = TextureShape::new(200, 200, Wrap::Repeat, Wrap::Clamp).unwrap();
        // Texel (0, 0) of page (0, 0) is 4 texels before the level's corner.
        assert_eq!(t.page_texel_source(0, 0, 0, 0, 0), (196, 0));
        assert_eq!(t.page_texel_source(0, 0, 0, 4, 4), (0, 0));
        // Page (1, 1)'s payload starts at texel 128; its right gutter runs past 200.
        assert_eq!(t.page_texel_source(0, 1, 1, 4, 4), (128, 128));
        assert_eq!(t.page_texel_source(0, 1, 1, 135, 135), (59, 199));
    }

    #[test]
    fn bands_shift_by_integers_and_stay_disjoint() {
        let a = Band::covering(0, -0.41, 1.43, 0).unwrap();
        assert_eq!((a.start, a.span, a.shift), (0, 3, 1));
        let b = Band::covering(3, 0.0, 1.0, NO_TEXTURE).unwrap();
        assert_eq!((b.start, b.span, b.shift), (3, 2, 3));
        // The largest v of each band, shifted, stays inside it.
        assert!(a.contains(1.43 + a.shift as f32));
        assert!(b.contains(1.0 + b.shift as f32));
        assert!(!a.contains(3.0));
        let bands = [a, b];
        assert_eq!(band_of(&bands, 3.5).map(|b| b.start), Some(3));
        assert!(bands_valid(&bands, 1));
        assert!(!bands_valid(&bands, 0));
        let overlapping = Band { start: 2, ..b };
        assert!(!bands_valid(&[a, overlapping], 1));
        assert!(Band::covering(0, f32::NAN, 1.0, 0).is_none());
    }
}
