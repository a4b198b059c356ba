//! The draw pipelines of `draw.wgsl`: the fill (lit; or, through `fs_main`, coloured by patch
//! or level, unlit albedo or normals), the pixel check's two passes (and their underside
//! variants) and the wireframe overlay, as triangle lists: one set for the indexed draw, one
//! for the vertex-pulling draw. The lit fill and the
//! check's front pass read only the attributes the model has (`draw.wgsl`'s fragment inputs).

use std::sync::OnceLock;

use tessera_core::repository::format::{ATTR_COLORS, ATTR_NORMALS};

use super::target::{COLOR_FORMAT, DEPTH_FORMAT};

/// The draw pipelines, each made when first used: a frame makes at most four of the eighteen
/// (a fill and the wireframe, indexed and pulled), and every pipeline a software adapter
/// compiles costs host memory (llvmpipe GL: about 3 MB). A pipeline that fails to build is
/// reported as a device error by the frame that first asks for it.
pub struct DrawPipelines {
    device: wgpu::Device,
    layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
    /// The vertex entry point.
    vertex: &'static str,
    /// The lit fill's and the check's front pass's fragment entry points for the model's
    /// attributes.
    lit: &'static str,
    check_front: &'static str,
    /// The color mode's fragment entry point: `fs_main`, or the textured one.
    colour: &'static str,
    wireframe: bool,
    made: [OnceLock<wgpu::RenderPipeline>; PASSES],
}

const PASSES: usize = Pass::Wire as usize + 1;

/// Which draw pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// Every face, coloured by patch or level, by albedo or by normal (`fs_main`, the modes
    /// other than lit and check; two-sided: the frame culls no patch by its normal cone
    /// either).
    Fill,
    /// Front faces only, as `Fill`: the default, one face rule for the
    /// rasteriser and the patch cones, so a picture does not depend on τ through which
    /// patches the cones dropped (back faces of kept patches would show where culled
    /// patches' front faces are missing).
    FillFront,
    /// `Fill` and `FillFront` in the lit mode, reading only the model's attributes.
    FillLit,
    FillFrontLit,
    /// `Fill` and `FillFront` in the color mode: `fs_main` (as `Fill`), or with textures the
    /// textured albedo.
    FillColour,
    FillFrontColour,
    /// The check's first pass: front faces only, grey.
    CheckFront,
    /// The check's second pass: back faces only, flag colour where no front face is.
    CheckBack,
    /// `CheckFront` and `CheckBack` with clockwise faces counting as front (underside check).
    CheckFrontUnder,
    CheckBackUnder,
    /// Triangle edges over the fill (the last: `PASSES` counts up to it).
    Wire,
}

impl DrawPipelines {
    /// The pipeline of `pass` (made now if it is the first use); `None` for the wireframe
    /// where the adapter has no line mode.
    pub fn get(&self, pass: Pass) -> Option<&wgpu::RenderPipeline> {
        if pass == Pass::Wire && !self.wireframe {
            return None;
        }
        Some(self.made[pass as usize].get_or_init(|| self.make(pass)))
    }
}

impl DrawPipelines {
    /// `layouts`: group 0 (frame, tables, selection lists), group 1 (page) and, textured,
    /// group 2 (`texture_cache.rs`); `module`: draw.wgsl (textured: with texture.wgsl);
    /// `vertex`: its vertex entry point (`vs_indexed` for the indexed draw, `vs_main` for
    /// vertex pulling); `attributes`: the model's (`ATTR_*`); `wireframe`: the adapter has
    /// line polygon mode. Three layouts make the lit and color fills textured.
    pub fn new(
        device: &wgpu::Device,
        layouts: &[&wgpu::BindGroupLayout],
        module: &wgpu::ShaderModule,
        vertex: &'static str,
        attributes: u32,
        wireframe: bool,
    ) -> DrawPipelines {
        let normals = attributes & ATTR_NORMALS != 0;
        let colours = attributes & ATTR_COLORS != 0;
        let textured = layouts.len() == 3;
        let lit = match (normals, colours, textured) {
            (false, false, false) => "fs_lit",
            (true, false, false) => "fs_lit_normals",
            (false, true, false) => "fs_lit_colours",
            (true, true, false) => "fs_lit_normals_colours",
            (false, false, true) => "fs_lit_textured",
            (true, false, true) => "fs_lit_normals_textured",
            (false, true, true) => "fs_lit_colours_textured",
            (true, true, true) => "fs_lit_normals_colours_textured",
        };
        let colour = match (colours, textured) {
            (_, false) => "fs_main",
            (false, true) => "fs_colour_textured",
            (true, true) => "fs_colour_colours_textured",
        };
        let check_front = if normals {
            "fs_check_front_normals"
        } else {
            "fs_check_front"
        };
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("draw"),
            bind_group_layouts: &layouts.iter().map(|&l| Some(l)).collect::<Vec<_>>(),
            immediate_size: 0,
        });
        DrawPipelines {
            device: device.clone(),
            layout,
            module: module.clone(),
            vertex,
            lit,
            check_front,
            colour,
            wireframe,
            made: Default::default(),
        }
    }

    fn make(&self, pass: Pass) -> wgpu::RenderPipeline {
        let (lit, check_front, colour) = (self.lit, self.check_front, self.colour);
        let (device, layout, module, vertex) =
            (&self.device, &self.layout, &self.module, self.vertex);
        let (entry_point, cull_mode, depth_write, depth_compare) = match pass {
            // Back faces are drawn: the lit mode shades them too.
            Pass::Fill => ("fs_main", None, true, wgpu::CompareFunction::GreaterEqual),
            Pass::FillFront => (
                "fs_main",
                Some(wgpu::Face::Back),
                true,
                wgpu::CompareFunction::GreaterEqual,
            ),
            Pass::FillLit => (lit, None, true, wgpu::CompareFunction::GreaterEqual),
            Pass::FillFrontLit => (
                lit,
                Some(wgpu::Face::Back),
                true,
                wgpu::CompareFunction::GreaterEqual,
            ),
            Pass::FillColour => (colour, None, true, wgpu::CompareFunction::GreaterEqual),
            Pass::FillFrontColour => (
                colour,
                Some(wgpu::Face::Back),
                true,
                wgpu::CompareFunction::GreaterEqual,
            ),
            Pass::CheckFront | Pass::CheckFrontUnder => (
                check_front,
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
            layout: Some(layout),
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
    }
}
