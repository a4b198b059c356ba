//! `tessera gen mesh --triangles N -o OUT.ply [--seed S] [--shuffle-vertices]
//! [--density-range R] [--colour] [--uv [--texture N]] [--json]`: a closed, watertight, 2-manifold procedural mesh with the
//! demo's relief (`tessera_preprocess::gen_mesh`), streamed as binary little-endian PLY in
//! constant memory to a file (temporary file + rename) or to standard output (`-o -`).
//!
//! The summary (or the `--json` object) goes to stdout, or to stderr when the mesh does.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use tessera_preprocess::gen_mesh::{texture, write_ply, GenMesh, MeshParams};

use crate::Outcome;

#[derive(Args)]
pub struct MeshArgs {
    /// Triangles, e.g. 2000000, 100M or 1G: exactly N when N is even, N + 1 when odd (a
    /// closed triangle mesh has an even count); at least 192.
    #[arg(long, value_name = "N", value_parser = parse_count)]
    pub triangles: u64,
    /// Output binary PLY, or `-` for standard output.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Seed of the relief (and of the vertex order): the same parameters give the same bytes.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write the vertices in a pseudo-random order (no locality), faces renumbered to match.
    #[arg(long)]
    pub shuffle_vertices: bool,
    /// Triangle areas vary by this factor from the densest region (around −z) to the
    /// sparsest (around +z), measured on the mesh before its relief; 1 = nearly uniform.
    #[arg(long, value_name = "R", default_value_t = 1.0)]
    pub density_range: f64,
    /// Give every vertex an RGB colour (PLY red, green, blue): a large coloured input.
    #[arg(long)]
    pub colour: bool,
    /// Give every vertex texture coordinates (PLY s, t): one chart a cube face in a 3 x 2
    /// atlas, so the cube's edges are seams (their vertices written once a face).
    #[arg(long)]
    pub uv: bool,
    /// Also write an N × N procedural PNG beside the mesh (OUT with the extension `.png`:
    /// a checkerboard over gradients, grid lines and a glyph a cell) and name it in the PLY
    /// header (`comment TextureFile`), so `build` reads a textured input. Streamed a row at a
    /// time; N from 1 to 65536 (4096: a 64 MiB RGBA texture).
    #[arg(long, value_name = "N", requires = "uv")]
    pub texture: Option<u32>,
    /// Print one JSON object (on stderr when the mesh goes to stdout).
    #[arg(long)]
    pub json: bool,
}

/// A count with an optional decimal suffix: K (10³), M (10⁶), G (10⁹).
fn parse_count(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let (digits, scale) = match t.char_indices().last() {
        Some((i, 'k' | 'K')) => (&t[..i], 1_000),
        Some((i, 'm' | 'M')) => (&t[..i], 1_000_000),
        Some((i, 'g' | 'G')) => (&t[..i], 1_000_000_000),
        _ => (t, 1),
    };
    digits
        .parse::<u64>()
        .ok()
        .and_then(|n| n.checked_mul(scale))
        .ok_or_else(|| format!("expected a count such as 2000000, 100M or 1G, got {s:?}"))
}

pub fn run(args: MeshArgs) -> anyhow::Result<Outcome> {
    let mesh = GenMesh::new(MeshParams {
        triangles: args.triangles,
        seed: args.seed,
        shuffle_vertices: args.shuffle_vertices,
        density_range: args.density_range,
        colour: args.colour,
    })
    .map_err(anyhow::Error::msg)?
    .with_uvs(args.uv);
    let to_stdout = args.output.as_os_str() == "-";
    if to_stdout && std::io::stdout().is_terminal() {
        anyhow::bail!("-o -: standard output is a terminal; redirect or pipe the binary PLY");
    }
    let texture = match args.texture {
        None => None,
        Some(_) if to_stdout => {
            anyhow::bail!("--texture writes a PNG beside the mesh: give -o a file, not -")
        }
        Some(n) if !(1..=texture::MAX_SIDE).contains(&n) => {
            anyhow::bail!("--texture {n}: the side must be 1 to {}", texture::MAX_SIDE)
        }
        Some(n) => {
            let path = args.output.with_extension("png");
            if path == args.output {
                anyhow::bail!(
                    "-o {}: the texture would overwrite the mesh",
                    path.display()
                );
            }
            let name = path
                .file_name()
                .and_then(|n| n.to_str())
                .filter(|n| !n.contains('\n'))
                .with_context(|| format!("{}: not a one-line UTF-8 name", path.display()))?
                .to_string();
            Some((n, path, name))
        }
    };
    let mesh = mesh.with_texture_file(texture.as_ref().map(|(_, _, name)| name.clone()));
    let texture_bytes = match &texture {
        Some((n, path, _)) => {
            let mut bytes = 0;
            crate::output::write_atomically(path, |_, file| {
                bytes = texture::write_texture_png(*n, file)?;
                Ok(())
            })
            .with_context(|| format!("writing the texture {}", path.display()))?;
            Some(bytes)
        }
        None => None,
    };
    let exact = mesh.triangle_count() == args.triangles;
    if !exact {
        eprintln!(
            "note: {} triangles requested, writing {} (a closed triangle mesh has an even count)",
            args.triangles,
            mesh.triangle_count()
        );
    }
    let bar = progress_bar(mesh.vertex_count() + mesh.triangle_count());
    let mut progress = |done: u64| {
        if let Some(bar) = &bar {
            bar.set_position(done);
        }
    };
    let start = Instant::now();
    let bytes = if to_stdout {
        let mut out = std::io::stdout().lock();
        write_ply(&mesh, &mut out, &mut progress).context("writing the mesh to standard output")?
    } else {
        let mut bytes = 0;
        crate::output::write_atomically(&args.output, |_, file| {
            bytes = write_ply(&mesh, file, &mut progress)?;
            Ok(())
        })?;
        bytes
    };
    let seconds = start.elapsed().as_secs_f64();
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let mb_per_s = bytes as f64 / 1e6 / seconds.max(1e-9);
    let name = if to_stdout {
        "standard output".to_string()
    } else {
        args.output.display().to_string()
    };
    let report = if args.json {
        json!({
            "output": name,
            "requested_triangles": args.triangles,
            "triangles": mesh.triangle_count(),
            "exact": exact,
            "vertices": mesh.vertex_count(),
            "grid": mesh.topology.n,
            "split_cells": mesh.topology.splits,
            "seed": args.seed,
            "shuffle_vertices": args.shuffle_vertices,
            "density_range": args.density_range,
            "colour": args.colour,
            "uv": args.uv,
            "texture": texture.as_ref().map(|(_, path, _)| path.display().to_string()),
            "texture_side": args.texture,
            "texture_bytes": texture_bytes,
            "bytes": bytes,
            "seconds": seconds,
            "mb_per_s": mb_per_s,
            "peak_rss_bytes": crate::peak_rss::peak_rss_bytes(),
        })
        .to_string()
    } else {
        format!(
            "wrote {name}: {} triangles{}, {} vertices, {bytes} bytes in {seconds:.2} s \
             ({mb_per_s:.0} MB/s)",
            mesh.triangle_count(),
            if exact { "" } else { " (rounded up to even)" },
            mesh.vertex_count(),
        ) + &texture.as_ref().map_or(String::new(), |(n, path, _)| {
            format!("; texture {} ({n} × {n})", path.display())
        })
    };
    if to_stdout {
        eprintln!("{report}");
    } else {
        println!("{report}");
    }
    Ok(Outcome::Ok)
}

/// A bar on stderr when it is a terminal (records written of vertices + triangles).
fn progress_bar(total: u64) -> Option<ProgressBar> {
    std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template("gen mesh: {wide_bar} {percent}% [{elapsed}<{eta}]")
                .unwrap(),
        );
        bar
    })
}

#[cfg(test)]
mod tests {
    use super::parse_count;

    #[test]
    fn counts_with_suffixes() {
        assert_eq!(parse_count("2000000"), Ok(2_000_000));
        assert_eq!(parse_count("100M"), Ok(100_000_000));
        assert_eq!(parse_count("1G"), Ok(1_000_000_000));
        assert_eq!(parse_count("5k"), Ok(5_000));
        for bad in ["", "M", "-5", "1.5M", "1e8", "99999999999G"] {
            assert!(parse_count(bad).is_err(), "{bad:?}");
        }
    }
}
