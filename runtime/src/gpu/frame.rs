//! The per-frame uniforms (`Frame` in `shaders/records.wgsl`): everything a frame needs, made
//! on the CPU in O(1) from the camera, τ and the repository header.

use bytemuck::{Pod, Zeroable};
use tessera_core::cull::CullTests;
use tessera_core::eye_relative::EyeLattice;
use tessera_core::repository::format::Header;

use crate::camera::Camera;

/// How fragments are coloured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadingMode {
    /// Lit by a light over the viewer's shoulder: stored normals, else the face normal.
    Lit,
    /// Lit as `Lit`, with the face normal everywhere, stored normals ignored (`--flat`).
    LitFaces,
    /// Unlit albedo: the stored per-vertex colour, `ALBEDO_GREY` where the model has none.
    Color,
    /// The normal as a colour, n × 0.5 + 0.5 per channel (x red, y green, z blue, model axes):
    /// the stored normal, interpolated and renormalised, else the face normal turned towards
    /// the eye.
    Normals,
    /// `Normals` with the face normal everywhere, stored normals ignored (`--flat`).
    NormalsFaces,
    /// One colour per simplex.
    Patches,
    /// One colour per LEB level.
    Levels,
    /// Front faces grey, back faces `FLAG_COLOUR` (the pixel crack check).
    Check,
    /// The same check for the other side of an open surface (a terrain seen from below):
    /// faces clockwise on screen count as front, counter-clockwise ones are flagged.
    CheckUnderside,
}

impl ShadingMode {
    /// One of the two lit modes.
    pub fn is_lit(self) -> bool {
        matches!(self, ShadingMode::Lit | ShadingMode::LitFaces)
    }

    /// One of the two check modes.
    pub fn is_check(self) -> bool {
        matches!(self, ShadingMode::Check | ShadingMode::CheckUnderside)
    }

    /// One of the modes that use face normals where the model stores normals (`--flat`).
    pub fn is_flat(self) -> bool {
        matches!(self, ShadingMode::LitFaces | ShadingMode::NormalsFaces)
    }

    /// `MODE_*` of `draw.wgsl`.
    fn code(self) -> u32 {
        match self {
            ShadingMode::Lit | ShadingMode::LitFaces => 0,
            ShadingMode::Patches => 1,
            ShadingMode::Levels => 2,
            ShadingMode::Check | ShadingMode::CheckUnderside => 3,
            ShadingMode::Color => 4,
            ShadingMode::Normals | ShadingMode::NormalsFaces => 5,
        }
    }
}

/// The colour the check mode gives back faces (RGBA8), counted by the pixel check.
pub const FLAG_COLOUR: [u8; 4] = [255, 0, 255, 255];

/// What `ShadingMode::Color` draws on a model without colours (RGBA8; `ALBEDO_GREY` of
/// `draw.wgsl`, 0.8).
pub const ALBEDO_GREY: [u8; 4] = [204, 204, 204, 255];

const CULL_FRUSTUM: u32 = 1;
const CULL_CONES: u32 = 2;
/// `ShadingMode::LitFaces`, `ShadingMode::NormalsFaces`: the fragment stage ignores stored
/// normals.
const SHADE_FACES: u32 = 4;

/// Mirrors `Frame` in `shaders/records.wgsl` (uniform layout: 16-byte rows).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct FrameUniforms {
    pub view_proj: [[f32; 4]; 4],
    pub eye_tau: [f32; 4],
    pub planes: [[f32; 4]; 4],
    pub forward_near: [f32; 4],
    pub metric: [f32; 4],
    /// xyz: the eye's lattice coordinate minus `eye_cell` (`EyeLattice::fraction`).
    pub eye_fraction: [f32; 4],
    /// xyz: model units per lattice step (`EyeLattice::unit`).
    pub step: [f32; 4],
    pub light: [f32; 4],
    pub counts: [u32; 4],
    /// xyz: the eye's lattice cell (`EyeLattice::cell`); vertices are placed at
    /// (f32(q − eye_cell) − eye_fraction) × step (`shaders/position.wgsl`).
    pub eye_cell: [i32; 4],
}

impl FrameUniforms {
    /// The uniforms of one frame. `cull` must be what the CPU reference is given to compare
    /// selections (its frustum is the camera's view volume when present).
    ///
    /// Two cameras: the traversal's fields (`eye_tau.xyz`, `planes`, `forward_near`, `metric`)
    /// come from `camera`, the one the cut is selected for; the drawing's fields (`view_proj`,
    /// the eye lattice `eye_cell`/`eye_fraction`/`step`, `light`) from `draw`, the one it is
    /// seen from (`FrameRequest::draw_camera`; pass `camera` again for an ordinary frame, which
    /// gives bit-identical uniforms). `eye_lattice` and `clip_of_lattice_point` describe `draw`.
    /// A pass without traversal that reads `eye_tau` to draw (`full_mesh.wgsl`) must pass the
    /// same camera twice.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        camera: &Camera,
        draw: &Camera,
        header: &Header,
        tau: f32,
        cull: &CullTests,
        mode: ShadingMode,
        tet_count: u32,
    ) -> FrameUniforms {
        // Traversal: the cut's camera.
        let eye = camera.eye_local(header.origin);
        let volume = cull.frustum.unwrap_or_else(|| camera.view_volume());
        let metric = camera.metric();
        // Drawing: the camera the cut is seen from.
        let lattice = EyeLattice::new(draw.eye, header.bbox_min, header.position_step);
        let b = draw.basis();
        let light = normalize([0, 1, 2].map(|i| -b.forward[i] + 0.6 * b.up[i] - 0.4 * b.right[i]));
        let flags = (cull.frustum.is_some() as u32 * CULL_FRUSTUM)
            | (cull.cones as u32 * CULL_CONES)
            | (mode.is_flat() as u32 * SHADE_FACES);
        let v4 = |v: [f32; 3], w: f32| [v[0], v[1], v[2], w];
        FrameUniforms {
            view_proj: draw.view_projection(),
            eye_tau: v4(eye, tau),
            planes: volume.side_planes.map(|n| v4(n, 0.0)),
            forward_near: v4(volume.forward, volume.near),
            metric: [metric.k, metric.near, volume.far, 0.0],
            eye_fraction: v4(lattice.fraction, 0.0),
            step: v4(lattice.unit, 0.0),
            light: v4(light.map(|x| x as f32), 0.0),
            counts: [tet_count, flags, mode.code(), header.attributes],
            eye_cell: [lattice.cell[0], lattice.cell[1], lattice.cell[2], 0],
        }
    }
}

impl FrameUniforms {
    /// The eye on the lattice these uniforms carry.
    pub fn eye_lattice(&self) -> EyeLattice {
        EyeLattice {
            cell: [self.eye_cell[0], self.eye_cell[1], self.eye_cell[2]],
            fraction: [
                self.eye_fraction[0],
                self.eye_fraction[1],
                self.eye_fraction[2],
            ],
            unit: [self.step[0], self.step[1], self.step[2]],
        }
    }

    /// `clip_position(eye_relative_position(q))` of `shaders/position.wgsl`, in f32 on the CPU
    /// (the GPU may fuse the matrix product's multiply-adds: its bits may differ by an ulp).
    pub fn clip_of_lattice_point(&self, q: [i32; 3]) -> [f32; 4] {
        let r = self.eye_lattice().eye_relative(q);
        let m = self.view_proj;
        [0, 1, 2, 3].map(|row| m[0][row] * r[0] + m[1][row] * r[1] + m[2][row] * r[2] + m[3][row])
    }
}

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / l)
}

const _: () = assert!(std::mem::size_of::<FrameUniforms>() == 64 + 16 * 4 + 16 * 8);
