//! Height fields (digital elevation models): readers for the formats DEMs come in, the grid they
//! all produce, and the triangle mesh a grid becomes.
//!
//! | extension | format | reader |
//! |---|---|---|
//! | `.cdf`, `.nc` | netCDF-3 classic / 64-bit offset (ETOPO5, ETOPO20) | `netcdf.rs` |
//! | `.npy`, `.npz` | NumPy arrays (npz: a zip of them) | `npy.rs` |
//! | `.tif`, `.tiff` | GeoTIFF (pixel scale, tie point, model type, GDAL nodata) | `geotiff.rs` |
//! | `.png`, `.pgm` | 8/16-bit greyscale images | `image_grid.rs` |
//! | `.f32`, `.raw` | raw little-endian f32, dimensions given (`DemOptions::raw_size`) | `raw.rs` |
//! | `.json` | `{"width", "height", "values"}` | `raw.rs` |
//!
//! Missing cells (a format's nodata or fill value, NaN) become holes: no triangle touches them,
//! never a zero height. Every reader checks its counts against the file's size before it
//! allocates, and a bad file is an error naming the file and the problem.

mod error;
mod geotiff;
mod image_grid;
mod mesh;
mod netcdf;
mod npy;
mod raw;
pub mod write;

use std::path::Path;

pub use error::{DemError, DemErrorKind};

/// Metres per degree on the equator: geographic grids are drawn as plate carrée in metres, so
/// heights in metres and horizontal positions share a unit.
pub const METRES_PER_DEGREE: f64 = 111_319.490_793;

/// A regular grid of heights, as a reader found it.
#[derive(Clone, Debug, PartialEq)]
pub struct HeightGrid {
    /// Samples per row.
    pub columns: usize,
    /// Rows.
    pub rows: usize,
    /// Heights row by row, row 0 first; NaN marks a missing cell.
    pub heights: Vec<f32>,
    /// Horizontal position of sample (row 0, column 0), in the grid's units.
    pub origin: [f64; 2],
    /// Step from one column to the next (x) and from one row to the next (y), in the grid's
    /// units; either may be negative (rows running south, say).
    pub spacing: [f64; 2],
    /// x and y are longitude and latitude in degrees.
    pub geographic: bool,
}

/// What a reader may need besides the file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DemOptions {
    /// Columns and rows of a raw f32 file.
    pub raw_size: Option<(usize, usize)>,
    /// The variable (netCDF) or array (npz) to read; by default the only 2-D one, or the
    /// largest.
    pub variable: Option<String>,
}

/// The file formats [`load_dem`] reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DemFormat {
    NetCdf,
    Npy,
    Npz,
    GeoTiff,
    Png,
    Pgm,
    RawF32,
    JsonGrid,
}

/// Extensions recognised as height fields (for messages).
pub const DEM_EXTENSIONS: &str =
    ".cdf, .nc, .npy, .npz, .tif, .tiff, .png, .pgm, .f32, .raw, .json";

impl DemFormat {
    /// The format of `path` from its extension (case-insensitive).
    pub fn from_path(path: &Path) -> Option<DemFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "cdf" | "nc" => DemFormat::NetCdf,
            "npy" => DemFormat::Npy,
            "npz" => DemFormat::Npz,
            "tif" | "tiff" => DemFormat::GeoTiff,
            "png" => DemFormat::Png,
            "pgm" => DemFormat::Pgm,
            "f32" | "raw" => DemFormat::RawF32,
            "json" => DemFormat::JsonGrid,
            _ => return None,
        })
    }
}

/// Reads the height field at `path`, its format chosen by the extension.
pub fn load_dem(path: &Path, options: &DemOptions) -> Result<HeightGrid, DemError> {
    let format = dem_format(path)?;
    if format == DemFormat::Npy {
        // Read a chunk at a time: the file's bytes and the grid are never held together.
        let error = |kind| DemError::new(path, kind);
        let (mut input, len) = open_buffered(path)?;
        let grid = npy::read_npy_from(&mut input, len).map_err(error)?;
        grid.validate().map_err(error)?;
        return Ok(grid);
    }
    let bytes = std::fs::read(path).map_err(|e| DemError::new(path, DemErrorKind::Io(e)))?;
    read_dem(format, &bytes, options).map_err(|kind| DemError::new(path, kind))
}

/// Stages the mesh of the height field at `path` in `dir` a row at a time, its grid never held
/// whole, where its format allows: a `.npy` stored row by row (C order; what `tessera gen
/// terrain` writes) and a raw f32 file (`dem`'s `raw_size`). Returns the grid's placement (no
/// heights) and the staged mesh — the same files as [`HeightGrid::stage`] of [`load_dem`]'s
/// grid — or `None` for any other file.
pub fn stage_dem_by_rows(
    path: &Path,
    dem: &DemOptions,
    options: &TerrainOptions,
    dir: &Path,
) -> Result<Option<(HeightGrid, crate::external::StagedMesh)>, DemError> {
    let error = |kind| DemError::new(path, kind);
    let format = dem_format(path)?;
    if !matches!(format, DemFormat::Npy | DemFormat::RawF32) {
        return Ok(None);
    }
    let (input, len) = open_buffered(path)?;
    let mut rows = if format == DemFormat::RawF32 {
        let (columns, rows) = raw::f32_grid_size(dem, len).map_err(error)?;
        npy::raw_f32_rows(input, columns, rows)
    } else {
        match npy::npy_rows(input, len).map_err(error)? {
            Some(rows) => rows,
            None => return Ok(None),
        }
    };
    let grid = HeightGrid::unit(rows.columns(), rows.rows(), Vec::new());
    let staged = mesh::stage_rows(&grid, options, dir, |row| rows.next_row(row)).map_err(error)?;
    Ok(Some((grid, staged)))
}

/// The file at `path`, buffered for reading a chunk at a time, and its length.
fn open_buffered(path: &Path) -> Result<(std::io::BufReader<std::fs::File>, u64), DemError> {
    let io = |e| DemError::new(path, DemErrorKind::Io(e));
    let file = std::fs::File::open(path).map_err(io)?;
    let len = file.metadata().map_err(io)?.len();
    Ok((std::io::BufReader::with_capacity(1 << 16, file), len))
}

/// Reads a height field from `bytes` held in memory as if they were the file `name` (format
/// from its extension): the same readers and checks as [`load_dem`], and errors name `name`.
pub fn load_dem_bytes(
    name: &Path,
    bytes: &[u8],
    options: &DemOptions,
) -> Result<HeightGrid, DemError> {
    let format = dem_format(name)?;
    read_dem(format, bytes, options).map_err(|kind| DemError::new(name, kind))
}

/// The format of `path`, or the error naming the extensions read.
fn dem_format(path: &Path) -> Result<DemFormat, DemError> {
    DemFormat::from_path(path).ok_or_else(|| {
        DemError::new(
            path,
            DemErrorKind::Format(format!(
                "not a height-field extension; supported: {DEM_EXTENSIONS}"
            )),
        )
    })
}

/// The reader of `format`, then the grid's invariants ([`HeightGrid::validate`]).
fn read_dem(
    format: DemFormat,
    bytes: &[u8],
    options: &DemOptions,
) -> Result<HeightGrid, DemErrorKind> {
    let grid = match format {
        DemFormat::NetCdf => netcdf::read(bytes, options),
        DemFormat::Npy => npy::read_npy(bytes),
        DemFormat::Npz => npy::read_npz(bytes, options),
        DemFormat::GeoTiff => geotiff::read(bytes),
        DemFormat::Png => image_grid::read_png(bytes),
        DemFormat::Pgm => image_grid::read_pgm(bytes),
        DemFormat::RawF32 => raw::read_f32(bytes, options),
        DemFormat::JsonGrid => raw::read_json(bytes),
    }?;
    grid.validate()?;
    Ok(grid)
}

/// The error of an infinite height.
pub(crate) fn infinite_sample(row: usize, column: usize, index: usize) -> DemErrorKind {
    DemErrorKind::Format(format!(
        "sample {index} (row {row}, column {column}) is infinite"
    ))
}

/// How a grid becomes a mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TerrainOptions {
    /// Horizontal spacing in metres, replacing the grid's (for grids without georeferencing).
    pub spacing: Option<f64>,
    /// Heights are multiplied by this.
    pub vertical_exaggeration: f64,
}

impl Default for TerrainOptions {
    fn default() -> Self {
        TerrainOptions {
            spacing: None,
            vertical_exaggeration: 1.0,
        }
    }
}

impl HeightGrid {
    /// A grid with its samples one unit apart from (0, 0), not geographic: what a format
    /// without georeferencing gives (`TerrainOptions::spacing` scales it).
    pub fn unit(columns: usize, rows: usize, heights: Vec<f32>) -> HeightGrid {
        HeightGrid {
            columns,
            rows,
            heights,
            origin: [0.0, 0.0],
            spacing: [1.0, 1.0],
            geographic: false,
        }
    }

    /// Checks the invariants every reader promises: a non-empty grid whose heights fill it,
    /// finite spacing and origin, no infinite height.
    pub fn validate(&self) -> Result<(), DemErrorKind> {
        let cells = self.columns.checked_mul(self.rows);
        if cells != Some(self.heights.len()) {
            return Err(DemErrorKind::Format(format!(
                "a {} × {} grid with {} heights: need one height per sample",
                self.columns,
                self.rows,
                self.heights.len()
            )));
        }
        self.validate_placement()?;
        if let Some(i) = self.heights.iter().position(|h| h.is_infinite()) {
            return Err(infinite_sample(i / self.columns, i % self.columns, i));
        }
        if self.heights.iter().all(|h| h.is_nan()) {
            return Err(DemErrorKind::Format("every sample is missing".into()));
        }
        Ok(())
    }

    /// [`Self::validate`]'s checks that need no height: at least 2 × 2 samples, a finite
    /// placement whose every sample lies at a finite position.
    pub fn validate_placement(&self) -> Result<(), DemErrorKind> {
        // No height count here: a grid read by rows has none yet (its heights are not held).
        if self.columns < 2 || self.rows < 2 {
            return Err(DemErrorKind::Format(format!(
                "a {} × {} grid: need at least 2 × 2 samples",
                self.columns, self.rows
            )));
        }
        let finite = |v: [f64; 2]| v.iter().all(|x| x.is_finite());
        if !finite(self.origin) || !finite(self.spacing) || self.spacing.contains(&0.0) {
            return Err(DemErrorKind::Format(format!(
                "origin {:?} / spacing {:?} must be finite, spacing non-zero",
                self.origin, self.spacing
            )));
        }
        // Every sample's position, as `to_mesh` computes it (in metres for geographic grids),
        // is finite: the farthest one in each axis is, and the others lie between it and the
        // origin.
        let (origin, step) = self.placement(&TerrainOptions::default());
        let far = [
            origin[0] + (self.columns - 1) as f64 * step[0],
            origin[1] + (self.rows - 1) as f64 * step[1],
        ];
        if !finite(origin) || !finite(far) {
            return Err(DemErrorKind::Format(format!(
                "origin {:?} / spacing {:?}{}: the grid's far corner lies at {far:?}, not a \
                 finite position",
                self.origin,
                self.spacing,
                if self.geographic { " degrees" } else { "" }
            )));
        }
        Ok(())
    }

    /// Samples that hold a height.
    pub fn valid_samples(&self) -> usize {
        self.heights.iter().filter(|h| !h.is_nan()).count()
    }

    /// Where the mesh's samples lie: the position (x, y) of sample (row 0, column 0) and the
    /// step per column and per row, in metres for geographic grids (plate carrée), else in the
    /// grid's units; `options.spacing` replaces both (origin 0, signs kept).
    pub fn placement(&self, options: &TerrainOptions) -> ([f64; 2], [f64; 2]) {
        let unit = if self.geographic && options.spacing.is_none() {
            METRES_PER_DEGREE
        } else {
            1.0
        };
        match options.spacing {
            Some(s) => (
                [0.0, 0.0],
                [s * self.spacing[0].signum(), s * self.spacing[1].signum()],
            ),
            None => (
                self.origin.map(|o| o * unit),
                self.spacing.map(|s| s * unit),
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::InputMesh;

    fn signed_area(mesh: &InputMesh, t: [u32; 3]) -> f64 {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    }

    #[test]
    fn a_full_grid_has_two_triangles_per_cell_counter_clockwise() {
        let mesh = HeightGrid::unit(4, 3, (0..12).map(|i| i as f32).collect())
            .to_mesh(&Default::default());
        assert_eq!(mesh.positions.len(), 12);
        assert_eq!(mesh.triangles.len(), 2 * 3 * 2);
        assert!(mesh.triangles.iter().all(|&t| signed_area(&mesh, t) > 0.0));
        assert_eq!(mesh.positions[5], [1.0, 1.0, 5.0]);
        // Rows running south (negative y step) keep the orientation.
        let mut south = HeightGrid::unit(4, 3, vec![0.0; 12]);
        south.spacing = [1.0, -1.0];
        let mesh = south.to_mesh(&Default::default());
        assert!(mesh.triangles.iter().all(|&t| signed_area(&mesh, t) > 0.0));
    }

    #[test]
    fn missing_samples_are_holes_not_zeros() {
        let mut heights = vec![1.0; 16];
        heights[5] = f32::NAN; // an interior sample of a 4 × 4 grid
        let mesh = HeightGrid::unit(4, 4, heights).to_mesh(&Default::default());
        assert_eq!(mesh.positions.len(), 15);
        assert!(mesh.positions.iter().all(|p| p[2] == 1.0));
        // Each of the four cells around the sample keeps one triangle, of its 3 present
        // corners: 18 − 4.
        assert_eq!(mesh.triangles.len(), 18 - 4);
        assert!(mesh.triangles.iter().all(|&t| signed_area(&mesh, t) > 0.0));
    }

    #[test]
    fn geographic_grids_are_plate_carree_in_metres() {
        let mut g = HeightGrid::unit(2, 2, vec![0.0, 1.0, 2.0, 3.0]);
        g.geographic = true;
        g.origin = [10.0, -5.0];
        g.spacing = [0.5, 0.25];
        let mesh = g.to_mesh(&TerrainOptions {
            vertical_exaggeration: 2.0,
            ..Default::default()
        });
        assert_eq!(
            mesh.positions[3],
            [10.5 * METRES_PER_DEGREE, -4.75 * METRES_PER_DEGREE, 6.0]
        );
        let mesh = g.to_mesh(&TerrainOptions {
            spacing: Some(30.0),
            vertical_exaggeration: 1.0,
        });
        assert_eq!(mesh.positions[3], [30.0, 30.0, 3.0]);
    }

    #[test]
    fn bytes_read_like_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let json = br#"{"width": 2, "height": 2, "values": [1, 2, 3, 4], "spacing": 5}"#;
        let path = dir.path().join("g.json");
        std::fs::write(&path, json).unwrap();
        let options = DemOptions::default();
        let grid = load_dem_bytes(Path::new("g.json"), json, &options).unwrap();
        assert_eq!(grid, load_dem(&path, &options).unwrap());
        assert_eq!(grid.spacing, [5.0, 5.0]);
        let e = load_dem_bytes(Path::new("g.json"), b"{", &options).unwrap_err();
        assert!(e.to_string().starts_with("g.json: JSON"), "{e}");
        let e = load_dem_bytes(Path::new("g.xyz"), json, &options).unwrap_err();
        assert!(
            e.to_string().contains("not a height-field extension"),
            "{e}"
        );
    }

    #[test]
    fn a_npy_file_streamed_reads_like_its_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let options = DemOptions::default();
        // More values than a chunk, in a type that rounds (i32 to f32), both orders.
        let (rows, columns) = (300usize, 257usize);
        let values: Vec<i32> = (0..rows * columns)
            .map(|i| (i as i32).wrapping_mul(2_654_435_761u32 as i32) >> 3)
            .collect();
        let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let shape = format!("({rows}, {columns})");
        let c_order = npy::tests::npy("<i4", &shape, &data);
        let mut fortran = npy::tests::npy("<i4", &format!("({columns}, {rows})"), &data);
        let at = fortran.windows(5).position(|w| w == b"False").unwrap();
        fortran[at..at + 5].copy_from_slice(b"True ");
        for (name, bytes) in [("c.npy", &c_order), ("f.npy", &fortran)] {
            let path = dir.path().join(name);
            std::fs::write(&path, bytes).unwrap();
            let from_bytes = load_dem_bytes(Path::new(name), bytes, &options).unwrap();
            assert_eq!(load_dem(&path, &options).unwrap(), from_bytes, "{name}");
            assert_eq!(from_bytes.heights.len(), rows * columns);
            // Cut short: the same error both ways, naming the file.
            let short = &bytes[..bytes.len() - 3];
            std::fs::write(&path, short).unwrap();
            let e = load_dem(&path, &options).unwrap_err().to_string();
            let b = load_dem_bytes(&path, short, &options)
                .unwrap_err()
                .to_string();
            assert_eq!(e, b);
            assert!(e.contains(name) && e.contains("too large"), "{e}");
        }
        let c = load_dem_bytes(Path::new("c.npy"), &c_order, &options).unwrap();
        assert_eq!(c.heights[1], values[1] as f32);
        let f = load_dem_bytes(Path::new("f.npy"), &fortran, &options).unwrap();
        // Column-major, shape (columns, rows): row 0, column 1 is value 1 × columns.
        assert_eq!((f.rows, f.columns), (columns, rows));
        assert_eq!(f.heights[1], values[columns] as f32);
    }

    #[test]
    fn validation_refuses_what_cannot_be_a_terrain() {
        assert!(HeightGrid::unit(1, 5, vec![0.0; 5]).validate().is_err());
        assert!(HeightGrid::unit(2, 2, vec![0.0; 3]).validate().is_err());
        assert!(HeightGrid::unit(2, 2, vec![f32::NAN; 4])
            .validate()
            .is_err());
        assert!(HeightGrid::unit(2, 2, vec![0.0, f32::INFINITY, 0.0, 0.0])
            .validate()
            .is_err());
        let mut g = HeightGrid::unit(2, 2, vec![0.0; 4]);
        g.spacing = [0.0, 1.0];
        assert!(g.validate().is_err());
        // Finite origin and spacing whose far corner is not: beyond f64, or beyond it once
        // degrees become metres.
        let mut g = HeightGrid::unit(3, 2, vec![0.0; 6]);
        g.origin = [1e308, 0.0];
        g.spacing = [1e308, 1.0];
        assert!(g.validate().is_err());
        g.origin = [1e304, 0.0];
        g.spacing = [1.0, 1.0];
        assert!(g.validate().is_ok());
        g.geographic = true;
        assert!(g.validate().is_err());
        assert!(HeightGrid::unit(2, 2, vec![0.0; 4]).validate().is_ok());
    }
}
