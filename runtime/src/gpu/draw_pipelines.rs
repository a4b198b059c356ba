//! The draw pipelines of `draw.wgsl`: the lit/shaded fill, the pixel check's two passes (and
//! their underside variants) and the wireframe overlay, as triangle lists: one set for the
//! indexed draw, one for the vertex-pulling draw.

use super::target::{COLOR_FORMAT, DEPTH_FORMAT};

/// The draw pipelines.
pub struct DrawPipelines {
    fill: wgpu::RenderPipeline,
    fill_front: wgpu::RenderPipeline,
    check_front: wgpu::RenderPipeline,
    check_back: wgpu::RenderPipeline,
    check_front_under: wgpu::RenderPipeline,
    check_back_under: wgpu::RenderPipeline,
    wire: Option<wgpu::RenderPipeline>,
}

/// Which draw pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// Every face, shaded by the frame's mode (two-sided: the frame culls no patch by its
    /// normal cone either).
    Fill,
    /// Front faces only, shaded by the frame's mode: the default, one face rule for the
    /// rasteriser and the patch cones, so a picture does not depend on τ through which
    /// patches the cones dropped (back faces of kept patches would show where culled
    /// patches' front faces are missing).
    FillFront,
    /// The check's first pass: front faces only, grey.
    CheckFront,
    /// The check's second pass: back faces only, flag colour where no front face is.
    CheckBack,
    /// `CheckFront` and `CheckBack` with clockwise faces counting as front (underside check).
    CheckFrontUnder,
    CheckBackUnder,
    /// Triangle edges over the fill.
    Wire,
}

impl DrawPipelines {
    /// The pipeline of `pass`; `None` for the wireframe where the adapter has no line mode.
    pub fn get(&self, pass: Pass) -> Option<&wgpu::RenderPipeline> {
        match pass {
            Pass::Fill => Some(&self.fill),
            Pass::FillFront => Some(&self.fill_front),
            Pass::CheckFront => Some(&self.check_front),
            Pass::CheckBack => Some(&self.check_back),
            Pass::CheckFrontUnder => Some(&self.check_front_under),
            Pass::CheckBackUnder => Some(&self.check_back_under),
            Pass::Wire => self.wire.as_ref(),
        }
    }
}

impl DrawPipelines {
    /// `layouts`: group 0 (frame, tables, selection lists) and group 1 (page); `module`:
    /// draw.wgsl; `vertex`: its vertex entry point (`vs_indexed` for the indexed draw,
    /// `vs_main` for vertex pulling); `wireframe`: the adapter has line polygon mode.
    pub fn new(
        device: &wgpu::Device,
        layouts: &[&wgpu::BindGroupLayout; 2],
        module: &wgpu::ShaderModule,
        vertex: &str,
        wireframe: bool,
    ) -> DrawPipelines {
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("draw"),
            bind_group_layouts: &[Some(layouts[0]), Some(layouts[1])],
            immediate_size: 0,
        });
        let pipeline = |pass: Pass| {
            let (entry_point, cull_mode, depth_write, depth_compare) = match pass {
                // Back faces are drawn: the lit mode shades them too.
                Pass::Fill => ("fs_main", None, true, wgpu::CompareFunction::GreaterEqual),
                Pass::FillFront => (
                    "fs_main",
                    Some(wgpu::Face::Back),
                    true,
                    wgpu::CompareFunction::GreaterEqual,
                ),
                Pass::CheckFront | Pass::CheckFrontUnder => (
                    "fs_check_front",
                    Some(wgpu::Face::Back),
                    true,
                    wgpu::CompareFunction::GreaterEqual,
                ),
                // Depth 0 "equal" the cleared depth: only where no front face was drawn.
                Pass::CheckBack | Pass::CheckBackUnder => (
                    "fs_check_back",
                    Some(wgpu::Face::Front),
                    false,
                    wgpu::CompareFunction::Equal,
                ),
                Pass::Wire => ("fs_wire", None, false, wgpu::CompareFunction::GreaterEqual),
            };
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(entry_point),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some(vertex),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    strip_index_format: None,
                    front_face: if matches!(pass, Pass::CheckFrontUnder | Pass::CheckBackUnder) {
                        wgpu::FrontFace::Cw
                    } else {
                        wgpu::FrontFace::Ccw
                    },
                    cull_mode,
                    unclipped_depth: false,
                    polygon_mode: if pass == Pass::Wire {
                        wgpu::PolygonMode::Line
                    } else {
                        wgpu::PolygonMode::Fill
                    },
                    conservative: false,
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(depth_write),
                    depth_compare: Some(depth_compare),
                    stencil: Default::default(),
                    // Reverse Z: a positive bias pulls the lines towards the eye.
                    bias: if pass == Pass::Wire {
                        wgpu::DepthBiasState {
                            constant: 2,
                            slope_scale: 1.0,
                            clamp: 0.0,
                        }
                    } else {
                        Default::default()
                    },
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module,
                    entry_point: Some(entry_point),
                    compilation_options: Default::default(),
                    targets: &[Some(COLOR_FORMAT.into())],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        DrawPipelines {
            fill: pipeline(Pass::Fill),
            fill_front: pipeline(Pass::FillFront),
            check_front: pipeline(Pass::CheckFront),
            check_back: pipeline(Pass::CheckBack),
            check_front_under: pipeline(Pass::CheckFrontUnder),
            check_back_under: pipeline(Pass::CheckBackUnder),
            wire: wireframe.then(|| pipeline(Pass::Wire)),
        }
    }
}
