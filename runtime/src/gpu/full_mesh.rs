//! The full-resolution peer: a plain triangle mesh uploaded once and drawn in ONE indexed draw
//! call — the baseline every multiresolution renderer must beat ("just draw everything").
//!
//! Same camera, same target (`RenderTarget`: RGBA8 colour, reverse-Z f32 depth), same flat
//! shading as `ShadingMode::Lit` on a model without stored normals (`shaders/full_mesh.wgsl`),
//! same `Frame` uniforms (`FrameUniforms::new`, so the view, eye and light are bit-identical),
//! and the same GPU timestamps as `Renderer::read_gpu_ms` (here: start to end of the one render
//! pass; there is no traversal). The face rule is the caller's (`Faces`: back faces culled in
//! the rasteriser, as the renderer's default lit frame, or both drawn, as a two-sided one);
//! no frustum test on the CPU or in a compute pass.
//!
//! Positions are f32 relative to the repository origin, so the peer sees the model in the
//! same eye-relative frame as the renderer (`relative_positions`). The runtime never imports
//! the preprocessor: the mesh arrives as slices.
//!
//! Cost: one upload of 12 bytes per vertex and 12 bytes per triangle; per frame O(1) CPU work
//! (one uniform write, one draw) and GPU work linear in the whole mesh, whatever the view.
//!
//! `set_triangles` swaps the triangle list over the same vertices: the benchmarks' peers that
//! choose their triangles per frame (a cluster-DAG cut) draw through it, uploading the list.
//! Then the renderer draws whatever list it was last given.

use std::time::Instant;

use tessera_core::cull::CullTests;
use tessera_core::repository::format::Header;
use wgpu::util::DeviceExt;

use super::device::{GpuContext, GpuFailure};
use super::frame::{FrameUniforms, ShadingMode};
use super::target::{RenderTarget, BACKGROUND, COLOR_FORMAT, DEPTH_FORMAT};
use super::timing::FrameTimer;
use crate::camera::Camera;
use crate::faces::Faces;
use crate::mesh_problem::{check_finite, check_indices, MeshProblem};

/// The full-mesh pass (`vs_full_mesh`, `fs_full_mesh`), prefixed by the shared records.
pub fn full_mesh_source() -> String {
    format!(
        "{}\n{}",
        include_str!("../../../shaders/records.wgsl"),
        include_str!("../../../shaders/full_mesh.wgsl")
    )
}

/// Bytes of one vertex in the vertex buffer (3 × f32).
pub const FULL_MESH_VERTEX_BYTES: u64 = 12;
/// Bytes of one triangle in the index buffer (3 × u32).
pub const FULL_MESH_TRIANGLE_BYTES: u64 = 12;

/// Why a mesh cannot be drawn.
#[derive(Debug, thiserror::Error)]
pub enum FullMeshError {
    #[error(transparent)]
    BadSize(#[from] super::target::TargetSizeError),
    #[error("the mesh has no triangles")]
    Empty,
    #[error(transparent)]
    Bad(#[from] MeshProblem),
    #[error(
        "the mesh's {what} buffer needs {bytes} bytes; the adapter's largest buffer is \
         {limit} bytes (the largest buffer, within u32 indices; the one-draw peer cannot \
         split it)"
    )]
    TooLarge {
        what: &'static str,
        bytes: u64,
        limit: u64,
    },
}

/// A whole triangle mesh resident on the GPU, drawn in one call.
pub struct FullMeshRenderer {
    origin: [f64; 3],
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    vertex_count: u32,
    uniforms: wgpu::Buffer,
    group: wgpu::BindGroup,
    pipeline: wgpu::RenderPipeline,
    target: RenderTarget,
    timer: Option<FrameTimer>,
}

/// Model-space f64 positions → f32 relative to `origin` (the repository's `Header::origin`;
/// f64 subtraction, then rounding, as the renderer's tables are made).
pub fn relative_positions(positions: &[[f64; 3]], origin: [f64; 3]) -> Vec<[f32; 3]> {
    positions
        .iter()
        .map(|p| [0, 1, 2].map(|i| (p[i] - origin[i]) as f32))
        .collect()
}

impl FullMeshRenderer {
    /// Validates and uploads the mesh and makes the pipeline and a `width` × `height` target.
    ///
    /// - `positions`: f32, finite, relative to `origin` (see `relative_positions`); at most
    ///   `max_buffer_size / 12` and at most 1,431,655,765 vertices (one vertex buffer);
    /// - `triangles`: counter-clockwise vertex indices, each `< positions.len()`; at least one,
    ///   at most `max_buffer_size / 12` and at most 1,431,655,765 (3 × count fits in u32);
    /// - `origin`: the model-space point the positions are relative to (the repository's), so
    ///   the eye is placed in the same frame;
    /// - `faces`: which faces are drawn (the frame it is compared with must draw the same).
    pub fn new(
        ctx: &GpuContext,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
        origin: [f64; 3],
        (width, height): (u32, u32),
        faces: Faces,
    ) -> Result<FullMeshRenderer, FullMeshError> {
        super::target::check_target_size(&ctx.limits, width, height)?;
        if triangles.is_empty() {
            return Err(FullMeshError::Empty);
        }
        // One buffer each, and u32 indices: vertex ids and the index count must fit in u32.
        let limit = ctx.limits.max_buffer_size;
        let u32_bytes = (u32::MAX as u64 / 3) * 12;
        for (what, bytes) in [
            ("vertex", positions.len() as u64 * FULL_MESH_VERTEX_BYTES),
            ("index", triangles.len() as u64 * FULL_MESH_TRIANGLE_BYTES),
        ] {
            if bytes > limit.min(u32_bytes) {
                return Err(FullMeshError::TooLarge {
                    what,
                    bytes,
                    limit: limit.min(u32_bytes),
                });
            }
        }
        check_finite(positions)?;
        check_indices(triangles, positions.len())?;

        let device = &ctx.device;
        use wgpu::BufferUsages as U;
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("full mesh positions"),
            contents: bytemuck::cast_slice(positions),
            usage: U::VERTEX,
        });
        // COPY_DST: `set_triangles` rewrites it.
        let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("full mesh triangles"),
            contents: bytemuck::cast_slice(triangles),
            usage: U::INDEX | U::COPY_DST,
        });
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let uniforms = buffer(
            "full mesh frame uniforms",
            std::mem::size_of::<FrameUniforms>() as u64,
            U::UNIFORM | U::COPY_DST,
        );
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("full mesh"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("full mesh"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniforms.as_entire_binding(),
            }],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("full_mesh.wgsl"),
            source: wgpu::ShaderSource::Wgsl(full_mesh_source().into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("full mesh"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("full mesh"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_full_mesh"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: FULL_MESH_VERTEX_BYTES,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3],
                })],
            },
            // As the renderer's lit fill passes: the faces asked for, reverse-Z depth test.
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                strip_index_format: None,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: faces.cull_mode(),
                unclipped_depth: false,
                polygon_mode: wgpu::PolygonMode::Fill,
                conservative: false,
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_full_mesh"),
                compilation_options: Default::default(),
                targets: &[Some(COLOR_FORMAT.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        Ok(FullMeshRenderer {
            origin,
            vertices,
            indices,
            index_count: triangles.len() as u32 * 3,
            vertex_count: positions.len() as u32,
            uniforms,
            group,
            pipeline,
            target: RenderTarget::new(ctx, width, height),
            timer: FrameTimer::new(ctx, "full mesh timestamps"),
        })
    }

    /// Replaces the triangles that later frames draw, over the same vertices: a peer that
    /// selects its triangles per frame (a cluster DAG cut) draws them with this renderer.
    ///
    /// - `triangles`: vertex indices, each `< vertex_count()` (checked: O(n) CPU work); may be
    ///   empty (frames then draw nothing); at most `max_buffer_size / 12` and 1,431,655,765.
    ///
    /// Cost: one queue write of 12 bytes a triangle, staged for the next submit; a new index
    /// buffer (twice the size needed) when the current one is too small.
    pub fn set_triangles(
        &mut self,
        ctx: &GpuContext,
        triangles: &[[u32; 3]],
    ) -> Result<(), FullMeshError> {
        let bytes = triangles.len() as u64 * FULL_MESH_TRIANGLE_BYTES;
        let limit = ctx.limits.max_buffer_size.min((u32::MAX as u64 / 3) * 12);
        if bytes > limit {
            return Err(FullMeshError::TooLarge {
                what: "index",
                bytes,
                limit,
            });
        }
        check_indices(triangles, self.vertex_count as usize)?;
        if bytes > self.indices.size() {
            self.indices = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("full mesh triangles"),
                size: (2 * bytes).min(limit).max(bytes),
                usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
        }
        if bytes > 0 {
            ctx.queue
                .write_buffer(&self.indices, 0, bytemuck::cast_slice(triangles));
        }
        self.index_count = triangles.len() as u32 * 3;
        Ok(())
    }

    /// Triangles drawn by every frame (the whole mesh, or the last `set_triangles`).
    pub fn triangle_count(&self) -> u32 {
        self.index_count / 3
    }

    /// Vertices uploaded.
    pub fn vertex_count(&self) -> u32 {
        self.vertex_count
    }

    /// Target size.
    pub fn size(&self) -> (u32, u32) {
        (self.target.width, self.target.height)
    }

    /// Records and submits one frame (one render pass, one indexed draw of every triangle);
    /// returns the CPU milliseconds spent (uniforms, commands, submit — not waiting for the
    /// GPU), like `Renderer::render`. With `read_image`, the colour is copied out for
    /// `read_image`. The camera's viewport should match the target.
    pub fn render(&mut self, ctx: &GpuContext, camera: &Camera, read_image: bool) -> f64 {
        let start = Instant::now();
        // The renderer's uniforms for a lit frame; only the origin of the header matters here
        // (the eye), the rest feeds the traversal, which this peer does not have.
        let header = Header {
            origin: self.origin,
            ..bytemuck::Zeroable::zeroed()
        };
        let cull = CullTests {
            frustum: None,
            cones: false,
        };
        let uniforms = FrameUniforms::new(camera, camera, &header, 0.0, &cull, ShadingMode::Lit, 0);
        ctx.queue
            .write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("full mesh frame"),
            });
        {
            let mut pass = self.target.begin_pass(
                &mut encoder,
                "full mesh",
                BACKGROUND,
                self.timer.as_ref().map(|t| t.render_end(true)),
            );
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.group, &[]);
            pass.set_vertex_buffer(0, self.vertices.slice(..));
            if self.index_count > 0 {
                pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..self.index_count, 0, 0..1);
            }
        }
        if let Some(t) = &self.timer {
            t.resolve(&mut encoder);
        }
        if read_image {
            self.target.copy_out(&mut encoder);
        }
        ctx.queue.submit([encoder.finish()]);
        ctx.submitted();
        start.elapsed().as_secs_f64() * 1e3
    }

    /// The image of the last frame rendered with `read_image` (blocks until it is done); the
    /// device's failure if it failed.
    pub fn read_image(&self, ctx: &GpuContext) -> Result<image::RgbaImage, GpuFailure> {
        self.target.read(ctx)
    }

    /// GPU milliseconds from the start to the end of the last frame's render pass, where the
    /// adapter has timestamps (blocks until that frame is done).
    pub fn read_gpu_ms(&self, ctx: &GpuContext) -> Result<Option<f64>, GpuFailure> {
        match &self.timer {
            Some(timer) => timer.read_ms(ctx),
            None => Ok(None),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pass parses and validates with naga, the front end wgpu uses (no GPU needed).
    #[test]
    fn full_mesh_shader_validates() {
        let source = full_mesh_source();
        let module = naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("full_mesh: {}", e.emit_to_string(&source)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("full_mesh: {e:?}"));
    }

    #[test]
    fn positions_are_made_relative_in_f64() {
        let origin = [1e7, -2.0, 0.5];
        let rel = relative_positions(&[[1e7 + 0.25, -1.0, 0.5]], origin);
        assert_eq!(rel, vec![[0.25, 1.0, 0.0]]);
    }

    /// A square in front of the camera covers the centre pixel and leaves the corners as
    /// background; bad meshes are refused. Needs an adapter (lavapipe in CI), like the GPU
    /// tests of the `tests` crate.
    #[test]
    fn draws_a_square_and_refuses_bad_meshes() {
        let ctx = GpuContext::new(None).unwrap_or_else(|e| {
            panic!("{e}\n(the GPU tests need a Vulkan adapter; .ci/run installs lavapipe)")
        });
        let origin = [100.0, 0.0, 0.0];
        let square = [
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ];
        let positions = relative_positions(
            &square.map(|p: [f64; 3]| [p[0] + origin[0], p[1], p[2]]),
            origin,
        );
        let triangles = [[0, 1, 2], [0, 2, 3]];
        let mut r =
            FullMeshRenderer::new(&ctx, &positions, &triangles, origin, (64, 48), Faces::Front)
                .unwrap();
        assert_eq!(r.triangle_count(), 2);
        let camera = Camera {
            up: [0.0, 1.0, 0.0],
            width: 64,
            height: 48,
            ..Camera::looking_at([100.0, 0.0, 3.0], [100.0, 0.0, 0.0], 1.5)
        };
        r.render(&ctx, &camera, true);
        let image = r.read_image(&ctx).unwrap();
        let centre = image.get_pixel(32, 24).0;
        let corner = image.get_pixel(0, 0).0;
        assert_ne!(centre, corner, "the square covers the centre");
        assert_eq!(corner, [28, 31, 38, 255], "background in the corner");
        if ctx.capabilities.timestamps {
            assert!(r.read_gpu_ms(&ctx).unwrap().is_some());
        }
        // Seen from behind: nothing with `Faces::Front`, the square with `Faces::Both`.
        let behind = Camera {
            up: [0.0, 1.0, 0.0],
            width: 64,
            height: 48,
            ..Camera::looking_at([100.0, 0.0, -3.0], [100.0, 0.0, 0.0], 1.5)
        };
        r.render(&ctx, &behind, true);
        let back = r.read_image(&ctx).unwrap();
        assert_eq!(back.get_pixel(32, 24).0, corner, "back faces culled");
        let mut both =
            FullMeshRenderer::new(&ctx, &positions, &triangles, origin, (64, 48), Faces::Both)
                .unwrap();
        both.render(&ctx, &behind, true);
        let back = both.read_image(&ctx).unwrap();
        assert_ne!(back.get_pixel(32, 24).0, corner, "both faces drawn");
        // Another triangle list over the same vertices: one triangle leaves half empty,
        // none draws nothing, more than the first upload grows the buffer.
        r.set_triangles(&ctx, &[[0, 1, 2]]).unwrap();
        assert_eq!(r.triangle_count(), 1);
        r.render(&ctx, &camera, true);
        let half = r.read_image(&ctx).unwrap();
        assert_ne!(
            half.get_pixel(40, 18).0,
            corner,
            "triangle 0-1-2 covers x > y"
        );
        assert_eq!(half.get_pixel(24, 18).0, corner, "x < y is empty");
        r.set_triangles(&ctx, &[]).unwrap();
        r.render(&ctx, &camera, true);
        assert_eq!(r.read_image(&ctx).unwrap().get_pixel(32, 24).0, corner);
        r.set_triangles(&ctx, &[[0, 1, 2], [0, 2, 3], [0, 1, 2]])
            .unwrap();
        r.render(&ctx, &camera, true);
        assert_eq!(r.read_image(&ctx).unwrap(), image);
        assert!(matches!(
            r.set_triangles(&ctx, &[[0, 1, 4]]),
            Err(FullMeshError::Bad(MeshProblem::IndexOutOfRange {
                vertex: 4,
                ..
            }))
        ));
        for bad in [&[[0, 1, 4]][..], &[][..]] {
            assert!(
                FullMeshRenderer::new(&ctx, &positions, bad, origin, (64, 48), Faces::Front)
                    .is_err()
            );
        }
        assert!(matches!(
            FullMeshRenderer::new(&ctx, &positions, &triangles, origin, (0, 48), Faces::Front),
            Err(FullMeshError::BadSize(_))
        ));
    }
}
