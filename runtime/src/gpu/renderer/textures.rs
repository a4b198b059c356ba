//! The renderer's textures (`texture_cache.rs`): given a `PageSource`, the lit and color fills
//! sample its pages (`shaders/texture.wgsl`); each frame's requests come back a frame or two
//! late and `update_textures` loads them; `render_settled` repeats a still frame until it asks
//! for nothing new.

use std::sync::Arc;

use tessera_core::repository::format::ATTR_UVS;

use super::super::device::GpuContext;
use super::super::draw_pipelines::DrawPipelines;
use super::super::shaders::draw_textured_source;
use super::super::texture_cache::{TextureCache, TextureUpdate};
use super::super::texture_pages::{PageSource, TextureError};
use super::{Frame, FrameRequest, Renderer};

/// How a still frame settled (`Renderer::render_settled`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Settled {
    /// Frames drawn, the last one returned.
    pub steps: u32,
    /// Whether the last frame asked for no page that was not resident (else the step bound
    /// stopped it, or the pool is too small for the view: `refused`).
    pub settled: bool,
    /// Pages loaded over all steps; requests refused by the last step.
    pub loads: u32,
    pub refused: u32,
    /// Distinct pages the last step's read-back asked for: the view's working set (pinned
    /// pages only where they were sampled as wanted).
    pub wanted: u32,
}

impl Renderer {
    /// Draws the model's texture coordinates through `source`'s textures from now on, in a
    /// page pool of `layers` layers (`texture_cache::layers_for` gives the budget's), the
    /// pinned pages loaded. Refuses a model without texture coordinates and an adapter that
    /// cannot draw textures (naming what it lacks); the renderer is unchanged then.
    pub fn set_textures(
        &mut self,
        ctx: &GpuContext,
        source: Arc<dyn PageSource>,
        layers: u32,
    ) -> Result<(), TextureError> {
        if self.header.attributes & ATTR_UVS == 0 {
            return Err(TextureError::NoUvs);
        }
        let cache = TextureCache::new(ctx, source, layers)?;
        let device = &ctx.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("draw.wgsl + texture.wgsl"),
            source: wgpu::ShaderSource::Wgsl(
                draw_textured_source(ctx.capabilities.early_depth_test).into(),
            ),
        });
        let layouts = [&self.draw_layout, &self.page_layout, &cache.group_layout];
        let (attributes, wireframe) = (self.header.attributes, ctx.capabilities.wireframe);
        let pipelines =
            |vertex| DrawPipelines::new(device, &layouts, &module, vertex, attributes, wireframe);
        (self.indexed, self.pulled) = (pipelines("vs_indexed"), pipelines("vs_main"));
        self.textures = Some(cache);
        ctx.check()?;
        Ok(())
    }

    /// The texture cache, if `set_textures` gave one.
    pub fn textures(&self) -> Option<&TextureCache> {
        self.textures.as_ref()
    }

    /// Loads the pages the frames' read-backs that arrived ask for (never waits); nothing
    /// without textures.
    pub fn update_textures(&mut self, ctx: &GpuContext) -> Result<TextureUpdate, TextureError> {
        match &mut self.textures {
            Some(textures) => textures.update(ctx),
            None => Ok(TextureUpdate::default()),
        }
    }

    /// A still frame with its textures settled: draws `request`, waits, loads what it asked
    /// for, and again until a frame asks for no page that was not resident (or `max_steps`
    /// frames); returns the last frame. Without textures, one frame.
    pub fn render_settled(
        &mut self,
        ctx: &GpuContext,
        request: &FrameRequest,
        max_steps: u32,
    ) -> Result<(Frame, Settled), TextureError> {
        assert!(max_steps >= 1, "at least one frame");
        let mut settled = Settled::default();
        loop {
            let frame = self.render_and_read(ctx, request)?;
            settled.steps += 1;
            if self.textures.is_none() {
                settled.settled = true;
                return Ok((frame, settled));
            }
            ctx.wait_idle()?;
            let update = self.update_textures(ctx)?;
            settled.loads += update.loads;
            settled.refused = update.refused;
            settled.wanted = update.wanted;
            // The frame's own read-back has arrived (the wait): nothing loaded means every
            // page it wanted was resident when it was drawn.
            let done = update.readbacks > 0 && update.loads == 0;
            settled.settled = done && update.refused == 0;
            if done || settled.steps >= max_steps {
                return Ok((frame, settled));
            }
        }
    }
}
