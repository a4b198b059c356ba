//! A textured repository's textures for an export: each texture's full-resolution level put
//! back together from its pages' payloads and PNG-encoded, and the cut's texture coordinates
//! taken out of their bands (`tessera_core::texture`): what a viewer elsewhere samples.
//!
//! Reassembling holds a texture's largest level in memory (4 bytes a texel) while it is encoded,
//! one texture at a time: an export writes that image whole anyway.

use anyhow::Context;
use image::{ImageEncoder, RgbaImage};
use tessera_core::repository::reader::Repository;
use tessera_core::texture::{
    band_of, Band, TextureShape, Wrap, NO_TEXTURE, PAGE_GUTTER, PAGE_PAYLOAD, PAGE_SIDE,
};

/// One texture, ready to embed or to write beside the mesh.
pub struct ExportTexture {
    /// PNG bytes of the texture's largest level.
    pub png: Vec<u8>,
    pub wrap_u: Wrap,
    pub wrap_v: Wrap,
}

/// A repository's textures and the bands that name them.
pub struct ExportTextures {
    pub textures: Vec<ExportTexture>,
    pub bands: Vec<Band>,
}

impl ExportTextures {
    /// Index into `bands` of the band each texture coordinate lies in (`None` outside all: a
    /// coordinate the build never writes).
    pub fn vertex_bands(&self, uvs: &[[f32; 2]]) -> Vec<Option<usize>> {
        uvs.iter()
            .map(|uv| {
                band_of(&self.bands, uv[1]).and_then(|b| self.bands.iter().position(|c| c == b))
            })
            .collect()
    }

    /// The texture each band samples (`None` for a band of colour alone).
    pub fn band_texture(&self, band: usize) -> Option<usize> {
        let t = self.bands[band].texture;
        (t != NO_TEXTURE).then_some(t as usize)
    }
}

/// `v` as the texture samples it, row 0 at 0 (glTF's convention): the stored `v` less its
/// band's shift. Outside every band, as stored.
pub fn unbanded_v(bands: &[Band], v: f32) -> f32 {
    match band_of(bands, v) {
        Some(b) => (f64::from(v) - f64::from(b.shift)) as f32,
        None => v,
    }
}

/// The repository's textures, `None` if it has none.
pub fn export_textures(repo: &Repository) -> anyhow::Result<Option<ExportTextures>> {
    let Some(table) = repo.textures() else {
        return Ok(None);
    };
    let shapes = table.shapes();
    let mut textures = Vec::with_capacity(shapes.len());
    for (t, shape) in shapes.iter().enumerate() {
        let first = table.first_page(t as u32);
        let encoding = table.encoding();
        let image = largest_level(shape, |index| {
            let stored = table.page(first + index)?;
            Ok(tessera_core::texture_codec::decode_page(encoding, stored)?)
        })
        .with_context(|| format!("reading texture {t}'s pages"))?;
        let mut png = Vec::new();
        image::codecs::png::PngEncoder::new(&mut png)
            .write_image(
                image.as_raw(),
                image.width(),
                image.height(),
                image::ExtendedColorType::Rgba8,
            )
            .with_context(|| format!("encoding texture {t} as PNG"))?;
        textures.push(ExportTexture {
            png,
            wrap_u: shape.wrap_u,
            wrap_v: shape.wrap_v,
        });
    }
    Ok(Some(ExportTextures {
        textures,
        bands: table.bands(),
    }))
}

/// Level 0 of a texture from its pages' payloads; `page(i)` gives the texture's page `i`
/// (`PAGE_SIDE²` RGBA8 texels, row-major).
pub fn largest_level(
    shape: &TextureShape,
    mut page: impl FnMut(u32) -> anyhow::Result<Vec<u8>>,
) -> anyhow::Result<RgbaImage> {
    let mut image = RgbaImage::new(shape.width, shape.height);
    let (nx, ny) = shape.pages_across(0);
    for py in 0..ny {
        for px in 0..nx {
            let index = shape.page_index(0, px, py).expect("a page of level 0");
            let bytes = page(index)?;
            anyhow::ensure!(
                bytes.len() == (PAGE_SIDE * PAGE_SIDE * 4) as usize,
                "page {index} holds {} bytes",
                bytes.len()
            );
            let (x0, y0) = (px * PAGE_PAYLOAD, py * PAGE_PAYLOAD);
            for j in 0..PAGE_PAYLOAD.min(shape.height - y0) {
                for i in 0..PAGE_PAYLOAD.min(shape.width - x0) {
                    let at = (((j + PAGE_GUTTER) * PAGE_SIDE + i + PAGE_GUTTER) * 4) as usize;
                    let texel: [u8; 4] = bytes[at..at + 4].try_into().expect("4 bytes");
                    image.put_pixel(x0 + i, y0 + j, image::Rgba(texel));
                }
            }
        }
    }
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pages of a level-0 image cut the way `core::texture` describes.
    fn pages_of(shape: &TextureShape, image: &RgbaImage) -> Vec<Vec<u8>> {
        let (nx, ny) = shape.pages_across(0);
        let mut pages = Vec::new();
        for y in 0..ny {
            for x in 0..nx {
                let mut page = Vec::with_capacity((PAGE_SIDE * PAGE_SIDE * 4) as usize);
                for j in 0..PAGE_SIDE {
                    for i in 0..PAGE_SIDE {
                        let (sx, sy) = shape.page_texel_source(0, x, y, i, j);
                        page.extend_from_slice(&image.get_pixel(sx, sy).0);
                    }
                }
                pages.push(page);
            }
        }
        pages
    }

    #[test]
    fn the_largest_level_comes_back_from_its_pages() {
        let shape = TextureShape::new(300, 131, Wrap::Repeat, Wrap::Clamp).unwrap();
        let image = RgbaImage::from_fn(300, 131, |x, y| {
            image::Rgba([x as u8, y as u8, (x * 7 + y * 3) as u8, 255])
        });
        let pages = pages_of(&shape, &image);
        let back = largest_level(&shape, |i| Ok(pages[i as usize].clone())).unwrap();
        assert_eq!(back, image);
        let short = largest_level(&shape, |_| Ok(vec![0; 16]));
        assert!(short.is_err());
    }

    #[test]
    fn coordinates_leave_their_bands() {
        let bands = [
            Band::covering(0, -0.4, 1.4, 0).unwrap(),
            Band::covering(3, 0.0, 0.5, NO_TEXTURE).unwrap(),
        ];
        assert_eq!(unbanded_v(&bands, 0.6 + bands[0].shift as f32), 0.6);
        assert_eq!(unbanded_v(&bands, 3.25), 0.25);
        let textures = ExportTextures {
            textures: Vec::new(),
            bands: bands.to_vec(),
        };
        assert_eq!(
            textures.vertex_bands(&[[0.0, 1.5], [0.0, 3.5], [0.0, 9.0]]),
            vec![Some(0), Some(1), None]
        );
        assert_eq!(textures.band_texture(0), Some(0));
        assert_eq!(textures.band_texture(1), None);
    }
}
