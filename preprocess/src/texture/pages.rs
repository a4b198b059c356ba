//! A level cut into pages (`tessera_core::texture`): page `(l, x, y)` holds the level's texels
//! `[x·P − G, x·P + P + G) × [y·P − G, y·P + P + G)`, those outside the level wrapped or
//! clamped by `TextureShape::page_texel_source`.

use tessera_core::texture::{TextureShape, PAGE_BYTES, PAGE_SIDE};

use super::pyramid::Level;

/// Appends page `(l, x, y)` of `shape` (`PAGE_BYTES` bytes, rows top first) to `out`, cut from
/// `level`, which must be level `l` of the shape's pyramid.
pub fn cut_page(level: &Level, shape: &TextureShape, l: u32, x: u32, y: u32, out: &mut Vec<u8>) {
    assert_eq!((level.width, level.height), shape.level_size(l));
    // The source column of each page column and the row of each page row: a texel's source
    // depends on its column and row alone.
    let columns: Vec<u32> = (0..PAGE_SIDE)
        .map(|i| shape.page_texel_source(l, x, y, i, 0).0)
        .collect();
    out.reserve(PAGE_BYTES);
    for j in 0..PAGE_SIDE {
        let row = shape.page_texel_source(l, x, y, 0, j).1;
        for &column in &columns {
            out.extend_from_slice(&level.texel(column, row));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tessera_core::texture::{Wrap, PAGE_GUTTER};

    /// A level whose every texel names itself: (x, y) as two little-endian u16.
    fn addressed(width: u32, height: u32) -> Level {
        let mut texels = Vec::new();
        for y in 0..height {
            for x in 0..width {
                texels.extend_from_slice(&(x as u16).to_le_bytes());
                texels.extend_from_slice(&(y as u16).to_le_bytes());
            }
        }
        Level {
            width,
            height,
            texels,
        }
    }

    /// The level texel page texel `(i, j)` holds.
    fn source(page: &[u8], i: u32, j: u32) -> (u32, u32) {
        let at = 4 * (j * PAGE_SIDE + i) as usize;
        let x = u16::from_le_bytes([page[at], page[at + 1]]);
        let y = u16::from_le_bytes([page[at + 2], page[at + 3]]);
        (x.into(), y.into())
    }

    #[test]
    fn gutters_repeat_or_clamp() {
        let shape = TextureShape::new(200, 150, Wrap::Repeat, Wrap::Clamp).unwrap();
        let level = addressed(200, 150);
        let mut page = Vec::new();
        cut_page(&level, &shape, 0, 0, 0, &mut page);
        assert_eq!(page.len(), PAGE_BYTES);
        let g = PAGE_GUTTER;
        // The payload starts at the level's corner.
        assert_eq!(source(&page, g, g), (0, 0));
        // Left gutter: u repeats from the right edge; top gutter: v clamps to row 0.
        assert_eq!(source(&page, 0, 0), (196, 0));
        assert_eq!(source(&page, g - 1, g + 5), (199, 5));
        // Page (1, 1): its payload from texel 128, its right gutter past 200 wraps to 0..,
        // its bottom rows past 150 clamp to 149.
        page.clear();
        cut_page(&level, &shape, 0, 1, 1, &mut page);
        assert_eq!(source(&page, g, g), (128, 128));
        assert_eq!(source(&page, g + 72, g + 21), (0, 149));
        assert_eq!(source(&page, PAGE_SIDE - 1, PAGE_SIDE - 1), (59, 149));
        assert_eq!(source(&page, 0, 0), (124, 124));
    }

    #[test]
    fn a_1x1_level_fills_its_page() {
        let shape = TextureShape::new(1, 1, Wrap::Clamp, Wrap::Repeat).unwrap();
        let level = Level {
            width: 1,
            height: 1,
            texels: vec![9, 8, 7, 6],
        };
        let mut page = Vec::new();
        cut_page(&level, &shape, 0, 0, 0, &mut page);
        assert_eq!(page.len(), PAGE_BYTES);
        assert!(page.chunks(4).all(|t| t == [9, 8, 7, 6]));
    }
}
