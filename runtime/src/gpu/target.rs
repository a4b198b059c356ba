//! The headless render target: an RGBA8 colour texture and a reverse-Z depth texture, and the
//! read-back of the colour into an image.

use super::device::{GpuContext, GpuFailure};

/// Colour format of the target (no sRGB conversion: the check compares exact byte values).
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Depth format: f32, cleared to 0 (infinitely far) and tested with `Greater` (reverse Z).
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Background of the shaded modes (the check mode clears to black).
pub const BACKGROUND: wgpu::Color = wgpu::Color {
    r: 0.11,
    g: 0.12,
    b: 0.15,
    a: 1.0,
};

/// `BACKGROUND` as the colour target stores it (RGBA8, unorm: round(255 · c)).
pub const BACKGROUND_RGBA8: [u8; 4] = [28, 31, 38, 255];

/// Why a target size cannot be drawn on this adapter: each case names the limit.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TargetSizeError {
    #[error(
        "the target size {width}×{height} is not within 1..={max} pixels per side (the \
         adapter's max_texture_dimension_2d)"
    )]
    Dimension { width: u32, height: u32, max: u32 },
    #[error(
        "the target size {width}×{height} needs a {bytes}-byte read-back buffer, more than \
         the adapter's max_buffer_size ({limit} bytes)"
    )]
    Readback {
        width: u32,
        height: u32,
        bytes: u64,
        limit: u64,
    },
}

/// Ok when a `width` × `height` target (textures and read-back buffer) fits `limits`.
pub fn check_target_size(
    limits: &wgpu::Limits,
    width: u32,
    height: u32,
) -> Result<(), TargetSizeError> {
    let max = limits.max_texture_dimension_2d;
    if !(1..=max).contains(&width) || !(1..=max).contains(&height) {
        return Err(TargetSizeError::Dimension { width, height, max });
    }
    let bytes = readback_bytes(width, height);
    if bytes > limits.max_buffer_size {
        return Err(TargetSizeError::Readback {
            width,
            height,
            bytes,
            limit: limits.max_buffer_size,
        });
    }
    Ok(())
}

/// An offscreen colour + depth target with its read-back buffer.
pub struct RenderTarget {
    pub width: u32,
    pub height: u32,
    pub color: wgpu::Texture,
    pub color_view: wgpu::TextureView,
    pub depth_view: wgpu::TextureView,
    readback: wgpu::Buffer,
    padded_row: u32,
}

impl RenderTarget {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> RenderTarget {
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let texture = |label: &str, format, usage| {
            ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let color = texture(
            "colour target",
            COLOR_FORMAT,
            // Sampled by `tessera view`, which draws the image into its window.
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let depth = texture(
            "depth target",
            DEPTH_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let padded_row = (4 * width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let readback = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("colour read-back"),
            size: readback_bytes(width, height),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        RenderTarget {
            width,
            height,
            color_view: color.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            color,
            readback,
            padded_row,
        }
    }

    /// Begins a render pass into the target: colour cleared to `clear`, depth to 0 (infinitely
    /// far in reverse Z) and not stored.
    pub fn begin_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &str,
        clear: wgpu::Color,
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) -> wgpu::RenderPass<'e> {
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &self.color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(clear),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes,
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }

    /// Records the copy of the colour texture into the read-back buffer.
    pub fn copy_out(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.color,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
        );
    }

    /// The colour written by the last `copy_out`, as tightly packed RGBA8 rows (blocks until
    /// the GPU is done); the device's failure if it failed or the read-back could not be
    /// mapped.
    pub fn read(&self, ctx: &GpuContext) -> Result<image::RgbaImage, GpuFailure> {
        let bytes = read_buffer(ctx, &self.readback, "the image")?;
        let row = 4 * self.width as usize;
        let mut pixels = Vec::with_capacity(row * self.height as usize);
        for r in bytes.chunks_exact(self.padded_row as usize) {
            pixels.extend_from_slice(&r[..row]);
        }
        image::RgbaImage::from_raw(self.width, self.height, pixels)
            .ok_or_else(|| GpuFailure("the image read back has the wrong size".into()))
    }
}

/// Bytes of the target's read-back buffer for `width` × `height` (rows padded to
/// `COPY_BYTES_PER_ROW_ALIGNMENT`).
pub fn readback_bytes(width: u32, height: u32) -> u64 {
    (4 * width as u64).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as u64) * height as u64
}

/// Maps a MAP_READ buffer, copies it out and unmaps it (blocks until the GPU is done). A
/// device that failed, or a map that failed, is a `GpuFailure` naming `what` was read.
pub fn read_buffer(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    what: &str,
) -> Result<Vec<u8>, GpuFailure> {
    ctx.check()?;
    if ctx.fail_this_readback() {
        buffer.destroy(); // FAULT_ENV's `readback`: the map below fails as a real one would
    }
    let slice = buffer.slice(..);
    let (sender, receiver) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        let _ = sender.send(result);
    });
    let waited = ctx.wait_idle();
    // A failed map names what was read, and the device's failure when it has one.
    let failed = |why: String, device: Option<&GpuFailure>| {
        GpuFailure(match device {
            Some(device) => format!("reading back {what} failed: {why} ({})", device.0),
            None => format!("reading back {what} failed: {why}"),
        })
    };
    match receiver.try_recv() {
        Ok(Ok(())) => {}
        Ok(Err(e)) => return Err(failed(e.to_string(), waited.as_ref().err())),
        Err(_) => {
            let why = "the map did not complete".to_string();
            return Err(failed(why, waited.as_ref().err()));
        }
    }
    waited?;
    let bytes = slice
        .get_mapped_range()
        .map_err(|e| failed(e.to_string(), None))?
        .to_vec();
    buffer.unmap();
    Ok(bytes)
}

#[cfg(test)]
mod background_tests {
    use super::*;

    #[test]
    fn the_stored_background_is_the_clear_colour_rounded() {
        let c = [BACKGROUND.r, BACKGROUND.g, BACKGROUND.b, BACKGROUND.a];
        assert_eq!(BACKGROUND_RGBA8, c.map(|x| (x * 255.0).round() as u8));
    }
}
