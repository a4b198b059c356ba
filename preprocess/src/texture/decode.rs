//! A texture's encoded image (PNG or JPEG, by its first bytes) read and decoded to RGBA8 with
//! the `image` crate. Every failure is a sentence for `BuildError::Texture`.

use std::borrow::Cow;
use std::io::Cursor;

use image::{ImageFormat, ImageReader, Limits};
use tessera_core::texture::MAX_TEXTURE_SIDE;

use super::pyramid::Level;
use crate::texture_input::{TextureInput, TextureSource};

/// The encoded bytes of a texture: its file's, or those the mesh held.
pub fn encoded_bytes(input: &TextureInput) -> Result<Cow<'_, [u8]>, String> {
    match &input.source {
        TextureSource::File(path) => std::fs::read(path)
            .map(Cow::Owned)
            .map_err(|e| format!("cannot read {}: {e}", path.display())),
        TextureSource::Encoded { bytes, .. } => Ok(Cow::Borrowed(bytes)),
    }
}

/// A reader of `bytes` whose format is found from their first bytes (a declared MIME type is
/// not trusted over them); PNG and JPEG only.
fn reader(bytes: &[u8]) -> Result<ImageReader<Cursor<&[u8]>>, String> {
    let format = image::guess_format(bytes).map_err(|_| {
        "unknown image format: not a PNG or a JPEG (by its first bytes)".to_string()
    })?;
    if !matches!(format, ImageFormat::Png | ImageFormat::Jpeg) {
        return Err(format!(
            "the {format:?} image format is not read: PNG or JPEG only"
        ));
    }
    Ok(ImageReader::with_format(Cursor::new(bytes), format))
}

/// Width and height from the image's header, without decoding it; sides must be in
/// `1..=MAX_TEXTURE_SIDE`.
pub fn dimensions(bytes: &[u8]) -> Result<(u32, u32), String> {
    let (w, h) = reader(bytes)?
        .into_dimensions()
        .map_err(|e| format!("corrupt image: {e}"))?;
    if !(1..=MAX_TEXTURE_SIDE).contains(&w) || !(1..=MAX_TEXTURE_SIDE).contains(&h) {
        return Err(format!(
            "{w} × {h} texels: each side must be 1..={MAX_TEXTURE_SIDE}"
        ));
    }
    Ok((w, h))
}

/// The image decoded to RGBA8 (grey, grey-alpha and RGB gain alpha 255; 16-bit channels are
/// rounded to 8), its decoder allowed at most `max_alloc` bytes.
pub fn decode(bytes: &[u8], max_alloc: u64) -> Result<Level, String> {
    let (w, h) = dimensions(bytes)?;
    let mut reader = reader(bytes)?;
    let mut limits = Limits::default();
    limits.max_alloc = Some(max_alloc);
    reader.limits(limits);
    let image = reader.decode().map_err(|e| format!("corrupt image: {e}"))?;
    if (image.width(), image.height()) != (w, h) {
        return Err(format!(
            "corrupt image: its header says {w} × {h}, it decodes to {} × {}",
            image.width(),
            image.height()
        ));
    }
    Ok(Level {
        width: w,
        height: h,
        texels: image.into_rgba8().into_raw(),
    })
}
