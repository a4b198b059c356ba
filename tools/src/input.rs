//! What `build` (and the benchmarks) accept as input: a mesh file, or a height field (DEM)
//! recognised by its extension, which builds on the 2D hierarchy; `-`: a PLY on standard input.

use std::io::IsTerminal;
use std::path::Path;

use anyhow::{bail, Context};
use clap::Args;
use serde_json::json;
use tessera_preprocess::checkpoint::{Fingerprint, StreamFingerprint};
use tessera_preprocess::dem::{
    load_dem, stage_dem_by_rows, DemFormat, DemOptions, HeightGrid, TerrainOptions,
};
use tessera_preprocess::import::{
    load_mesh_from_reader, load_mesh_with, ImportError, ImportErrorKind, ImportOptions,
    ImportReport, MeshFormat,
};
use tessera_preprocess::texture_input::MeshTextures;
use tessera_preprocess::{Domain, InputMesh};

/// Height-field options of the commands that read an input.
#[derive(Args, Clone, Debug, Default)]
pub struct HeightFieldArgs {
    /// Build the 2D hierarchy (height field, z up) even for a mesh file; DEM files (.cdf, .nc,
    /// .npy, .npz, .tif, .tiff, .png, .pgm, .f32, .raw, .json) always build it.
    #[arg(long)]
    pub heightfield: bool,
    /// Columns and rows of a raw little-endian f32 grid (.f32, .raw): WIDTHxHEIGHT.
    #[arg(long, value_name = "WxH", value_parser = parse_raw_size)]
    pub raw_size: Option<(usize, usize)>,
    /// The netCDF variable or npz array to read (default: the only 2-D one, or the largest).
    #[arg(long, value_name = "NAME")]
    pub variable: Option<String>,
    /// Horizontal spacing between samples in metres, replacing the grid's own (geographic
    /// grids default to plate carrée metres).
    #[arg(long, value_name = "METRES")]
    pub spacing: Option<f64>,
    /// Heights are multiplied by this.
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    pub exaggeration: f64,
}

fn parse_raw_size(s: &str) -> Result<(usize, usize), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, got {s:?}"))?;
    let w: usize = w.trim().parse().map_err(|e| format!("width {w:?}: {e}"))?;
    let h: usize = h.trim().parse().map_err(|e| format!("height {h:?}: {e}"))?;
    Ok((w, h))
}

/// An input ready to build.
pub struct LoadedInput {
    pub mesh: InputMesh,
    pub domain: Domain,
    /// The grid, for a DEM.
    pub grid: Option<GridFacts>,
    /// One line about what was read.
    pub description: String,
    /// The mesh's textures (`ImportReport::textures`); `None` for a height field.
    pub textures: Option<MeshTextures>,
    /// Texture files the mesh names that do not exist.
    pub missing_textures: Vec<String>,
}

impl HeightFieldArgs {
    pub fn terrain_options(&self) -> anyhow::Result<TerrainOptions> {
        if let Some(s) = self.spacing {
            if !(s.is_finite() && s > 0.0) {
                bail!("--spacing {s}: must be a positive number of metres");
            }
        }
        if !(self.exaggeration.is_finite() && self.exaggeration != 0.0) {
            bail!(
                "--exaggeration {}: must be finite and non-zero",
                self.exaggeration
            );
        }
        Ok(TerrainOptions {
            spacing: self.spacing,
            vertical_exaggeration: self.exaggeration,
        })
    }

    fn dem_options(&self) -> DemOptions {
        DemOptions {
            raw_size: self.raw_size,
            variable: self.variable.clone(),
        }
    }

    /// Reads a height field (any DEM extension).
    pub fn load_grid(&self, path: &Path) -> anyhow::Result<HeightGrid> {
        Ok(load_dem(path, &self.dem_options())?)
    }
}

/// Reads `path`: a DEM by extension (2D hierarchy), else a mesh (3D, or 2D with
/// `--heightfield`); `-` reads a PLY mesh from standard input.
pub fn load_input(path: &Path, args: &HeightFieldArgs) -> anyhow::Result<LoadedInput> {
    load_input_staged(path, args, None)
}

/// [`load_input`]; with `staging` (temporary directory, memory budget in bytes), a mesh file
/// is imported out of core (`import::stage_mesh`: streamed to disk and welded by external
/// sorts, the same mesh) before it is read into memory.
pub fn load_input_staged(
    path: &Path,
    args: &HeightFieldArgs,
    staging: Option<(&Path, u64)>,
) -> anyhow::Result<LoadedInput> {
    load_input_with(path, args, staging, &ImportOptions::default())
}

/// [`load_input_staged`] with the importers' `import` options (textures or not).
pub fn load_input_with(
    path: &Path,
    args: &HeightFieldArgs,
    staging: Option<(&Path, u64)>,
    import: &ImportOptions,
) -> anyhow::Result<LoadedInput> {
    let options = args.terrain_options()?;
    if DemFormat::from_path(path).is_some() {
        let grid = args.load_grid(path)?;
        let mesh = grid.to_mesh(&options);
        let facts = GridFacts::of(&grid);
        let description = height_field_description(path, &facts, mesh.triangles.len())?;
        return Ok(LoadedInput {
            mesh,
            domain: Domain::HeightField,
            grid: Some(facts),
            description,
            textures: None,
            missing_textures: Vec::new(),
        });
    }
    if args.raw_size.is_some() || args.variable.is_some() || args.spacing.is_some() {
        bail!(
            "{}: --raw-size, --variable and --spacing apply to height-field files only ({})",
            path.display(),
            tessera_preprocess::dem::DEM_EXTENSIONS
        );
    }
    if is_stdin(path) && std::io::stdin().is_terminal() {
        bail!("standard input is a terminal: pipe a PLY mesh into `-`");
    }
    let report = read_mesh(path, staging, import).map_err(import_error)?;
    let domain = mesh_domain(args);
    let mut mesh = report.mesh;
    if options.vertical_exaggeration != 1.0 {
        for p in &mut mesh.positions {
            p[2] *= options.vertical_exaggeration;
        }
    }
    let description = format!(
        "mesh ({} triangles, {} vertices)",
        mesh.triangles.len(),
        mesh.positions.len()
    );
    Ok(LoadedInput {
        mesh,
        domain,
        grid: None,
        description,
        textures: report.textures,
        missing_textures: report.missing_textures,
    })
}

/// What `build` builds from: the input in memory, or a mesh staged on disk and never loaded
/// (`build --memory` with a mesh file or `-`: `build_repository_staged`).
pub enum BuildInput {
    Loaded(LoadedInput),
    Staged {
        staged: tessera_preprocess::external::StagedMesh,
        domain: Domain,
        /// A height field's grid.
        grid: Option<GridFacts>,
        description: String,
    },
    /// Nothing read: the build continues from its checkpoint's simplification state (the
    /// input's textures found again, `import::find_textures`).
    Resumed {
        domain: Domain,
        description: String,
        textures: Option<MeshTextures>,
        missing_textures: Vec<String>,
    },
}

impl BuildInput {
    pub fn domain(&self) -> Domain {
        match self {
            BuildInput::Loaded(input) => input.domain,
            BuildInput::Staged { domain, .. } | BuildInput::Resumed { domain, .. } => *domain,
        }
    }

    pub fn grid(&self) -> Option<&GridFacts> {
        match self {
            BuildInput::Loaded(input) => input.grid.as_ref(),
            BuildInput::Staged { grid, .. } => grid.as_ref(),
            BuildInput::Resumed { .. } => None,
        }
    }

    /// The input's textures (`None` without).
    pub fn textures(&self) -> Option<&MeshTextures> {
        match self {
            BuildInput::Loaded(input) => input.textures.as_ref(),
            BuildInput::Staged { staged, .. } => staged.textures.as_ref(),
            BuildInput::Resumed { textures, .. } => textures.as_ref(),
        }
    }

    /// Texture files the input names that do not exist.
    pub fn missing_textures(&self) -> &[String] {
        match self {
            BuildInput::Loaded(input) => &input.missing_textures,
            BuildInput::Staged { staged, .. } => &staged.missing_textures,
            BuildInput::Resumed {
                missing_textures, ..
            } => missing_textures,
        }
    }

    pub fn description(&self) -> &str {
        match self {
            BuildInput::Loaded(input) => &input.description,
            BuildInput::Staged { description, .. } | BuildInput::Resumed { description, .. } => {
                description
            }
        }
    }
}

/// `build`'s input: with `staging` (temporary directory, memory budget), a mesh file or `-` is
/// staged on disk and left there (a height field, or a mesh whose heights are exaggerated, is
/// loaded as [`load_input_staged`] does). Standard input staged is read to its end and
/// fingerprinted (for its checkpoint).
pub fn load_build_input(
    path: &Path,
    args: &HeightFieldArgs,
    staging: Option<(&Path, u64)>,
    import: &ImportOptions,
) -> anyhow::Result<(BuildInput, Option<Fingerprint>)> {
    // A height field under a budget: its mesh staged row by row as it is made (48 bytes a
    // sample in memory otherwise); a `.npy` or a raw f32 file read by rows too, any other grid
    // read whole first (4 bytes a sample).
    if let (Some((dir, _)), true) = (staging, DemFormat::from_path(path).is_some()) {
        let options = args.terrain_options()?;
        let (facts, staged) = match stage_dem_by_rows(path, &args.dem_options(), &options, dir)? {
            Some((placed, staged)) => {
                let facts = GridFacts {
                    valid_samples: staged.raw_vertices as usize,
                    ..GridFacts::of(&placed)
                };
                (facts, staged)
            }
            None => {
                let grid = args.load_grid(path)?;
                let staged = grid.stage(&options, dir)?;
                (GridFacts::of(&grid), staged)
            }
        };
        let description = height_field_description(path, &facts, staged.triangles.len() as usize)?;
        let input = BuildInput::Staged {
            staged,
            domain: Domain::HeightField,
            grid: Some(facts),
            description,
        };
        return Ok((input, None));
    }
    let plain_mesh = is_plain_mesh(path, args)?;
    let Some((dir, budget)) = staging.filter(|_| plain_mesh) else {
        return Ok((
            BuildInput::Loaded(load_input_with(path, args, staging, import)?),
            None,
        ));
    };
    let (staged, fingerprint) = if is_stdin(path) {
        if std::io::stdin().is_terminal() {
            bail!("standard input is a terminal: pipe a PLY mesh into `-`");
        }
        let stream = StreamFingerprint::default();
        let staged = tessera_preprocess::import::stage_ply_from_reader(
            stream.reader(std::io::stdin()),
            "standard input",
            dir,
            budget as usize,
        )?;
        // What the import left unread counts too: a resume reads the stream to its end.
        std::io::copy(&mut stream.reader(std::io::stdin()), &mut std::io::sink())
            .context("reading standard input")?;
        (staged, Some(stream.fingerprint()))
    } else {
        let staged =
            tessera_preprocess::import::stage_mesh_with(path, dir, budget as usize, import)
                .map_err(import_error)?;
        (staged, None)
    };
    Ok((staged_input(staged, args), fingerprint))
}

/// Gives an input without normals (a mesh, or a height field's mesh) angle-weighted vertex
/// normals (`normals.rs`), split at creases sharper than `crease_degrees` (180: none): in
/// memory, or out of core within `staging`'s budget for a staged mesh (the same wedges and
/// normals). A resumed build has the normals its checkpoint staged.
pub fn compute_missing_normals(
    input: &mut BuildInput,
    staging: Option<(&Path, u64)>,
    crease_degrees: f64,
) -> anyhow::Result<()> {
    if !(crease_degrees > 0.0 && crease_degrees <= 180.0) {
        bail!("--crease-angle {crease_degrees}: must be above 0 and at most 180 degrees");
    }
    let computed = match input {
        BuildInput::Loaded(loaded) => tessera_preprocess::normals::compute_missing_normals_creased(
            &mut loaded.mesh,
            crease_degrees,
        ),
        BuildInput::Staged { staged, .. }
            if staged.attributes.normals.is_none() && crease_degrees < 180.0 =>
        {
            let (dir, budget) = staging.expect("a staged mesh has a staging budget");
            tessera_preprocess::external::creased_normals::stage_creased_normals(
                staged,
                crease_degrees,
                budget as usize,
                dir,
            )
            .context("computing the vertex normals split at creases")?;
            true
        }
        BuildInput::Staged { staged, .. } if staged.attributes.normals.is_none() => {
            let (dir, budget) = staging.expect("a staged mesh has a staging budget");
            let normals = tessera_preprocess::external::vertex_normals::stage_vertex_normals(
                staged,
                budget as usize,
                dir,
            )
            .context("computing the vertex normals")?;
            staged.attributes.normals = Some(normals);
            true
        }
        _ => false,
    };
    if computed {
        let description = match input {
            BuildInput::Loaded(loaded) => &mut loaded.description,
            BuildInput::Staged { description, .. } => description,
            BuildInput::Resumed { description, .. } => description,
        };
        description.push_str("; vertex normals computed");
    }
    Ok(())
}

/// Whether `path` is a mesh built as it is (not a height field, no exaggeration): what
/// `build --memory` stages on disk, and what a checkpoint can resume.
pub fn is_plain_mesh(path: &Path, args: &HeightFieldArgs) -> anyhow::Result<bool> {
    let options = args.terrain_options()?;
    Ok(DemFormat::from_path(path).is_none()
        && options.vertical_exaggeration == 1.0
        && args.raw_size.is_none()
        && args.variable.is_none()
        && args.spacing.is_none())
}

/// A staged mesh as `build`'s input.
pub fn staged_input(
    staged: tessera_preprocess::external::StagedMesh,
    args: &HeightFieldArgs,
) -> BuildInput {
    let domain = mesh_domain(args);
    let description = format!(
        "mesh ({} triangles, {} vertices; staged on disk)",
        staged.triangles.len(),
        staged.positions.len()
    );
    BuildInput::Staged {
        staged,
        domain,
        grid: None,
        description,
    }
}

/// An importer's error; an unknown extension also lists the height-field ones.
fn import_error(e: ImportError) -> anyhow::Error {
    if matches!(e.kind, ImportErrorKind::UnsupportedExtension(_)) {
        anyhow::anyhow!(
            "{e}; height fields: {}",
            tessera_preprocess::dem::DEM_EXTENSIONS
        )
    } else {
        e.into()
    }
}

/// A mesh file builds the 3D hierarchy, or the 2D one with `--heightfield`.
pub fn mesh_domain(args: &HeightFieldArgs) -> Domain {
    if args.heightfield {
        Domain::HeightField
    } else {
        Domain::Volume
    }
}

/// Whether `path` means standard input (`-`).
pub fn is_stdin(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// A mesh file, or a PLY (ASCII or binary) on standard input for `-`: the same reader and
/// welding either way, so the same mesh.
fn read_mesh(
    path: &Path,
    staging: Option<(&Path, u64)>,
    import: &ImportOptions,
) -> Result<ImportReport, ImportError> {
    if is_stdin(path) {
        return load_mesh_from_reader(std::io::stdin(), MeshFormat::Ply, "standard input");
    }
    let Some((dir, budget)) = staging else {
        return load_mesh_with(path, import);
    };
    let staged = tessera_preprocess::import::stage_mesh_with(path, dir, budget as usize, import)?;
    let mesh = staged
        .load()
        .map_err(|e| tessera_preprocess::import::ImportErrorKind::Io(e).at_path(path))?;
    Ok(ImportReport {
        mesh,
        raw_vertices: staged.raw_vertices as usize,
        raw_triangles: staged.raw_triangles as usize,
        welded_vertices: staged.welded_vertices as usize,
        degenerate_triangles: staged.degenerate_triangles as usize,
        duplicate_triangles: staged.duplicate_triangles as usize,
        unreferenced_vertices: staged.unreferenced_vertices as usize,
        textures: staged.textures,
        missing_textures: staged.missing_textures,
    })
}

/// The grid part of `build --json` (null for a mesh).
/// What `build` reports of a height field's grid (its heights are not kept).
#[derive(Clone, Copy, Debug)]
pub struct GridFacts {
    pub columns: usize,
    pub rows: usize,
    pub valid_samples: usize,
    pub geographic: bool,
}

impl GridFacts {
    pub fn of(grid: &HeightGrid) -> GridFacts {
        GridFacts {
            columns: grid.columns,
            rows: grid.rows,
            valid_samples: grid.valid_samples(),
            geographic: grid.geographic,
        }
    }
}

/// "height field C × R (…)", or the error of a grid with no triangle.
fn height_field_description(
    path: &Path,
    grid: &GridFacts,
    triangles: usize,
) -> anyhow::Result<String> {
    if triangles == 0 {
        bail!(
            "{}: no cell of the {} × {} grid has three samples with heights",
            path.display(),
            grid.columns,
            grid.rows
        );
    }
    Ok(format!(
        "height field {} × {} ({} samples with heights, {triangles} triangles)",
        grid.columns, grid.rows, grid.valid_samples,
    ))
}

pub fn grid_json(grid: Option<&GridFacts>) -> serde_json::Value {
    match grid {
        Some(g) => json!({
            "columns": g.columns,
            "rows": g.rows,
            "valid_samples": g.valid_samples,
            "geographic": g.geographic,
        }),
        None => serde_json::Value::Null,
    }
}
