//! Skirts for the terrain pixel check: walls on a cut's border edges that close an open height
//! field only inside the check (shaders/draw.wgsl, `vs_skirt`).
//!
//! Why: through a nodata hole an eye may see the far side of the surface, and which pixels
//! do depends on the cut (a hole one cell wide is a sub-pixel aperture behind which coarser
//! geometry moves by up to τ). Walls hanging from the border make what a ray through a hole
//! meets a wall, or nothing, at every τ, so the check can compare each cut's hole pixels with
//! the input's (`pixel_check.rs`). Height fields shorten their border chains, so each frame's
//! walls follow its own cut — but only on the border edges that simplify the input's border
//! (`border_loops.rs`): a crack gets no wall and stays visible.
//!
//! Wall corners are lattice points (i32, the border vertices' own q, and lattice heights below
//! and above the terrain), placed by the vertex stage like every patch vertex
//! (`shaders/position.wgsl`): a wall's top edge lands on the same bits as the border edge it
//! hangs from, whatever the terrain's extent.

use std::collections::HashMap;

use tessera_core::eye_relative::lattice_unit;
use tessera_core::repository::reader::{Repository, RepositoryError};

use crate::border_loops::BorderLoops;

/// Wall triangles (corners on the position lattice, z possibly outside `[0, 2^21)`), one list
/// per side.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkirtMeshes {
    /// Walls from each border edge down to below the terrain's lowest point.
    pub down: Vec<[i32; 3]>,
    /// Walls from each border edge up to above its highest point.
    pub up: Vec<[i32; 3]>,
}

/// What the walls of any cut of one repository are made from: the input's border chains and
/// the lattice heights the walls reach.
pub struct SkirtSource {
    loops: BorderLoops,
    floor: i32,
    ceiling: i32,
}

impl SkirtSource {
    /// The input's border chains (from the leaf patches) of a height-field repository.
    pub fn new(repo: &Repository) -> Result<SkirtSource, RepositoryError> {
        let mut input = Vec::new();
        for (i, tet) in repo.tets().iter().enumerate() {
            if tet.is_leaf() {
                let patch = repo.patch(i)?;
                let patch = patch.view();
                let ids: Vec<u32> = patch.global_ids().collect();
                input.extend(patch.triangles().map(|t| t.map(|v| ids[v as usize])));
            }
        }
        let h = repo.header();
        let depth = (h.bbox_max[2] - h.bbox_min[2]).max(1e-6 * (h.bbox_max[0] - h.bbox_min[0]));
        // 1 % of the depth below and above, on the lattice: z units of the step (or of the
        // flat-axis unit), at least one unit beyond the terrain; |z| stays far below 2^23.
        let unit = lattice_unit(h.position_step)[2];
        let lattice_z = |z: f64| (z - h.bbox_min[2]) / unit;
        Ok(SkirtSource {
            loops: BorderLoops::new(input.iter()),
            floor: lattice_z(h.bbox_min[2] - 0.01 * depth).floor().min(-1.0) as i32,
            ceiling: lattice_z(h.bbox_max[2] + 0.01 * depth)
                .ceil()
                .max(lattice_z(h.bbox_max[2]).round() + 1.0) as i32,
        })
    }

    /// The walls of the cut `selection` (simplex indices): one per border edge of the cut that
    /// simplifies the input's border, directed as its triangle runs (counter-clockwise from
    /// above, so the hole lies to the edge's right).
    pub fn walls(
        &self,
        repo: &Repository,
        selection: &[u32],
    ) -> Result<SkirtMeshes, RepositoryError> {
        let mut triangles = Vec::new();
        let mut position: HashMap<u32, [i32; 3]> = HashMap::new();
        for &i in selection {
            let patch = repo.patch(i as usize)?;
            let patch = patch.view();
            let ids: Vec<u32> = patch.global_ids().collect();
            for (v, &id) in ids.iter().enumerate() {
                position
                    .entry(id)
                    .or_insert_with(|| patch.position(v).map(|c| c as i32));
            }
            triangles.extend(patch.triangles().map(|t| t.map(|v| ids[v as usize])));
        }
        let refs: Vec<&[u32; 3]> = triangles.iter().collect();
        let mut border = self.loops.classify(&refs).border;
        border.sort_unstable();
        let mut meshes = SkirtMeshes::default();
        for (a, b) in border {
            let (a, b) = (position[&a], position[&b]);
            let (a_low, b_low) = ([a[0], a[1], self.floor], [b[0], b[1], self.floor]);
            let (a_high, b_high) = ([a[0], a[1], self.ceiling], [b[0], b[1], self.ceiling]);
            // Counter-clockwise seen from the hole side (the edge's right).
            meshes.down.extend([a, a_low, b_low, a, b_low, b]);
            meshes.up.extend([a, b, b_high, a, b_high, a_high]);
        }
        Ok(meshes)
    }
}

/// The skirts on the GPU: two pipelines (the check's front and back passes, counter-clockwise
/// front whatever the side checked: the wall's hole side is front in both) and the walls of
/// each side, once set.
pub struct CheckSkirts {
    front: wgpu::RenderPipeline,
    back: wgpu::RenderPipeline,
    down: Option<(wgpu::Buffer, u32)>,
    up: Option<(wgpu::Buffer, u32)>,
}

impl CheckSkirts {
    /// `draw_layout`: the renderer's group 0 (frame uniforms first); `module`: draw.wgsl.
    pub fn new(
        device: &wgpu::Device,
        draw_layout: &wgpu::BindGroupLayout,
        module: &wgpu::ShaderModule,
    ) -> CheckSkirts {
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("skirts"),
            bind_group_layouts: &[Some(draw_layout)],
            immediate_size: 0,
        });
        let attributes = wgpu::vertex_attr_array![0 => Sint32x3];
        let pipeline = |front_pass: bool| {
            let (entry, cull, write, compare) = if front_pass {
                (
                    "fs_check_front",
                    wgpu::Face::Back,
                    true,
                    wgpu::CompareFunction::GreaterEqual,
                )
            } else {
                (
                    "fs_check_back",
                    wgpu::Face::Front,
                    false,
                    wgpu::CompareFunction::Equal,
                )
            };
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(entry),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some("vs_skirt"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: 12,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &attributes,
                    })],
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    front_face: wgpu::FrontFace::Ccw,
                    cull_mode: Some(cull),
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: super::target::DEPTH_FORMAT,
                    depth_write_enabled: Some(write),
                    depth_compare: Some(compare),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets: &[Some(super::target::COLOR_FORMAT.into())],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        CheckSkirts {
            front: pipeline(true),
            back: pipeline(false),
            down: None,
            up: None,
        }
    }

    /// Uploads the walls (replacing earlier ones).
    pub fn set(&mut self, device: &wgpu::Device, meshes: &SkirtMeshes) {
        use wgpu::util::DeviceExt;
        let upload = |label: &str, vertices: &[[i32; 3]]| {
            (!vertices.is_empty()).then(|| {
                let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: bytemuck::cast_slice(vertices),
                    usage: wgpu::BufferUsages::VERTEX,
                });
                (buffer, vertices.len() as u32)
            })
        };
        self.down = upload("skirts down", &meshes.down);
        self.up = upload("skirts up", &meshes.up);
    }

    /// Draws the walls of one side in one of the check's passes (group 0 already bound).
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, from_below: bool, front_pass: bool) {
        let walls = if from_below { &self.up } else { &self.down };
        if let Some((buffer, count)) = walls {
            pass.set_pipeline(if front_pass { &self.front } else { &self.back });
            pass.set_vertex_buffer(0, buffer.slice(..));
            pass.draw(0..*count, 0..1);
        }
    }
}
