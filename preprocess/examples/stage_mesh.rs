//! Stages a mesh on disk with a memory budget (the out-of-core build's import) or loads it in
//! memory, and prints what it did: for measuring the two back to back with `/usr/bin/time -v`.
//!
//!     cargo run --release -p tessera-preprocess --example stage_mesh -- IN.ply [BUDGET_MIB | memory]

use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = std::path::Path::new(
        args.get(1)
            .ok_or("usage: stage_mesh IN [BUDGET_MIB|memory]")?,
    );
    let mode = args.get(2).map(String::as_str).unwrap_or("64");
    let start = Instant::now();
    if mode == "memory" {
        let r = tessera_preprocess::import::load_mesh(path)?;
        println!(
            "in memory: {} vertices, {} triangles, {:.2} s",
            r.mesh.positions.len(),
            r.mesh.triangles.len(),
            start.elapsed().as_secs_f64()
        );
    } else {
        let budget: usize = mode.parse::<usize>()? << 20;
        let dir = tempfile::tempdir_in(path.parent().unwrap_or(std::path::Path::new(".")))?;
        let s = tessera_preprocess::import::stage_mesh(path, dir.path(), budget)?;
        println!(
            "staged with {mode} MiB: {} vertices, {} triangles, {} bytes on disk, {:.2} s",
            s.positions.len(),
            s.triangles.len(),
            s.bytes(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
