// Shared by every pass: the repository records as stored in the file (uploaded as they are),
// the traversal's slot records and per-slot draw locations the runtime derives, and the
// per-frame uniforms.
// Rust mirrors: tessera_core::repository::format::{DiamondRecord, TetRecord},
// tessera_runtime::gpu::records::SlotRecord, tessera_runtime::gpu::resident::PatchLocation,
// tessera_runtime::gpu::frame::FrameUniforms.
// Scalars only (no vec3 members), so the WGSL layout is the file's packed layout.

const NO_INDEX: u32 = 0xffffffffu;

// One diamond the hierarchy splits: 56 bytes, one per diamond.
struct DiamondRecord {
    cx: f32, cy: f32, cz: f32,      // saturated bounding sphere centre, relative to the origin
    radius: f32,
    error: f32,                     // saturated object-space error, model units
    parents: array<u32, 4>,
    packed_counts: u32,             // parent_count, tet_count, phase, pad (u8 each)
    level: u32,
    id_x: i32, id_y: i32, id_z: i32,
}

// One simplex with its patch: 88 bytes, one per simplex.
// Drawn iff rho(diamond) <= tau < rho(parent_diamond); rho = 0 for a leaf, infinity for a root.
struct TetRecord {
    cx: f32, cy: f32, cz: f32,      // bounding sphere of the patch, relative to the origin
    radius: f32,
    ax: f32, ay: f32, az: f32,      // normal cone axis
    cone_cos: f32,                  // -1: no back-face culling possible
    diamond: u32,                   // NO_INDEX for a leaf
    parent_diamond: u32,            // NO_INDEX for a root
    first_child: u32,
    level: u32,
    patch_offset_lo: u32, patch_offset_hi: u32,
    patch_bytes: u32,
    vertex_count: u32,
    strip_index_count: u32,
    triangle_count: u32,
    id_offset_lo: u32, id_offset_hi: u32,
    id_bytes: u32,
    reserved: u32,
}

// What the traversal reads of a simplex: 88 bytes, one per record slot
// (tessera_runtime::gpu::records). Fully resident, slot = simplex; streaming, a fixed pool of
// slots the units' records come and go in. level, vertex_count and strip_index_count sit where
// TetRecord has them, so the passes that read those (compaction, expansion, draw) bind the
// slot records as TetRecord.
struct SlotRecord {
    cx: f32, cy: f32, cz: f32,      // the simplex's bounding sphere (nested), relative to the origin
    radius: f32,
    ax: f32, ay: f32, az: f32,      // normal cone axis
    cone_cos: f32,
    diamond: u32,                   // its diamond (global index); NO_INDEX for a leaf
    simplex: u32,                   // its id in the repository (read-back; patch colours)
    children: u32,                  // slot of its first child (then + 1); NO_INDEX: may not refine
    level: u32,
    dcx: f32, dcy: f32,             // its diamond's saturated sphere centre x, y
    patch_bytes: u32,
    vertex_count: u32,
    strip_index_count: u32,
    triangle_count: u32,
    dcz: f32,                       // ... centre z
    dradius: f32,                   // ... radius
    derror: f32,                    // its diamond's saturated object-space error
    pad: u32,
}

// Where a slot's patch is resident: 16 bytes, one per record slot.
struct PatchLocation {
    page: u32,          // resident page; NO_INDEX if the patch is empty
    first_entry: u32,   // first entry of that page's selection list
    first_index: u32,   // strip start in the page, in indices (u16, or u32 over 65,535 vertices)
    base_vertex: u32,   // first position in the page, in 8-byte slots
}

// One selected patch of a page's selection list: the traversal appends the simplex, the
// compaction pass writes the exclusive prefix sum of the list's strip slots.
struct Selected {
    simplex: u32,
    first_slot: u32,
}

// A resident page, for the compaction and expansion passes (tessera_runtime::gpu::compact).
struct PageInfo {
    first_entry: u32,       // its selection list's first entry
    index_capacity: u32,    // strip slots its index region holds
    first_index: u32,       // the region's start in the index buffer
    pad: u32,
}

// What the compaction pass writes per page, 16 words (tessera_runtime::gpu::compact): the
// vertex-pulling draw (wgpu DrawIndirectArgs) at word 0, the indexed draw
// (DrawIndexedIndirectArgs) at word 4, the expansion's dispatch at word 9, the selected slots
// at word 12. Exactly one of the two draws has a non-zero count.
const PAGE_ARGS_WORDS: u32 = 16u;
const PULL_DRAW: u32 = 0u;
const INDEXED_DRAW: u32 = 4u;
const EXPAND_DISPATCH: u32 = 9u;
const SELECTED_SLOTS: u32 = 12u;

// Strip slots of a patch with m strip indices: slot k is (s[k], s[k+1], s[k+2]).
fn strip_slots(m: u32) -> u32 {
    return select(0u, m - 2u, m >= 3u);
}

struct Frame {
    view_proj: mat4x4<f32>,     // eye-relative position -> clip (reverse Z, infinite far plane)
    eye_tau: vec4<f32>,         // xyz: eye - origin (rounded from f64); w: tau in pixels
    planes: array<vec4<f32>, 4>,// inward normals of the left, right, bottom, top planes
    forward_near: vec4<f32>,    // xyz: view direction; w: near cull distance
    metric: vec4<f32>,          // x: K (pixels per unit at distance 1); y: metric near; z: far
    eye_fraction: vec4<f32>,    // xyz: (eye - bbox_min) / step - eye_cell (position.wgsl)
    step: vec4<f32>,            // xyz: model units per lattice step (a flat axis: see EyeLattice)
    light: vec4<f32>,           // xyz: unit direction towards the light, eye-relative
    counts: vec4<u32>,          // x: simplices; y: cull flags; z: shading mode; w: attributes
    eye_cell: vec4<i32>,        // xyz: floor((eye - bbox_min) / step), clamped to +-2^23
}

const CULL_FRUSTUM: u32 = 1u;
const CULL_CONES: u32 = 2u;
const SHADE_FACES: u32 = 4u;  // frame.counts.y: lit with face normals only (`--flat`)
const ATTR_NORMALS: u32 = 1u;
const ATTR_COLORS: u32 = 2u;
const ATTR_UVS: u32 = 4u;
