//! The welded, cleaned input mesh every importer produces and the builder consumes.

/// A triangle mesh after welding: vertex `i` is global vertex id `i`, kept all the way into the
/// repository (the crack check compares cuts by these ids).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct InputMesh {
    /// Model-space positions (f64 so that models far from the origin keep their precision).
    pub positions: Vec<[f64; 3]>,
    /// Counter-clockwise triangles of vertex ids; no repeated id within a triangle (the build
    /// refuses one: `BuildError::RepeatedVertex`). The importers also drop duplicate triangles
    /// (same vertex set) and weld identical positions; the build accepts meshes that have
    /// either, keeps a duplicate as the input has it, and keeps distinct vertices at one
    /// position distinct.
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex normals, only if the input file has them.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Per-vertex RGBA8 colours, only if the input file has them.
    pub colors: Option<Vec<[u8; 4]>>,
    /// Per-vertex texture coordinates, only if the input file has them.
    pub uvs: Option<Vec<[f32; 2]>>,
}
