//! `tessera repack REPO -o OUT [--no-compress | --codec NAME] [--json]`: the same repository
//! with its patches entropy-coded (`coded`, the default), packed, or stored as drawn, without a
//! rebuild — for repositories built before coding, packed (`packed`, `packed-v1`: their vertex
//! order stays, so a `packed-v1` one codes less well than a rebuild), or built with
//! `build --no-compress` (`core::repository::repack`).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use serde_json::json;
use tessera_core::repository::repack::repack;
use tessera_core::repository::PatchCodec;

use crate::Outcome;

#[derive(Args)]
pub struct RepackArgs {
    /// Repository to read.
    pub repository: PathBuf,
    /// Repository to write (a temporary file, then renamed; may not be the input).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Store the patches as drawn instead of coded (the same as `--codec raw`).
    #[arg(long, conflicts_with = "codec")]
    pub no_compress: bool,
    /// How to store the patches: `coded` (the default: positions predicted along the strip,
    /// rANS), `packed` (the format before it: meshoptimizer's vertex codec, 4-bit strip
    /// symbols) or `raw` (as drawn).
    #[arg(long, value_name = "NAME", value_parser = ["coded", "packed", "raw"])]
    pub codec: Option<String>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: RepackArgs) -> anyhow::Result<Outcome> {
    let start = Instant::now();
    let same_file = std::fs::canonicalize(&args.repository)
        .ok()
        .zip(std::fs::canonicalize(&args.output).ok())
        .is_some_and(|(a, b)| a == b);
    anyhow::ensure!(
        !same_file,
        "{}: the output may not be the input (the input stays mapped while it is read)",
        args.output.display()
    );
    let source = crate::repository_arg::open(&args.repository, "repack")
        .with_context(|| format!("{}", args.repository.display()))?;
    let codec = match (args.no_compress, args.codec.as_deref()) {
        (true, _) | (_, Some("raw")) => PatchCodec::Raw,
        (_, Some("packed")) => PatchCodec::Packed,
        _ => PatchCodec::Coded,
    };
    let bytes = repack(&source, codec, &args.output)
        .with_context(|| format!("{}", args.repository.display()))?;
    let value = json!({
        "input": args.repository,
        "output": args.output,
        "input_codec": source.codec().name(),
        "output_codec": codec.name(),
        "input_bytes": source.file_bytes(),
        "output_bytes": bytes,
        "seconds": start.elapsed().as_secs_f64(),
    });
    if args.json {
        println!("{value}");
    } else {
        println!(
            "{} ({}, {} bytes) -> {} ({}, {bytes} bytes) in {:.2} s",
            args.repository.display(),
            source.codec().name(),
            source.file_bytes(),
            args.output.display(),
            codec.name(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(Outcome::Ok)
}
