//! The source mesh as the peers draw it: f32 positions relative to the repository origin
//! (exactly what `FullMeshRenderer` uploads), the same positions widened to f64 for measuring
//! (so a peer's measured surface is what it drew), and the welded triangles.

use tessera_preprocess::InputMesh;
use tessera_runtime::gpu::full_mesh::relative_positions;

pub struct PeerMesh {
    /// Relative to the repository origin, as uploaded.
    pub positions: Vec<[f32; 3]>,
    /// `positions` widened to f64 (exact).
    pub positions_f64: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

impl PeerMesh {
    pub fn new(mesh: &InputMesh, origin: [f64; 3]) -> PeerMesh {
        let positions = relative_positions(&mesh.positions, origin);
        let positions_f64 = positions.iter().map(|p| p.map(f64::from)).collect();
        PeerMesh {
            positions,
            positions_f64,
            triangles: mesh.triangles.clone(),
        }
    }

    /// The positions as meshopt reads them (12-byte stride).
    pub fn vertex_adapter(&self) -> meshopt::VertexDataAdapter<'_> {
        meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&self.positions), 12, 0)
            .expect("packed f32 positions, 12 bytes each")
    }

    /// The triangles as one flat index list.
    pub fn indices(&self) -> &[u32] {
        self.triangles.as_flattened()
    }
}
