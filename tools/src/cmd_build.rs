//! `tessera build INPUT|- -o OUT.tsr [--leaf-triangles N | --levels L] [--threads N] [--json]`
//! `[--memory SIZE [--temp DIR] [--resume]] [--heightfield] [--raw-size WxH] [--variable NAME]`
//! `[--spacing M] [--exaggeration X] [--no-compress]`
//!
//! A mesh builds the 3D hierarchy (tetrahedra); a DEM (by extension) or `--heightfield` the 2D
//! one (right triangles over x, y).`

use std::path::PathBuf;
use std::time::Instant;

use crate::input::BuildInput;
use anyhow::Context;
use clap::Args;
use serde_json::json;
use tessera_core::repository::format::{PatchCodec, POSITION_BITS};
use tessera_preprocess::checkpoint::Checkpoint;
use tessera_preprocess::{
    build_repository, build_repository_checkpointed, build_repository_staged, BuildConfig,
    BuildSummary, Construction, Domain, MemoryBudget, SimplifySettings,
};

use crate::progress::Stages;
use crate::Outcome;

#[derive(Args)]
pub struct BuildArgs {
    /// Input mesh, or height field (DEM); `-` reads a PLY mesh from standard input.
    pub input: PathBuf,
    /// Output repository (written to a temporary file, then renamed).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Split leaves holding more than N triangles (adaptive construction; default 1024 for
    /// meshes, 256 for height fields).
    #[arg(long, value_name = "N", conflicts_with = "levels")]
    pub leaf_triangles: Option<usize>,
    /// Build a complete hierarchy of L levels instead.
    #[arg(long, value_name = "L")]
    pub levels: Option<u16>,
    /// Worker threads (default: one per core). With more than one, a build under `--memory`
    /// also runs one thread that reads the staged mesh ahead of the workers.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Memory budget (`512M`, `2G`): a mesh file is staged on disk and built out of core, each
    /// stage's working set sized to the budget; the repository is the same bytes either way.
    /// Some per-simplex and per-vertex tables are still held whatever the budget (100 M
    /// triangles need about 0.8 GiB: BENCHMARKS.md).
    #[arg(long, value_name = "SIZE", value_parser = parse_size)]
    pub memory: Option<u64>,
    /// Directory of the temporary files of `--memory` and of the build's checkpoint (default:
    /// the output's directory). The working files have no names; the checkpoint
    /// (`.OUT.tessera-build/`) is what a killed build leaves for `--resume`.
    #[arg(long, value_name = "DIR", requires = "memory")]
    pub temp: Option<PathBuf>,
    /// Store the patches as they are drawn instead of coded (positions predicted along the
    /// strip and rANS-coded with the strip and attributes, lossless; decoded by the loader):
    /// larger files, no decoding.
    #[arg(long)]
    pub no_compress: bool,
    /// Store no normals where the input has none: lit mode then shades with face normals.
    /// By default a mesh without normals, and a height field, gets angle-weighted vertex
    /// normals computed at build time (within the `--memory` budget where one is given).
    #[arg(long)]
    pub no_computed_normals: bool,
    /// Split computed normals at creases: around a vertex, faces meeting at more than DEG
    /// degrees get normals of their own (wedges of the vertex), so hard edges stay hard; 180
    /// (the default) splits nothing. The same bytes with `--memory`.
    #[arg(long, value_name = "DEG", default_value_t = 180.0)]
    pub crease_angle: f64,
    /// Store errors that are bounds: each diamond's error is an upper bound on the two-sided
    /// (Hausdorff) distance between its patches and the input surface, so a cut drawn at τ
    /// is within τ of the input everywhere. Slower to build, and the errors are larger than
    /// the default's estimates (ARCHITECTURE.md, "Stored errors")
    #[arg(long)]
    pub bounded_errors: bool,
    /// Weight of normals (unit vectors) against positions (model sizes) when diamonds are
    /// simplified, where the input has normals; 0 weighs them not at all
    #[arg(long, value_name = "W", default_value_t = SimplifySettings::default().normal_weight)]
    pub normal_weight: f32,
    /// Weight of colours (RGB in [0, 1]) against positions (model sizes) when diamonds are
    /// simplified, where the input has colours; 0 weighs them not at all
    #[arg(long, value_name = "W", default_value_t = SimplifySettings::default().colour_weight)]
    pub colour_weight: f32,
    /// Weight of texture coordinates (UV units) against positions (model sizes) when diamonds
    /// are simplified, where the input has them; 0 weighs them not at all
    #[arg(long, value_name = "W", default_value_t = SimplifySettings::default().uv_weight)]
    pub uv_weight: f32,
    /// Bits per axis of the position grid over the bounding box (1–21), applied while
    /// building instead of the grid chosen from the error: fewer make the repository smaller
    /// and every stored error larger by the grid's half-diagonal (printed, and
    /// `quantisation_error` in `--json`)
    #[arg(long, value_name = "BITS", conflicts_with_all = ["position_step", "lossless"],
          value_parser = clap::value_parser!(u32).range(1..=POSITION_BITS as i64))]
    pub position_bits: Option<u32>,
    /// The position grid's step at most STEP model units (the coarsest power-of-two multiple
    /// of the full lattice's step that is no coarser), instead of the default chosen from the
    /// error: Nexus's default step, 2^trunc(log2(0.05 e)) for e the smallest error of the
    /// first level of diamonds above the leaves. Every stored error grows by the grid's
    /// half-diagonal
    #[arg(long, value_name = "STEP", conflicts_with = "lossless",
          value_parser = positive_step)]
    pub position_step: Option<f64>,
    /// Keep the full 2^21 position lattice (no grid chosen from the error)
    #[arg(long)]
    pub lossless: bool,
    /// Continue the build of the same input, flags and output that was killed or failed, from
    /// its checkpoint (`.OUT.tessera-build/` beside the output or in `--temp`); the repository
    /// is the same bytes. Needs `--memory`; from standard input (`-`), the same stream piped
    /// again (it is read to its end and checked). Without `--resume` a leftover checkpoint is
    /// removed and the build starts over.
    #[arg(long)]
    pub resume: bool,
    /// End the process once stage STAGE is committed to the checkpoint (`staged`,
    /// `hierarchy`, `leaves`, or `level-N`: the first level checkpoint with at least N levels
    /// merged), exit 0 with no output written; `--resume` continues from there. A build then
    /// runs as several processes, a stage or more each (with `--json`: `{"stopped_after",
    /// "checkpoint"}`). A stage the build never reaches lets it finish.
    #[arg(long, value_name = "STAGE", requires = "memory",
          value_parser = crate::build_checkpoint::StopAfter::parse)]
    pub stop_after: Option<crate::build_checkpoint::StopAfter>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// Ignore the textures the input names (OBJ `map_Kd`, glTF `baseColorTexture`, PLY
    /// `comment TextureFile`): no texture section, texture coordinates as the file has them.
    #[arg(long)]
    pub no_textures: bool,
    /// How texture pages are stored: `bc1` (4 bits a texel, lossless it is not: `--json`
    /// reports its PSNR; 6.06 times smaller on disk and 7.95 times on the GPU, where the
    /// adapter samples BC1) or `rgba8` (32 bits a texel, lossless).
    #[arg(long, value_name = "ENCODING", default_value = "bc1", value_parser = parse_page_encoding)]
    pub texture_encoding: tessera_core::texture::PageEncoding,
    /// Report each stage's own peak resident memory in `--json` (Linux: resets the kernel's
    /// peak at each stage, so `/usr/bin/time` then reports only the last stage's peak; without
    /// this flag each stage's figure is the peak so far and external tools see the true peak).
    #[arg(long)]
    pub stage_peaks: bool,
    #[command(flatten)]
    pub heightfield: crate::input::HeightFieldArgs,
}

pub fn run(args: BuildArgs) -> anyhow::Result<Outcome> {
    let stages = Stages::new("build");
    let peaks = crate::peak_rss::StagePeaks::new(args.stage_peaks);
    tessera_preprocess::external::temp_usage::reset_peak();
    stages.stage("import");
    peaks.start("import");
    let start = Instant::now();
    let memory = match args.memory {
        None => None,
        Some(bytes) => {
            let temp_dir = crate::output::temp_dir_for(args.temp.as_deref(), &args.output)?;
            // Few allocator arenas, so what one worker frees another reuses (allocator.rs).
            tessera_preprocess::external::allocator::arenas_for_budget(bytes);
            Some(MemoryBudget { bytes, temp_dir })
        }
    };
    let staging = memory.as_ref().map(|m| (m.temp_dir.as_path(), m.bytes));
    // A mesh file staged under a budget keeps a checkpoint (`build_checkpoint.rs`).
    let staged_mesh =
        memory.is_some() && crate::input::is_plain_mesh(&args.input, &args.heightfield)?;
    let mesh_config = configure(&args, crate::input::mesh_domain(&args.heightfield), &memory);
    if staged_mesh {
        let temp = memory.as_ref().map(|m| m.temp_dir.as_path());
        say_how_to_resume_when_interrupted(crate::build_checkpoint::dir_for(&args.output, temp));
    }
    let manifest = |fingerprint| {
        let mut manifest = tessera_preprocess::checkpoint::manifest_for(fingerprint, &mesh_config);
        let normals = if args.no_computed_normals {
            "input"
        } else {
            "input, else computed"
        };
        manifest.flags.insert("normals".into(), normals.into());
        let textures = if args.no_textures { "ignored" } else { "read" };
        manifest.flags.insert("textures".into(), textures.into());
        manifest
    };
    let prepared = crate::build_checkpoint::prepare(
        &args.input,
        &args.output,
        memory.as_ref().map(|m| m.temp_dir.as_path()),
        &manifest,
        staged_mesh,
        args.resume,
        args.stop_after.clone().map(|s| (s, args.json)),
    )?;
    // (The lock is held until the build ends.)
    let (mut checkpoint, _lock) = match prepared {
        Some(p) => (Some(p.checkpoint), Some(p.lock)),
        None => (None, None),
    };
    let input = match load_or_resume(&args, staging, checkpoint.as_mut()) {
        Ok(input) => input,
        Err(e) => {
            if let Some(c) = checkpoint {
                crate::build_checkpoint::after_failure(c, &e);
            }
            return Err(e);
        }
    };
    let mut config = configure(&args, input.domain(), &memory);
    config.textures = input.textures().cloned();
    let import_seconds = start.elapsed().as_secs_f64();
    let name = if crate::input::is_stdin(&args.input) {
        "standard input".to_string()
    } else {
        args.input.display().to_string()
    };
    let on_stage = |s: &str| {
        stages.stage(s);
        peaks.start(s);
    };
    let staged = match &input {
        BuildInput::Staged { staged, .. } => Some(staged),
        _ => None,
    };
    let built = match (&input, checkpoint.as_mut()) {
        (_, Some(c)) => build_repository_checkpointed(staged, &config, &args.output, &on_stage, c),
        (BuildInput::Loaded(loaded), None) => {
            build_repository(&loaded.mesh, &config, &args.output, &on_stage)
        }
        (BuildInput::Staged { staged, .. }, None) => {
            build_repository_staged(staged, &config, &args.output, &on_stage)
        }
        (BuildInput::Resumed { .. }, None) => unreachable!("resumed from a checkpoint"),
    }
    .with_context(|| format!("building {name}"));
    let summary = match (built, checkpoint) {
        (Ok(summary), Some(c)) => {
            c.remove().context("removing the build's checkpoint")?;
            summary
        }
        (Ok(summary), None) => summary,
        (Err(e), Some(c)) => {
            crate::build_checkpoint::after_failure(c, &e);
            return Err(e);
        }
        (Err(e), None) => return Err(e),
    };
    let mut summary = summary;
    let grid = crate::build_grid::apply(grid_rule(&args), &args.output)?;
    if let Some(g) = &grid {
        summary.root_error = g.root_error;
        summary.position_step = g.position_step;
        summary.quantisation_error = g.quantisation_error;
        summary.repository_bytes = g.repository_bytes;
    }
    stages.finish();
    let stage_peaks = peaks.finish();
    let seconds = start.elapsed().as_secs_f64();
    if args.json {
        let mut value = summary_json(&summary, seconds);
        value["import_seconds"] = json!(import_seconds);
        value["memory_budget_bytes"] = json!(args.memory);
        // Whether the stored errors are bounds (`--bounded-errors`) or estimates.
        value["bounded_errors"] = json!(args.bounded_errors);
        value["position_bits"] = json!(args.position_bits.unwrap_or(POSITION_BITS));
        // The grid chosen from the error (or `--position-step`), applied after the build.
        value["position_grid"] = grid.as_ref().map_or(json!(null), |g| g.json());
        // The most the out-of-core stages' temporary files held at once (0 without --memory).
        value["temp_bytes_peak"] = json!(tessera_preprocess::external::temp_usage::peak());
        // Which files made that peak (approximately: taken as the peak was reached).
        value["temp_bytes_at_peak"] =
            temp_parts_json(tessera_preprocess::external::temp_usage::by_kind_at_peak());
        let temp_stage_peaks = crate::peak_rss::temp_stage_peaks();
        if let Some(stages) = value["stages"].as_array_mut() {
            stages.insert(0, json!({"stage": "import", "seconds": import_seconds}));
            // Each stage's peak resident memory: its own with `--stage-peaks`, else the peak so far
            // (see `StagePeaks`).
            for stage in stages.iter_mut() {
                let name = stage["stage"].as_str().unwrap_or_default().to_string();
                if let Some((_, peak)) = stage_peaks.iter().find(|(s, _)| *s == name) {
                    stage["peak_rss_bytes"] = json!(peak);
                }
                if let Some((_, peak, parts)) = temp_stage_peaks.iter().find(|(s, ..)| *s == name) {
                    stage["temp_bytes_peak"] = json!(peak);
                    stage["temp_bytes_at_peak"] = temp_parts_json(parts.clone());
                }
            }
        }
        let overall = stage_peaks
            .iter()
            .map(|&(_, p)| p)
            .chain(crate::peak_rss::peak_rss_bytes())
            .max();
        value["peak_rss_bytes"] = json!(overall);
        value["stage_peaks_are_per_stage"] = json!(peaks.reset);
        value["output"] = json!(args.output.display().to_string());
        value["domain"] = json!(match input.domain() {
            tessera_preprocess::Domain::Volume => "volume",
            tessera_preprocess::Domain::HeightField => "heightfield",
        });
        value["grid"] = crate::input::grid_json(input.grid());
        // Textures read (0 without), and texture files named but not found.
        value["textures"] = json!(input.textures().map_or(0, |t| t.textures.len()));
        value["missing_textures"] = json!(input.missing_textures());
        println!("{value}");
    } else {
        println!("{name}: {}", input.description());
        if let Some(t) = input.textures() {
            println!("textures: {} ({} bands)", t.textures.len(), t.bands.len());
        }
        for missing in input.missing_textures() {
            println!("texture not found, drawn untextured: {missing}");
        }
        print_summary(
            &summary,
            args.position_bits.unwrap_or(POSITION_BITS),
            seconds,
            import_seconds,
        );
        if let Some(g) = &grid {
            g.print();
        }
        println!("wrote {}", args.output.display());
    }
    Ok(Outcome::Ok)
}

/// The build's configuration for an input of `domain`.
fn parse_page_encoding(text: &str) -> Result<tessera_core::texture::PageEncoding, String> {
    use tessera_core::texture::PageEncoding;
    [PageEncoding::Bc1, PageEncoding::Rgba8]
        .into_iter()
        .find(|e| e.name() == text)
        .ok_or_else(|| format!("{text:?}: the texture encodings are bc1 and rgba8"))
}

fn configure(args: &BuildArgs, domain: Domain, memory: &Option<MemoryBudget>) -> BuildConfig {
    let mut config = BuildConfig {
        threads: args.threads,
        memory: memory.clone(),
        codec: if args.no_compress {
            PatchCodec::Raw
        } else {
            PatchCodec::Coded
        },
        ..BuildConfig::for_domain(domain)
    };
    config.simplify.bounded_errors = args.bounded_errors;
    config.simplify.normal_weight = args.normal_weight;
    config.simplify.colour_weight = args.colour_weight;
    config.simplify.uv_weight = args.uv_weight;
    config.position_bits = args.position_bits.unwrap_or(POSITION_BITS);
    config.texture_encoding = args.texture_encoding;
    if let Some(n) = args.leaf_triangles {
        config.construction = Construction::LeafTriangles(n);
    }
    if let Some(l) = args.levels {
        config.construction = Construction::Levels(l);
    }
    config
}

/// The input: read (and staged, and saved as the checkpoint's first stage), or taken from the
/// checkpoint (its staged mesh, or nothing when it holds the simplification's state).
fn load_or_resume(
    args: &BuildArgs,
    staging: Option<(&std::path::Path, u64)>,
    checkpoint: Option<&mut Checkpoint>,
) -> anyhow::Result<BuildInput> {
    use tessera_preprocess::checkpoint::{open_staged, save_staged};
    let domain = crate::input::mesh_domain(&args.heightfield);
    let import = tessera_preprocess::import::ImportOptions {
        textures: !args.no_textures,
    };
    // A checkpoint keeps the staged mesh, not its textures: found in the input again (standard
    // input, a PLY without a directory, has none).
    let textures_again = || -> anyhow::Result<_> {
        if crate::input::is_stdin(&args.input) {
            return Ok((None, Vec::new()));
        }
        Ok(tessera_preprocess::import::find_textures(
            &args.input,
            &import,
        )?)
    };
    if let Some(c) = &checkpoint {
        if let Some(stage) = c
            .last_stage()
            .filter(|s| s.name != "staged" && s.name != "hierarchy")
        {
            let (textures, missing_textures) = textures_again()?;
            return Ok(BuildInput::Resumed {
                domain,
                description: format!("mesh (resumed after stage {})", stage.name),
                textures,
                missing_textures,
            });
        }
        if let Some(mut staged) = open_staged(c).context("opening the checkpoint's staged mesh")? {
            (staged.textures, staged.missing_textures) = textures_again()?;
            return Ok(crate::input::staged_input(staged, &args.heightfield));
        }
    }
    let (mut input, stream) =
        crate::input::load_build_input(&args.input, &args.heightfield, staging, &import)?;
    if !args.no_computed_normals {
        crate::input::compute_missing_normals(&mut input, staging, args.crease_angle)?;
    }
    if let (Some(c), BuildInput::Staged { staged, .. }) = (checkpoint, &mut input) {
        let at = format!("checkpoint {}", c.dir().display());
        let at = || at.clone();
        if let Some(fingerprint) = stream {
            c.set_input(fingerprint).with_context(at)?;
        }
        save_staged(c, staged).with_context(at)?;
    }
    Ok(input)
}

/// The `--json` object (stable keys).
pub fn summary_json(s: &BuildSummary, seconds: f64) -> serde_json::Value {
    json!({
        "input_triangles": s.input_triangles,
        "input_vertices": s.input_vertices,
        "tetrahedra": s.tetrahedra,
        "leaves": s.leaves,
        "diamonds": s.diamonds,
        "depth": s.depth,
        "seconds": seconds,
        "build_seconds": s.seconds,
        "repository_bytes": s.repository_bytes,
        "patch_triangles": s.patch_triangles,
        "mean_triangles_per_patch": s.patch_triangles as f64 / s.tetrahedra.max(1) as f64,
        "root_error": s.root_error,
        "locked_vertices": s.locked_vertices,
        "resimplified_diamonds": s.resimplified_diamonds,
        "position_step": s.position_step,
        "quantisation_error": s.quantisation_error,
        "stages": s.stages.iter().map(|(name, t)| json!({"stage": name, "seconds": t})).collect::<Vec<_>>(),
        // The texture pages written (null without textures); PSNR null where lossless.
        "texture_pages": s.textures.as_ref().map(|t| json!({
            "encoding": t.encoding.name(),
            "pages": t.pages,
            "bytes": t.page_bytes,
            "psnr_db": t.psnr_db.is_finite().then_some(t.psnr_db),
        })),
    })
}

pub fn print_summary(s: &BuildSummary, position_bits: u32, seconds: f64, import_seconds: f64) {
    println!(
        "input: {} triangles, {} vertices (import {:.2} s)",
        s.input_triangles, s.input_vertices, import_seconds
    );
    println!(
        "hierarchy: {} tetrahedra ({} leaves), {} diamonds, depth {}",
        s.tetrahedra, s.leaves, s.diamonds, s.depth
    );
    println!(
        "patches: {} triangles over all levels, {:.1} per patch; root error {:.3e}",
        s.patch_triangles,
        s.patch_triangles as f64 / s.tetrahedra.max(1) as f64,
        s.root_error
    );
    println!(
        "positions: {position_bits} bits per axis, step {:.3e} × {:.3e} × {:.3e}; quantisation error {:.3e} \
         (counted in every stored error)",
        s.position_step[0], s.position_step[1], s.position_step[2], s.quantisation_error
    );
    if let Some(t) = &s.textures {
        let loss = if t.psnr_db.is_finite() {
            format!("PSNR {:.2} dB against the texels as cut", t.psnr_db)
        } else {
            "lossless".to_string()
        };
        println!(
            "texture pages: {} {}, {} bytes; {loss}",
            t.pages,
            t.encoding.name(),
            t.page_bytes
        );
    }
    let stages: Vec<String> = s
        .stages
        .iter()
        .map(|(n, t)| format!("{n} {t:.2}s"))
        .collect();
    println!(
        "repository: {} bytes; {:.2} s total ({})",
        s.repository_bytes,
        seconds,
        stages.join(", ")
    );
}

/// A byte count: a number with an optional `K`, `M`, `G` or `T` suffix (powers of 1024; a
/// trailing `B` or `iB` is accepted: `512M`, `512MiB`, `2G`, `1048576`).
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let t = t
        .strip_suffix("iB")
        .or_else(|| t.strip_suffix('B'))
        .unwrap_or(t);
    let (digits, shift) = match t.chars().last() {
        Some('K' | 'k') => (&t[..t.len() - 1], 10),
        Some('M' | 'm') => (&t[..t.len() - 1], 20),
        Some('G' | 'g') => (&t[..t.len() - 1], 30),
        Some('T' | 't') => (&t[..t.len() - 1], 40),
        _ => (t, 0),
    };
    let n: u64 = digits
        .trim()
        .parse()
        .map_err(|_| format!("'{text}' is not a size (e.g. 512M, 2G)"))?;
    let bytes = n
        .checked_mul(1u64 << shift)
        .ok_or_else(|| format!("'{text}' is too large"))?;
    if bytes < 1 << 20 {
        return Err(format!("'{text}': give at least 1M"));
    }
    Ok(bytes)
}

/// What each kind of temporary file held, as a JSON object (kinds holding nothing left out).
fn temp_parts_json(
    parts: Vec<(tessera_preprocess::external::temp_usage::TempKind, u64)>,
) -> serde_json::Value {
    parts
        .into_iter()
        .filter(|&(_, bytes)| bytes > 0)
        .map(|(kind, bytes)| (kind.name().to_string(), json!(bytes)))
        .collect::<serde_json::Map<_, _>>()
        .into()
}

/// On Ctrl-C (SIGINT) or SIGTERM, says that the committed stages are kept and how to continue,
/// then exits 130, as a shell reports an interrupted command (the working files have no names,
/// so nothing else is left; nothing is ever written at the output before its last rename).
fn say_how_to_resume_when_interrupted(dir: PathBuf) {
    let installed = ctrlc::set_handler(move || {
        if dir.exists() {
            eprintln!(
                "\ninterrupted: the stages done are kept in {}; the same command with \
                 --resume continues from the last one",
                dir.display()
            );
        } else {
            eprintln!("\ninterrupted before the first stage: nothing is kept");
        }
        std::process::exit(130);
    });
    // Without the handler, an interrupt ends the build as before, only without the hint.
    drop(installed);
}

/// How the grid is chosen: from the error unless `--lossless` or `--position-bits` (applied
/// while building) say otherwise, or at most `--position-step`.
fn grid_rule(args: &BuildArgs) -> crate::build_grid::GridRule {
    use crate::build_grid::GridRule;
    match (
        args.lossless || args.position_bits.is_some(),
        args.position_step,
    ) {
        (true, _) => GridRule::None,
        (false, Some(step)) => GridRule::AtMost(step),
        (false, None) => GridRule::FromError,
    }
}

fn positive_step(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("{s}: a positive, finite number of model units")),
    }
}

#[cfg(test)]
mod tests {
    use super::parse_size;

    #[test]
    fn sizes_parse_in_powers_of_1024() {
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("2G"), Ok(2 << 30));
        assert_eq!(parse_size("64MiB"), Ok(64 << 20));
        assert_eq!(parse_size("1048576"), Ok(1 << 20));
        assert!(parse_size("12").is_err());
        assert!(parse_size("lots").is_err());
        assert!(parse_size("99999999999T").is_err());
    }
}
