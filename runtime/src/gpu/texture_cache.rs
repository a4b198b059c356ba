//! The texture cache on the GPU: a pool of page layers, the page table, the textures' info
//! and the fragment shader's request bits (`shaders/texture.wgsl`, bind group 2), and the
//! loop that turns read-back requests into loads (`texture_residency.rs` decides).
//!
//! - Pool: one `D2Array` texture, 136 × 136 a layer with the page's own 3 mips, one layer a
//!   resident page: the layer count is the cache's capacity. `Bc1RgbaUnormSrgb` (12,208
//!   bytes a layer) where the pages are BC1 and the adapter samples it, the stored mips
//!   uploaded as they are; else `Rgba8UnormSrgb` (`LAYER_BYTES`, 97,104), BC1 pages decoded
//!   and RGBA8 pages given their mips (`texture_pages::page_mips`) as they load
//!   (`texture_pages::PoolFormat`). Texture arrays exist on every backend (GL too).
//! - Page table: a u32 a global page, layer + 1 (0: not resident), written as pages come and
//!   go; a frame already submitted keeps what it read (writes land between submits).
//! - Requests: a bit a global page, set by the fragments (`atomicOr`), copied after the frame's
//!   draws into one of a ring of read-back buffers and cleared (a frame that finds the ring
//!   busy keeps its bits for the next), mapped without waiting like the streaming feedback
//!   (`feedback.rs`); `update` reads what has arrived, a frame or two late.
//!
//! The pool's layer count is never a multiple of 6 (`not_cube_compatible`): wgpu's GL backend
//! would make it a cube map array, which samples black or stale as a 2D array.
//!
//! Budget rule (`layers_for`): with a GPU budget, the pool, table, info and request buffers
//! take at most a quarter of it, and the pool no more layers than `SCREEN_PAGES` times the
//! pages the viewport's pixels fill at one texel a pixel (a frame's working set grows with its
//! pixels, not with the textures: at most 399 pages were wanted by a 1280 × 720 frame of the
//! 4096² benchmark texture, 7.1 such pages); the rest is the geometry's. At most every page, at
//! least the pinned pages plus `MIN_FREE_LAYERS` (or every page, if fewer), else
//! `BudgetTooSmall` names the budget; without one, every page. Both capped by
//! `max_texture_array_layers`.

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

use tessera_core::texture::PAGE_SIDE;

use super::device::{GpuContext, GpuFailure};
use super::texture_pages::{PageSource, PoolFormat, TextureError, TextureLayout, PAGE_MIPS};
use super::texture_residency::PageResidency;
use tessera_core::texture_codec::{bc1_blocks_across, bc1_mip_range, decode_page_mips};

/// Layers beyond the pinned pages a budget must allow.
pub const MIN_FREE_LAYERS: u32 = 16;
/// Under a budget, the pool's layers are at most this many times the pages a viewport's
/// pixels fill at one texel a pixel (the module's budget rule).
pub const SCREEN_PAGES: u64 = 8;
/// Read-back buffers in the request ring.
const RING: usize = 3;
/// Storage buffers texture.wgsl adds to the fragment stage (info, table, requests); draw.wgsl
/// binds one (the slot records) there already.
const FRAGMENT_STORAGE_BUFFERS: u32 = 4;

/// What `update` did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextureUpdate {
    /// Request read-backs that arrived.
    pub readbacks: u32,
    /// Pages requested in them (distinct per read-back, summed).
    pub requested: u32,
    /// Distinct pages the newest read-back asked for (a frame's working set).
    pub wanted: u32,
    pub loads: u32,
    pub evictions: u32,
    /// Requested pages that found no layer (the pool too small for the view).
    pub refused: u32,
}

const IDLE: u8 = 0;
const COPIED: u8 = 1;
const MAPPING: u8 = 2;
const MAPPED: u8 = 3;
const FAILED: u8 = 4;

struct Staging {
    buffer: wgpu::Buffer,
    state: Arc<AtomicU8>,
}

/// The pool, tables, request bits and their residency.
pub struct TextureCache {
    source: Arc<dyn PageSource>,
    layout: TextureLayout,
    format: PoolFormat,
    residency: PageResidency,
    pool: wgpu::Texture,
    table: wgpu::Buffer,
    requests: wgpu::Buffer,
    ring: Vec<Staging>,
    pending: Option<usize>,
    pub(crate) group_layout: wgpu::BindGroupLayout,
    pub(crate) group: wgpu::BindGroup,
    /// Read-backs planned so far (the residency's stamps).
    stamp: u64,
    /// The most pages resident at once.
    pub max_resident: usize,
}

/// Words of the request bits for `pages` pages.
fn request_words(pages: u32) -> u64 {
    (pages as u64).div_ceil(32).max(1)
}

/// Bytes of the info, table and request buffers (the ring included): the cache's part that
/// does not depend on its layers.
pub fn table_bytes(layout: &TextureLayout) -> u64 {
    let info = layout.info_words().len() as u64 * 4;
    info + layout.total_pages().max(1) as u64 * 4
        + request_words(layout.total_pages()) * 4 * (1 + RING as u64)
}

/// Every byte the cache allocates with `layers` layers of `format`.
pub fn cache_bytes(layout: &TextureLayout, layers: u32, format: PoolFormat) -> u64 {
    table_bytes(layout) + layers as u64 * format.layer_bytes()
}

/// The pool's layers of `format` under `budget` for a `viewport` of pixels (the module's
/// budget rule), or why none fits.
pub fn layers_for(
    ctx: &GpuContext,
    layout: &TextureLayout,
    budget: Option<u64>,
    format: PoolFormat,
    viewport: (u32, u32),
) -> Result<u32, TextureError> {
    let all = layout.total_pages().max(2);
    let floor = all
        .min(layout.pinned().len() as u32 + MIN_FREE_LAYERS)
        .max(2);
    let limit = ctx.limits.max_texture_array_layers;
    if floor > limit {
        return Err(TextureError::OverLayerLimit {
            needed: floor,
            limit,
        });
    }
    let layers = match budget {
        None => all,
        Some(budget) => {
            let share = (budget / 4).saturating_sub(table_bytes(layout)) / format.layer_bytes();
            if share < floor as u64 {
                return Err(TextureError::BudgetTooSmall {
                    budget,
                    needed: 4 * cache_bytes(layout, floor, format),
                });
            }
            let payload = u64::from(tessera_core::texture::PAGE_PAYLOAD).pow(2);
            let pixels = u64::from(viewport.0) * u64::from(viewport.1);
            let screen = (SCREEN_PAGES * pixels).div_ceil(payload).max(floor as u64);
            all.min(share.min(screen).min(u32::MAX as u64) as u32)
        }
    };
    Ok(not_cube_compatible(layers.min(limit), floor))
}

/// `layers`, or one fewer (one more if fewer than `at_least`) if it is a multiple of 6: wgpu's
/// GL backend makes a square 2D texture whose layer count is a multiple of 6 a cube map
/// (array; wgpu-hal `gles::Texture::get_info_from_desc`), which a `texture_2d_array` then
/// samples wrongly: a 240- or 450-layer pool drew black on llvmpipe GL (239 and 449 did not),
/// and a 12-layer one kept drawing a layer's old page after it was reused (13 did not). Done
/// on every backend alike.
pub fn not_cube_compatible(layers: u32, at_least: u32) -> u32 {
    match layers.is_multiple_of(6) {
        true if layers > at_least => layers - 1,
        true => layers + 1,
        false => layers,
    }
}

/// The textures' bind group (texture.wgsl's group 2) over a new view of the pool.
fn bind(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    pool: &wgpu::Texture,
    sampler: &wgpu::Sampler,
    [info, table, requests]: [&wgpu::Buffer; 3],
) -> wgpu::BindGroup {
    let view = pool.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("textures"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Sampler(sampler),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: info.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: table.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: requests.as_entire_binding(),
            },
        ],
    })
}

/// Ok, or what the adapter lacks to draw textures.
fn check_device(ctx: &GpuContext, layout: &TextureLayout) -> Result<(), TextureError> {
    let flags = ctx.adapter.get_downlevel_capabilities().flags;
    if !flags.contains(wgpu::DownlevelFlags::FRAGMENT_WRITABLE_STORAGE) {
        return Err(TextureError::Missing(
            "writable storage buffers in fragment shaders".into(),
        ));
    }
    let have = ctx.limits.max_storage_buffers_per_shader_stage;
    if have < FRAGMENT_STORAGE_BUFFERS {
        return Err(TextureError::Missing(format!(
            "limit max_storage_buffers_per_shader_stage ≥ {FRAGMENT_STORAGE_BUFFERS} (it has {have})"
        )));
    }
    let bytes = table_bytes(layout);
    let limit = ctx.limits.max_storage_buffer_binding_size;
    if bytes > limit {
        return Err(TextureError::OverBindingLimit { bytes, limit });
    }
    Ok(())
}

impl TextureCache {
    /// The cache of `source`'s textures with `layers` layers (`layers_for`) of the format
    /// `PoolFormat::for_pages` gives, its pinned pages loaded. Refuses an adapter that cannot
    /// draw textures, naming what it lacks.
    pub fn new(
        ctx: &GpuContext,
        source: Arc<dyn PageSource>,
        layers: u32,
    ) -> Result<TextureCache, TextureError> {
        let layout = TextureLayout::new(source.shapes(), source.bands())?;
        check_device(ctx, &layout)?;
        let format = PoolFormat::for_pages(ctx, source.encoding());
        let pinned = layout.pinned();
        let at_least = (pinned.len() as u32).max(2);
        let layers = not_cube_compatible(layers.max(at_least), at_least);
        if layers > ctx.limits.max_texture_array_layers {
            return Err(TextureError::OverLayerLimit {
                needed: layers,
                limit: ctx.limits.max_texture_array_layers,
            });
        }
        use wgpu::util::DeviceExt;
        use wgpu::BufferUsages as U;
        let device = &ctx.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let pool = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("texture page pool"),
            size: wgpu::Extent3d {
                width: PAGE_SIDE,
                height: PAGE_SIDE,
                depth_or_array_layers: layers,
            },
            mip_level_count: PAGE_MIPS,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: format.texture_format(),
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let info = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("texture info"),
            contents: bytemuck::cast_slice(&layout.info_words()),
            usage: U::STORAGE,
        });
        let table = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("texture page table"),
            size: layout.total_pages().max(1) as u64 * 4,
            usage: U::STORAGE | U::COPY_DST,
            mapped_at_creation: false,
        });
        let words = request_words(layout.total_pages());
        let requests = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("texture page requests"),
            size: words * 4,
            usage: U::STORAGE | U::COPY_SRC | U::COPY_DST,
            mapped_at_creation: false,
        });
        let ring = (0..RING)
            .map(|_| Staging {
                buffer: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("texture page requests read-back"),
                    size: words * 4,
                    usage: U::MAP_READ | U::COPY_DST,
                    mapped_at_creation: false,
                }),
                state: Arc::new(AtomicU8::new(IDLE)),
            })
            .collect();
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("texture pages"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: fragment,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("textures"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: fragment,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: fragment,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
                storage(2, true),
                storage(3, true),
                storage(4, false),
            ],
        });
        let group = bind(
            device,
            &group_layout,
            &pool,
            &sampler,
            [&info, &table, &requests],
        );
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuFailure(format!(
                "allocating {} bytes of texture pages: {e}",
                cache_bytes(&layout, layers, format)
            ))
            .into());
        }
        let cache = TextureCache {
            residency: PageResidency::new(layers, &pinned),
            source,
            layout,
            format,
            pool,
            table,
            requests,
            ring,
            pending: None,
            group_layout,
            group,
            stamp: 0,
            max_resident: pinned.len(),
        };
        for (layer, &page) in pinned.iter().enumerate() {
            cache.upload(ctx, page, layer as u32)?;
        }
        ctx.check()?;
        Ok(cache)
    }

    /// The layers (capacity) and the pages resident now.
    pub fn capacity(&self) -> u32 {
        self.residency.capacity()
    }

    pub fn resident(&self) -> usize {
        self.residency.resident_count()
    }

    pub fn layout(&self) -> &TextureLayout {
        &self.layout
    }

    /// The pool's format.
    pub fn format(&self) -> PoolFormat {
        self.format
    }

    /// Every byte the cache allocates.
    pub fn bytes(&self) -> u64 {
        cache_bytes(&self.layout, self.capacity(), self.format)
    }

    /// Page `page` into layer `layer` (its three mips) and the table entry.
    fn upload(&self, ctx: &GpuContext, page: u32, layer: u32) -> Result<(), TextureError> {
        let stored = self
            .source
            .page(page)
            .map_err(|message| TextureError::Page { page, message })?;
        let encoding = self.source.encoding();
        let wrong_size = |message: String| TextureError::Page { page, message };
        // Each mip: its bytes, bytes a row (of texels, or of 4 × 4 blocks), rows, and the
        // extent copied (a BC1 mip's physical size: whole blocks).
        let mips: Vec<(Vec<u8>, u32, u32, u32)> = match self.format {
            PoolFormat::Bc1 => {
                if stored.len() != encoding.page_bytes() {
                    return Err(wrong_size(format!(
                        "{} bytes, not {}",
                        stored.len(),
                        encoding.page_bytes()
                    )));
                }
                (0..PAGE_MIPS)
                    .map(|mip| {
                        let blocks = bc1_blocks_across(mip);
                        let bytes = stored[bc1_mip_range(mip)].to_vec();
                        (bytes, blocks * 8, blocks, blocks * 4)
                    })
                    .collect()
            }
            PoolFormat::Rgba8 => decode_page_mips(encoding, &stored)
                .map_err(|e| wrong_size(e.to_string()))?
                .into_iter()
                .enumerate()
                .map(|(mip, bytes)| {
                    let side = PAGE_SIDE >> mip;
                    (bytes, side * 4, side, side)
                })
                .collect(),
        };
        // By `write_texture`, rows unpadded: wgpu stages them at the backend's own pitch,
        // which on GL is what `glCompressedTexSubImage3D` needs (a BC1 copy with rows padded
        // to 256 bytes is refused there, and an incomplete pool samples black).
        for (mip, (bytes, row, rows, side)) in mips.iter().enumerate() {
            ctx.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &self.pool,
                    mip_level: mip as u32,
                    origin: wgpu::Origin3d {
                        x: 0,
                        y: 0,
                        z: layer,
                    },
                    aspect: wgpu::TextureAspect::All,
                },
                bytes,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(*row),
                    rows_per_image: Some(*rows),
                },
                wgpu::Extent3d {
                    width: *side,
                    height: *side,
                    depth_or_array_layers: 1,
                },
            );
        }
        ctx.queue.write_buffer(
            &self.table,
            page as u64 * 4,
            bytemuck::bytes_of(&(layer + 1)),
        );
        Ok(())
    }

    /// After the frame's draws: its request bits into an idle read-back buffer, then cleared
    /// (kept for the next frame when the ring is busy).
    pub fn copy_out(&mut self, encoder: &mut wgpu::CommandEncoder) {
        self.pending = None;
        let Some(k) = self
            .ring
            .iter()
            .position(|s| s.state.load(Ordering::Acquire) == IDLE)
        else {
            return;
        };
        encoder.copy_buffer_to_buffer(&self.requests, 0, &self.ring[k].buffer, 0, None);
        encoder.clear_buffer(&self.requests, 0, None);
        self.ring[k].state.store(COPIED, Ordering::Release);
        self.pending = Some(k);
    }

    /// After the submit: start mapping what `copy_out` copied.
    pub fn after_submit(&mut self) {
        let Some(k) = self.pending.take() else {
            return;
        };
        let state = self.ring[k].state.clone();
        state.store(MAPPING, Ordering::Release);
        self.ring[k]
            .buffer
            .slice(..)
            .map_async(wgpu::MapMode::Read, move |result| {
                state.store(
                    if result.is_ok() { MAPPED } else { FAILED },
                    Ordering::Release,
                );
            });
    }

    /// Reads the request read-backs that have arrived (polls, never waits) and loads what
    /// they ask for, evicting as `PageResidency::plan` says.
    pub fn update(&mut self, ctx: &GpuContext) -> Result<TextureUpdate, TextureError> {
        ctx.device
            .poll(wgpu::PollType::Poll)
            .map_err(|e| GpuFailure(format!("polling the device: {e}")))?;
        ctx.check()?;
        let mut update = TextureUpdate::default();
        for k in 0..self.ring.len() {
            match self.ring[k].state.load(Ordering::Acquire) {
                FAILED => {
                    ctx.wait_idle()?;
                    return Err(GpuFailure(
                        "reading back the texture page requests failed: its buffer could not be mapped".into(),
                    )
                    .into());
                }
                MAPPED => {}
                _ => continue,
            }
            let words: Vec<u32> = {
                let view = self.ring[k]
                    .buffer
                    .slice(..)
                    .get_mapped_range()
                    .map_err(|e| {
                        GpuFailure(format!("reading back the texture page requests: {e}"))
                    })?;
                bytemuck::pod_collect_to_vec(&view)
            };
            self.ring[k].buffer.unmap();
            self.ring[k].state.store(IDLE, Ordering::Release);
            let total = self.layout.total_pages();
            let requested: Vec<u32> = words
                .iter()
                .enumerate()
                .flat_map(|(w, &bits)| {
                    (0..32)
                        .filter(move |b| bits >> b & 1 == 1)
                        .map(move |b| w as u32 * 32 + b)
                })
                .filter(|&p| p < total)
                .collect();
            self.stamp += 1;
            let layout = &self.layout;
            let plan = self
                .residency
                .plan(&requested, self.stamp, |p| layout.level_of(p));
            for &page in &plan.evicted {
                ctx.queue
                    .write_buffer(&self.table, page as u64 * 4, bytemuck::bytes_of(&0u32));
            }
            for &(page, layer) in &plan.loads {
                if let Err(e) = self.upload(ctx, page, layer) {
                    self.residency.unload(page);
                    return Err(e);
                }
            }
            self.max_resident = self.max_resident.max(self.residency.resident_count());
            update.readbacks += 1;
            update.requested += requested.len() as u32;
            update.wanted = requested.len() as u32;
            update.loads += plan.loads.len() as u32;
            update.evictions += plan.evicted.len() as u32;
            update.refused += plan.refused;
        }
        Ok(update)
    }
}

#[cfg(test)]
mod tests {
    use super::not_cube_compatible;

    #[test]
    fn no_pool_has_a_multiple_of_6_layers() {
        assert_eq!(not_cube_compatible(450, 17), 449);
        assert_eq!(not_cube_compatible(449, 17), 449);
        // One fewer would drop below the pinned pages: one more.
        assert_eq!(not_cube_compatible(6, 6), 7);
        assert_eq!(not_cube_compatible(12, 2), 11);
        for layers in 2..2000 {
            assert!(!not_cube_compatible(layers, 2).is_multiple_of(6));
        }
    }
}
