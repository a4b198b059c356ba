//! `build`'s position grid (issue 49): by default chosen from the error after the build — the
//! coarsest power-of-two multiple of the lattice's step at most Nexus's default step for the
//! same model, 2^trunc(log2(0.05 e)), e the smallest error of the first level of diamonds
//! above the leaves — or at most `--position-step`; none with `--lossless` or
//! `--position-bits` (which quantises while building, as before).
//!
//! The build encodes each patch before any level's error is known, on the full lattice; the
//! grid is then applied by one more pass over the repository (`repack::repack_on_grid`:
//! decode, round, code, write a temporary file, rename over the output). Its time is reported
//! apart (`grid_seconds`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use serde_json::{json, Value};
use tessera_core::repository::grid::{
    first_level_error, half_diagonal, nexus_step, shifts_for, NEXUS_FRACTION,
};
use tessera_core::repository::repack::repack_on_grid;
use tessera_core::repository::Repository;

/// How `build` picks its position grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GridRule {
    /// Nexus's default step from the first level's error (the default).
    FromError,
    /// At most this step (`--position-step`).
    AtMost(f64),
    /// The full lattice (`--lossless`, or `--position-bits`, applied while building).
    None,
}

/// The grid a build applied.
#[derive(Clone, Debug)]
pub struct GridApplied {
    pub first_level_error: Option<f64>,
    /// The step asked for: Nexus's default, or `--position-step`.
    pub target_step: f64,
    pub shifts: [u32; 3],
    pub position_step: [f64; 3],
    pub quantisation_error: f64,
    /// The first diamond's stored error afterwards (the build's `root_error`).
    pub root_error: f64,
    pub repository_bytes: u64,
    pub seconds: f64,
}

impl GridApplied {
    pub fn json(&self) -> Value {
        json!({
            "first_level_error": self.first_level_error,
            "target_step": self.target_step,
            "shifts": self.shifts,
            "position_step": self.position_step,
            "quantisation_error": self.quantisation_error,
            "repository_bytes": self.repository_bytes,
            "seconds": self.seconds,
        })
    }

    pub fn print(&self) {
        let e = self
            .first_level_error
            .map_or("none".to_string(), |e| format!("{e:.3e}"));
        println!(
            "grid: first-level error {e}, step at most {:.3e}: lattice × 2^{:?} = {:.3e} × \
             {:.3e} × {:.3e}; quantisation error {:.3e} (counted in every stored error); \
             repository {} bytes ({:.2} s)",
            self.target_step,
            self.shifts,
            self.position_step[0],
            self.position_step[1],
            self.position_step[2],
            self.quantisation_error,
            self.repository_bytes,
            self.seconds
        );
    }
}

/// Applies `rule` to the repository `output` (built on the full lattice); `None` when the rule
/// keeps the lattice or asks for no coarser grid than it.
pub fn apply(rule: GridRule, output: &Path) -> anyhow::Result<Option<GridApplied>> {
    let start = Instant::now();
    let at = || output.display().to_string();
    let source = Repository::open(output).with_context(at)?;
    let e = first_level_error(&source);
    let target = match (rule, e) {
        (GridRule::None, _) | (GridRule::FromError, None) => return Ok(None),
        (GridRule::FromError, Some(e)) => nexus_step(e, NEXUS_FRACTION),
        (GridRule::AtMost(step), _) => step,
    };
    let shifts = shifts_for(source.header().position_step, target);
    if shifts == [0; 3] {
        return Ok(None);
    }
    let temporary = sibling(output, ".grid");
    let bytes = repack_on_grid(&source, source.codec(), shifts, &temporary).with_context(at)?;
    let position_step = source.header().position_step;
    drop(source);
    std::fs::rename(&temporary, output)
        .with_context(|| format!("renaming {} to {}", temporary.display(), at()))?;
    let position_step = [0, 1, 2].map(|a| position_step[a] * (1u64 << shifts[a]) as f64);
    let coarse = Repository::open(output).with_context(at)?;
    let root_error = coarse.diamonds().first().map_or(0.0, |d| d.error as f64);
    Ok(Some(GridApplied {
        root_error,
        first_level_error: e,
        target_step: target,
        shifts,
        position_step,
        quantisation_error: half_diagonal(position_step),
        repository_bytes: bytes,
        seconds: start.elapsed().as_secs_f64(),
    }))
}

/// `path` with `suffix` added to its file name, hidden (a leading dot).
fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let name = path
        .file_name()
        .map_or("repository".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}{suffix}"))
}
