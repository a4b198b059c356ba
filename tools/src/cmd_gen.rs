//! `tessera gen terrain -o OUT.{npy,json} [--seed S] [--levels L] [--spacing M]
//! [--roughness R] [--regions MH,PW]`: a diamond-square terrain (seed 002) with a map of
//! regions, written as a height field that `tessera build` reads. `gen mesh`: see
//! `cmd_gen_mesh.rs`.

use std::path::PathBuf;

use anyhow::bail;
use clap::{Args, Subcommand};
use tessera_preprocess::dem::write::{json_bytes, npy_bytes};
use tessera_preprocess::diamond_square::{generate, TerrainParams};

use crate::Outcome;

#[derive(Args)]
pub struct GenArgs {
    #[command(subcommand)]
    pub what: GenWhat,
}

#[derive(Subcommand)]
pub enum GenWhat {
    /// A diamond-square terrain with a map of regions.
    Terrain(TerrainArgs),
    /// A closed procedural mesh of any size with the demo's relief, streamed as binary PLY.
    Mesh(crate::cmd_gen_mesh::MeshArgs),
}

#[derive(Args)]
pub struct TerrainArgs {
    /// Output height field: .npy (f32 heights) or .json (heights and spacing).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Random seed: the same parameters give the same terrain on every machine.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The grid is (2^L + 1)² samples (1..=13).
    #[arg(long, value_name = "L", default_value_t = 9)]
    pub levels: u32,
    /// Metres between samples.
    #[arg(long, value_name = "METRES", default_value_t = 30.0)]
    pub spacing: f64,
    /// Multiplies every region's roughness (1 = as the regions say; < 1 smoother).
    #[arg(long, default_value_t = 1.0)]
    pub roughness: f64,
    /// The map of regions, rows separated by commas, one letter per region: M mountain,
    /// H hills, P plain, V valley, W water; neighbouring regions blend.
    #[arg(long, default_value = "MH,PW")]
    pub regions: String,
}

pub fn run(args: GenArgs) -> anyhow::Result<Outcome> {
    match args.what {
        GenWhat::Terrain(a) => terrain(a),
        GenWhat::Mesh(a) => crate::cmd_gen_mesh::run(a),
    }
}

fn terrain(args: TerrainArgs) -> anyhow::Result<Outcome> {
    let params = TerrainParams {
        seed: args.seed,
        levels: args.levels,
        spacing: args.spacing,
        roughness_scale: args.roughness,
        regions: args
            .regions
            .split(',')
            .map(|r| r.trim().to_string())
            .collect(),
    };
    let ext = args
        .output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let write: fn(&_) -> Vec<u8> = match ext.as_deref() {
        Some("npy") => npy_bytes,
        Some("json") => json_bytes,
        _ => bail!(
            "{}: the output must end in .npy or .json",
            args.output.display()
        ),
    };
    let grid = generate(&params)?;
    crate::output::write_bytes(&write(&grid), &args.output)?;
    let (lo, hi) = grid
        .heights
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &h| (a.min(h), b.max(h)));
    println!(
        "wrote {}: {} × {} samples, {} m apart, heights {lo:.0} … {hi:.0} m",
        args.output.display(),
        grid.columns,
        grid.rows,
        args.spacing
    );
    if ext.as_deref() == Some("npy") {
        println!(
            "(a .npy holds no spacing: build it with --spacing {})",
            args.spacing
        );
    }
    Ok(Outcome::Ok)
}
