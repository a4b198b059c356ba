//! The triangle mesh a height grid becomes: one vertex per sample with a height, two triangles
//! per cell whose four corners have heights, one per cell with exactly three (missing samples
//! are holes). Made a row at a time (two rows of vertex ids), so that under a memory budget it
//! is staged on disk as it is made (`stage`) instead of held (`to_mesh`): the same vertices,
//! ids and triangles either way.

use std::io;
use std::path::Path;

use super::{infinite_sample, DemErrorKind, HeightGrid, TerrainOptions};
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
        let mut mesher = RowMesher::new(self, options);
        for row in self.heights.chunks_exact(self.columns) {
            mesher.row(row, &mut vertex, &mut triangle)?;
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
        Ok(unwelded(positions, triangles))
    }
}

/// A grid's staged mesh: nothing welded or removed, no attributes.
fn unwelded(positions: PositionFile, triangles: RecordFile<[u32; 3]>) -> StagedMesh {
    StagedMesh {
        raw_vertices: positions.len(),
        raw_triangles: triangles.len(),
        welded_vertices: 0,
        degenerate_triangles: 0,
        duplicate_triangles: 0,
        unreferenced_vertices: 0,
        textures: None,
        missing_textures: Vec::new(),
        positions,
        triangles,
        attributes: VertexAttributes {
            normals: None,
            colors: None,
            uvs: None,
        },
    }
}

/// The mesh of a grid made a row of samples at a time: the vertex ids of the row above and of
/// this one are all it keeps.
pub(crate) struct RowMesher {
    columns: usize,
    origin: [f64; 2],
    spacing: [f64; 2],
    exaggeration: f64,
    /// Counter-clockwise from above when x grows with the column and y with the row;
    /// mirrored otherwise.
    flip: bool,
    /// Vertex ids of the row above and of this row (u32::MAX: missing).
    above: Vec<u32>,
    here: Vec<u32>,
    next_id: u32,
    row: usize,
}

impl RowMesher {
    /// For `grid`'s placement (its heights unused).
    pub(crate) fn new(grid: &HeightGrid, options: &TerrainOptions) -> RowMesher {
        let (origin, spacing) = grid.placement(options);
        RowMesher {
            columns: grid.columns,
            origin,
            spacing,
            exaggeration: options.vertical_exaggeration,
            flip: (spacing[0] < 0.0) != (spacing[1] < 0.0),
            above: vec![u32::MAX; grid.columns],
            here: vec![u32::MAX; grid.columns],
            next_id: 0,
            row: 0,
        }
    }

    /// Hands the row's vertices (missing samples skipped) and the triangles of the cells
    /// between it and the row above to `vertex` and `triangle`.
    pub(crate) fn row<E>(
        &mut self,
        heights: &[f32],
        vertex: &mut impl FnMut([f64; 3]) -> Result<(), E>,
        triangle: &mut impl FnMut([u32; 3]) -> Result<(), E>,
    ) -> Result<(), E> {
        let (r, flip) = (self.row, self.flip);
        let mut push = |t: [u32; 3]| {
            if t.iter().all(|&v| v != u32::MAX) {
                triangle(if flip { [t[0], t[2], t[1]] } else { t })
            } else {
                Ok(())
            }
        };
        for (c, &h) in heights.iter().enumerate() {
            self.here[c] = u32::MAX;
            if !h.is_nan() {
                self.here[c] = self.next_id;
                self.next_id += 1;
                vertex([
                    self.origin[0] + c as f64 * self.spacing[0],
                    self.origin[1] + r as f64 * self.spacing[1],
                    h as f64 * self.exaggeration,
                ])?;
            }
        }
        if r > 0 {
            for c in 0..self.columns - 1 {
                let (a, b, d, e) = (
                    self.above[c],
                    self.above[c + 1],
                    self.here[c],
                    self.here[c + 1],
                );
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
        std::mem::swap(&mut self.above, &mut self.here);
        self.row += 1;
        Ok(())
    }
}

/// The mesh of the grid whose placement `grid` gives (its heights unused: they come from
/// `next_row`, a row at a time), staged on disk in `dir` as it is made: the same files as
/// [`HeightGrid::stage`] of the whole grid, which is never held. The rows are checked as
/// [`HeightGrid::validate`] checks a grid (no infinite height, not every sample missing,
/// exactly `grid.rows` rows).
pub fn stage_rows(
    grid: &HeightGrid,
    options: &TerrainOptions,
    dir: &Path,
    mut next_row: impl FnMut(&mut Vec<f32>) -> Result<bool, DemErrorKind>,
) -> Result<StagedMesh, DemErrorKind> {
    let io = DemErrorKind::Io;
    grid.validate_placement()?;
    let mut positions = PositionFile::create(dir).map_err(io)?;
    let mut triangles = RecordFile::<[u32; 3]>::create(dir).map_err(io)?;
    let mut mesher = RowMesher::new(grid, options);
    let (mut row, mut rows) = (Vec::with_capacity(grid.columns), 0);
    while next_row(&mut row)? {
        if rows == grid.rows || row.len() != grid.columns {
            return Err(DemErrorKind::Format(format!(
                "row {rows} of a {} × {} grid holds {} samples",
                grid.columns,
                grid.rows,
                row.len()
            )));
        }
        if let Some(c) = row.iter().position(|h| h.is_infinite()) {
            return Err(infinite_sample(rows, c, rows * grid.columns + c));
        }
        mesher
            .row(&row, &mut |p| positions.push(&p), &mut |t| {
                triangles.push(&t)
            })
            .map_err(io)?;
        rows += 1;
    }
    if rows != grid.rows {
        return Err(DemErrorKind::Format(format!(
            "{rows} rows of a {} × {} grid",
            grid.columns, grid.rows
        )));
    }
    let (positions, triangles) = (
        positions.finish().map_err(io)?,
        triangles.finish().map_err(io)?,
    );
    if positions.is_empty() {
        return Err(DemErrorKind::Format("every sample is missing".into()));
    }
    Ok(unwelded(positions, triangles))
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

    #[test]
    fn a_npy_staged_by_rows_is_the_grid_staged_whole() {
        let (columns, rows) = (9, 7);
        let mut heights: Vec<f32> = (0..columns * rows).map(|i| (i * 5 % 7) as f32).collect();
        for i in [0, 10, 11, 12, 30, 62] {
            heights[i] = f32::NAN;
        }
        let grid = HeightGrid::unit(columns, rows, heights);
        let options = TerrainOptions {
            spacing: Some(30.0),
            vertical_exaggeration: 2.0,
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.npy");
        std::fs::write(&path, crate::dem::write::npy_bytes(&grid)).unwrap();
        let (placed, by_rows) =
            crate::dem::stage_dem_by_rows(&path, &Default::default(), &options, dir.path())
                .unwrap()
                .expect("a C-order .npy is read by rows");
        assert_eq!((placed.columns, placed.rows), (columns, rows));
        let whole = grid.stage(&options, dir.path()).unwrap();
        assert_eq!(by_rows.raw_vertices, whole.raw_vertices);
        assert_eq!(by_rows.load().unwrap(), whole.load().unwrap());

        // Checked as a grid read whole is: an infinite height, a truncated file, every
        // sample missing.
        let message = |grid: &HeightGrid, cut: usize| {
            let mut bytes = crate::dem::write::npy_bytes(grid);
            bytes.truncate(bytes.len() - cut);
            std::fs::write(&path, bytes).unwrap();
            let staged =
                crate::dem::stage_dem_by_rows(&path, &Default::default(), &options, dir.path());
            let whole = crate::dem::load_dem(&path, &Default::default());
            (
                staged.err().unwrap().to_string(),
                whole.err().unwrap().to_string(),
            )
        };
        let mut infinite = grid.clone();
        infinite.heights[40] = f32::INFINITY;
        let (rows_message, whole_message) = message(&infinite, 0);
        assert_eq!(rows_message, whole_message);
        assert!(rows_message.contains("sample 40 (row 4, column 4) is infinite"));
        let (rows_message, whole_message) = message(&grid, 4);
        assert!(rows_message.contains("g.npy"), "{rows_message}");
        assert!(whole_message.contains("g.npy"), "{whole_message}");
        let missing = HeightGrid::unit(columns, rows, vec![f32::NAN; columns * rows]);
        let (rows_message, whole_message) = message(&missing, 0);
        assert_eq!(rows_message, whole_message);
    }

    #[test]
    fn a_raw_f32_file_staged_by_rows_is_the_grid_staged_whole() {
        let (columns, rows) = (6, 5);
        let mut heights: Vec<f32> = (0..columns * rows).map(|i| (i * 3 % 11) as f32).collect();
        for i in [0, 7, 8, 29] {
            heights[i] = f32::NAN;
        }
        let raw =
            |heights: &[f32]| -> Vec<u8> { heights.iter().flat_map(|h| h.to_le_bytes()).collect() };
        let options = TerrainOptions {
            spacing: Some(10.0),
            vertical_exaggeration: 1.5,
        };
        let dem = crate::dem::DemOptions {
            raw_size: Some((columns, rows)),
            ..Default::default()
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.f32");
        std::fs::write(&path, raw(&heights)).unwrap();
        let (placed, by_rows) = crate::dem::stage_dem_by_rows(&path, &dem, &options, dir.path())
            .unwrap()
            .expect("a raw f32 file is read by rows");
        assert_eq!((placed.columns, placed.rows), (columns, rows));
        let grid = crate::dem::load_dem(&path, &dem).unwrap();
        let whole = grid.stage(&options, dir.path()).unwrap();
        assert_eq!(by_rows.raw_vertices, whole.raw_vertices);
        assert_eq!(by_rows.load().unwrap(), whole.load().unwrap());

        // The whole-grid reader's errors: a file a sample short and one a sample long, no size
        // given, a grid of one sample, an infinite height.
        let messages = |bytes: Vec<u8>, dem: &crate::dem::DemOptions| {
            std::fs::write(&path, bytes).unwrap();
            let staged = crate::dem::stage_dem_by_rows(&path, dem, &options, dir.path());
            let whole = crate::dem::load_dem(&path, dem);
            (
                staged.err().unwrap().to_string(),
                whole.err().unwrap().to_string(),
            )
        };
        let (rows_message, whole_message) = messages(raw(&heights[1..]), &dem);
        assert_eq!(rows_message, whole_message);
        assert!(
            rows_message.contains("the file has 116 bytes"),
            "{rows_message}"
        );
        let long = raw(&[&heights[..], &[1.0]].concat());
        let (rows_message, whole_message) = messages(long, &dem);
        assert_eq!(rows_message, whole_message);
        assert!(
            rows_message.contains("124 bytes is not 6 × 5"),
            "{rows_message}"
        );
        let (rows_message, whole_message) = messages(raw(&heights), &Default::default());
        assert_eq!(rows_message, whole_message);
        assert!(rows_message.contains("--raw-size"), "{rows_message}");
        let single = crate::dem::DemOptions {
            raw_size: Some((1, 1)),
            ..Default::default()
        };
        let (rows_message, whole_message) = messages(raw(&[1.0]), &single);
        assert_eq!(rows_message, whole_message);
        assert!(
            rows_message.contains("need at least 2 × 2"),
            "{rows_message}"
        );
        let mut infinite = heights.clone();
        infinite[13] = f32::INFINITY;
        let (rows_message, whole_message) = messages(raw(&infinite), &dem);
        assert_eq!(rows_message, whole_message);
        assert!(rows_message.contains("is infinite"), "{rows_message}");
    }
}
