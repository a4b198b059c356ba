//! The triangle mesh a height grid becomes: one vertex per sample with a height, two triangles
//! per cell whose four corners have heights, one per cell with exactly three (missing samples
//! are holes). Made a row at a time (two rows of vertex ids), so that under a memory budget it
//! is staged on disk as it is made (`stage`) instead of held (`to_mesh`): the same vertices,
//! ids and triangles either way.

use std::io;
use std::path::Path;

use super::{HeightGrid, TerrainOptions};
use crate::external::staged::VertexAttributes;
use crate::external::{PositionFile, RecordFile, StagedMesh};
use crate::mesh::InputMesh;

impl HeightGrid {
    /// Hands the mesh's vertices (in sample order, missing samples skipped) and triangles (in
    /// cell order) to `vertex` and `triangle`, a row of samples at a time. Triangles are
    /// counter-clockwise seen from above (+z). Geographic grids are drawn as plate carrée in
    /// metres (`METRES_PER_DEGREE`).
    pub fn for_each_mesh_element<E>(
        &self,
        options: &TerrainOptions,
        mut vertex: impl FnMut([f64; 3]) -> Result<(), E>,
        mut triangle: impl FnMut([u32; 3]) -> Result<(), E>,
    ) -> Result<(), E> {
        let columns = self.columns;
        let (origin, spacing) = self.placement(options);
        // Counter-clockwise from above when x grows with the column and y with the row;
        // mirrored otherwise.
        let flip = (spacing[0] < 0.0) != (spacing[1] < 0.0);
        let mut push = |t: [u32; 3]| {
            if t.iter().all(|&v| v != u32::MAX) {
                triangle(if flip { [t[0], t[2], t[1]] } else { t })
            } else {
                Ok(())
            }
        };
        // Vertex ids of the row above and of this row (u32::MAX: missing).
        let mut above = vec![u32::MAX; columns];
        let mut here = vec![u32::MAX; columns];
        let mut next_id = 0u32;
        for (r, row) in self.heights.chunks_exact(columns).enumerate() {
            for (c, &h) in row.iter().enumerate() {
                here[c] = u32::MAX;
                if !h.is_nan() {
                    here[c] = next_id;
                    next_id += 1;
                    vertex([
                        origin[0] + c as f64 * spacing[0],
                        origin[1] + r as f64 * spacing[1],
                        h as f64 * options.vertical_exaggeration,
                    ])?;
                }
            }
            if r > 0 {
                for c in 0..columns - 1 {
                    let (a, b, d, e) = (above[c], above[c + 1], here[c], here[c + 1]);
                    let corners = [a, b, d, e].iter().filter(|&&v| v != u32::MAX).count();
                    if corners == 4 {
                        push([a, b, e])?;
                        push([a, e, d])?;
                    } else if corners == 3 {
                        // The one triangle of the three present corners, same orientation.
                        match [a, b, d, e].iter().position(|&v| v == u32::MAX) {
                            Some(0) => push([b, e, d])?,
                            Some(1) => push([a, e, d])?,
                            Some(2) => push([a, b, e])?,
                            _ => push([a, b, d])?,
                        }
                    }
                }
            }
            std::mem::swap(&mut above, &mut here);
        }
        Ok(())
    }

    /// The mesh, in memory.
    pub fn to_mesh(&self, options: &TerrainOptions) -> InputMesh {
        let mut positions = Vec::with_capacity(self.valid_samples());
        let mut triangles = Vec::with_capacity(2 * (self.columns - 1) * (self.rows - 1));
        let done: Result<(), std::convert::Infallible> = self.for_each_mesh_element(
            options,
            |p| {
                positions.push(p);
                Ok(())
            },
            |t| {
                triangles.push(t);
                Ok(())
            },
        );
        let Ok(()) = done;
        InputMesh {
            positions,
            triangles,
            normals: None,
            colors: None,
            uvs: None,
        }
    }

    /// The mesh, staged on disk in `dir` as it is made (`external/staged.rs`): what a build
    /// under a memory budget reads instead of `to_mesh`'s. Nothing is welded or removed (no
    /// two samples share a position; a sample whose cells all miss a corner stays, unused, as
    /// in `to_mesh`'s mesh), so the import's counts are the mesh's own.
    pub fn stage(&self, options: &TerrainOptions, dir: &Path) -> io::Result<StagedMesh> {
        let mut positions = PositionFile::create(dir)?;
        let mut triangles = RecordFile::<[u32; 3]>::create(dir)?;
        self.for_each_mesh_element(options, |p| positions.push(&p), |t| triangles.push(&t))?;
        let (positions, triangles) = (positions.finish()?, triangles.finish()?);
        Ok(StagedMesh {
            raw_vertices: positions.len(),
            raw_triangles: triangles.len(),
            welded_vertices: 0,
            degenerate_triangles: 0,
            duplicate_triangles: 0,
            unreferenced_vertices: 0,
            positions,
            triangles,
            attributes: VertexAttributes {
                normals: None,
                colors: None,
                uvs: None,
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_staged_mesh_is_the_mesh_in_memory() {
        // Holes of every kind: an interior sample, a corner, a whole row's run, a sample left
        // alone among missing ones; rows running south (mirrored triangles).
        let (columns, rows) = (7, 6);
        let mut heights: Vec<f32> = (0..columns * rows).map(|i| (i * 7 % 5) as f32).collect();
        for i in [8, 0, 22, 23, 24, 25, 37, 39, 31] {
            heights[i] = f32::NAN;
        }
        let mut grid = HeightGrid::unit(columns, rows, heights);
        grid.spacing = [0.1, -0.3];
        grid.origin = [5.0, 2.0];
        let options = TerrainOptions {
            spacing: None,
            vertical_exaggeration: 1.5,
        };
        let dir = tempfile::tempdir().unwrap();
        let staged = grid.stage(&options, dir.path()).unwrap();
        let in_memory = grid.to_mesh(&options);
        assert!(!in_memory.triangles.is_empty());
        assert_eq!(staged.load().unwrap(), in_memory);
        assert_eq!(staged.raw_vertices as usize, grid.valid_samples());
    }
}
