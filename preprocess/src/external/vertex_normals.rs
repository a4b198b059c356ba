//! A staged mesh's computed vertex normals (`normals.rs`), out of core: the same f32 values
//! as `normals::vertex_normals` of the loaded mesh, so a build gives the same bytes either way.
//!
//! The running sums (12 bytes a vertex) are held for a window of vertex ids at a time, as many
//! as half the budget holds; each window is one pass of the triangles with their corners'
//! positions (`joins::TriangleCorners`, the other half), adding each corner that falls in the
//! window in triangle order, then written out normalised. A mesh whose sums fit is one pass.
//! Sums are by vertex (`mesh.rs`): a wedge adds to its vertex's, and every wedge of a vertex
//! gets its vertex's normal (a texture seam is no crease); windows end at vertices.

use std::io;
use std::path::Path;

use super::joins::TriangleCorners;
use super::staged::{RecordFile, StagedMesh};
use crate::normals::{accumulate, corner_contributions, finish};

/// Bytes a vertex's running sum takes.
const SUM_BYTES: usize = std::mem::size_of::<[f32; 3]>();

/// The angle-weighted normals of `staged`'s vertices, a record a vertex in `dir`, computed
/// within about `budget` bytes.
pub fn stage_vertex_normals(
    staged: &StagedMesh,
    budget: usize,
    dir: &Path,
) -> io::Result<RecordFile<[f32; 3]>> {
    let vertices = staged.positions.len();
    let starts = staged.vertex_starts()?;
    let window = ((budget / 2) / SUM_BYTES).max(1 << 16) as u64;
    let join = TriangleCorners {
        staged,
        budget: budget / 2,
    };
    let mut out = RecordFile::create(dir)?;
    let mut sums: Vec<[f32; 3]> = Vec::new();
    let mut lo = 0u64;
    while lo < vertices {
        let mut hi = (lo + window).min(vertices);
        while hi < vertices && starts.canonical(hi as u32) != hi as u32 {
            hi += 1; // a window holds whole vertices
        }
        sums.clear();
        sums.resize((hi - lo) as usize, [0.0; 3]);
        join.for_each(
            &|t, corners| (t, corner_contributions(corners)),
            &mut |_, (t, contributions)| {
                for k in 0..3 {
                    let v = starts.canonical(t[k]) as u64;
                    if (lo..hi).contains(&v) {
                        accumulate(&mut sums[(v - lo) as usize], contributions[k]);
                    }
                }
            },
        )?;
        let normals: Vec<[f32; 3]> = (lo..hi)
            .map(|w| finish(sums[(starts.canonical(w as u32) as u64 - lo) as usize]))
            .collect();
        out.push_all(&normals)?;
        lo = hi;
    }
    out.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::ImportReport;
    use crate::normals::vertex_normals;

    #[test]
    fn out_of_core_normals_are_the_in_memory_ones_bit_for_bit() {
        let mut mesh = crate::procedural::demo_mesh(7);
        mesh.normals = None;
        // Shuffled ids, so the windows and the chunks' passes meet corners out of order.
        let n = mesh.positions.len() as u32;
        let map = |v: u32| (v as u64 * 48_271 % n as u64) as u32;
        let mut positions = vec![[0.0; 3]; n as usize];
        for (v, p) in mesh.positions.iter().enumerate() {
            positions[map(v as u32) as usize] = *p;
        }
        mesh.positions = positions;
        for t in &mut mesh.triangles {
            *t = t.map(map);
        }
        let want = vertex_normals(&mesh.positions, &mesh.triangles);
        let dir = tempfile::tempdir().unwrap();
        let report = ImportReport {
            raw_vertices: mesh.positions.len(),
            raw_triangles: mesh.triangles.len(),
            mesh,
            welded_vertices: 0,
            degenerate_triangles: 0,
            duplicate_triangles: 0,
            unreferenced_vertices: 0,
            textures: None,
            missing_textures: Vec::new(),
        };
        let staged = StagedMesh::from_report(report, dir.path()).unwrap();
        // In one window with the positions read whole, and in several windows of chunks.
        for budget in [64 << 20, 1 << 20] {
            let file = stage_vertex_normals(&staged, budget, dir.path()).unwrap();
            let got = file.read_all().unwrap();
            assert_eq!(got.len(), want.len());
            let same = got
                .iter()
                .zip(&want)
                .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits));
            assert!(same, "budget {budget}: the normals differ");
        }
    }
}
