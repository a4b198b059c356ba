//! A texture's mip levels (`tessera_core::texture`): each level from the one before by a 2 × 2
//! box filter in linear light. Colour channels are decoded from sRGB to linear f32, averaged
//! and encoded back (rounded to the nearest 8-bit value); alpha, stored linear, is averaged as
//! it is. An odd edge repeats its last texel, so level sizes are exactly
//! `TextureShape::level_size`. A level is made from the stored 8-bit level before it (what the
//! renderer samples), so the pyramid is held as 8-bit texels only: 4 bytes a texel.

use tessera_core::texture::TextureShape;
use tessera_core::texture_codec::halve;

/// One level's texels: RGBA8, colour sRGB, row-major, top row first.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Level {
    pub width: u32,
    pub height: u32,
    /// `4 · width · height` bytes.
    pub texels: Vec<u8>,
}

impl Level {
    /// The RGBA8 texel at `(x, y)` (`x < width`, `y < height`).
    pub fn texel(&self, x: u32, y: u32) -> [u8; 4] {
        let at = 4 * (y as usize * self.width as usize + x as usize);
        self.texels[at..at + 4].try_into().expect("4 bytes")
    }
}

/// The level after `level`: half its size rounded up (at least 1), each texel the linear-light
/// mean of the 2 × 2 texels it covers, the last row or column repeated where the size is odd.
pub fn next_level(level: &Level) -> Level {
    let (texels, width, height) = halve(&level.texels, level.width, level.height);
    Level {
        width,
        height,
        texels,
    }
}

/// Every level of `shape`'s pyramid from its level 0 (`TextureShape::levels` of them).
pub fn pyramid(level0: Level, shape: &TextureShape) -> Vec<Level> {
    assert_eq!((level0.width, level0.height), (shape.width, shape.height));
    let mut levels = vec![level0];
    for l in 1..shape.levels() {
        let next = next_level(levels.last().expect("level 0"));
        debug_assert_eq!((next.width, next.height), shape.level_size(l));
        levels.push(next);
    }
    levels
}

/// Bytes of every level of `shape`'s pyramid, 4 a texel.
pub fn pyramid_bytes(shape: &TextureShape) -> u64 {
    (0..shape.levels())
        .map(|l| {
            let (w, h) = shape.level_size(l);
            4 * u64::from(w) * u64::from(h)
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use tessera_core::texture::Wrap;

    fn level(width: u32, height: u32, texels: &[[u8; 4]]) -> Level {
        Level {
            width,
            height,
            texels: texels.concat(),
        }
    }

    #[test]
    fn black_and_white_average_to_188_in_linear_light() {
        let (b, w) = ([0, 0, 0, 0], [255, 255, 255, 255]);
        let next = next_level(&level(2, 2, &[b, w, w, b]));
        assert_eq!((next.width, next.height), (1, 1));
        // Linear 0.5 is sRGB 0.7354: 187.5, not the 128 an sRGB-space mean would give.
        // Alpha is linear: its mean is 127.5, rounded up.
        assert_eq!(next.texel(0, 0), [188, 188, 188, 128]);
    }

    #[test]
    fn a_uniform_level_stays_uniform_and_odd_edges_repeat() {
        let grey = [90, 140, 200, 77];
        let next = next_level(&level(3, 1, &[grey; 3]));
        assert_eq!((next.width, next.height), (2, 1));
        assert!(next.texels.chunks(4).all(|t| t == grey));
        // The last column (odd width) averages with itself: its own value.
        let (a, b, c) = ([10, 10, 10, 10], [20, 20, 20, 20], [250, 0, 60, 200]);
        let next = next_level(&level(3, 1, &[a, b, c]));
        assert_eq!(next.texel(1, 0), c);
    }

    #[test]
    fn a_1x1_texture_is_one_level() {
        let shape = TextureShape::new(1, 1, Wrap::Repeat, Wrap::Repeat).unwrap();
        let levels = pyramid(level(1, 1, &[[1, 2, 3, 4]]), &shape);
        assert_eq!(levels.len(), 1);
        assert_eq!(pyramid_bytes(&shape), 4);
        // Were it filtered, a 1 × 1 level stays itself.
        assert_eq!(next_level(&levels[0]).texel(0, 0), [1, 2, 3, 4]);
    }

    #[test]
    fn level_sizes_follow_the_shape() {
        let shape = TextureShape::new(300, 129, Wrap::Repeat, Wrap::Clamp).unwrap();
        let texels = (0..300 * 129 * 4).map(|i| (i % 251) as u8).collect();
        let level0 = Level {
            width: 300,
            height: 129,
            texels,
        };
        let levels = pyramid(level0, &shape);
        assert_eq!(levels.len(), 3);
        for (l, level) in levels.iter().enumerate() {
            assert_eq!((level.width, level.height), shape.level_size(l as u32));
            assert_eq!(
                level.texels.len(),
                4 * (level.width * level.height) as usize
            );
        }
        assert_eq!(pyramid_bytes(&shape), 4 * (300 * 129 + 150 * 65 + 75 * 33));
    }
}
