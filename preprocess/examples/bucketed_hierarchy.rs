//! Peak memory and time of the hierarchy construction, in core or bucketed, on one mesh:
//!
//! ```text
//! cargo build --release -p tessera-preprocess --example bucketed_hierarchy
//! /usr/bin/time -v target/release/examples/bucketed_hierarchy INPUT incore [LEAF]
//! /usr/bin/time -v target/release/examples/bucketed_hierarchy INPUT bucketed [LEAF] [CAP] [TEMP]
//! /usr/bin/time -v target/release/examples/bucketed_hierarchy INPUT spooled [LEAF] [CAP] [TEMP]
//! target/release/examples/bucketed_hierarchy INPUT check [LEAF] [CAP]   # both, compared
//! ```
//!
//! The mesh is loaded first (as `build` does); then the peak RSS is reset (Linux
//! `/proc/self/clear_refs`), so the figures printed for the construction are its own peak
//! over the loaded mesh. `incore` computes every barycentre and calls `build_hierarchy`, as
//! `build` does; `bucketed` streams them from the mesh into `build_hierarchy_bucketed`;
//! `spooled` streams the mesh once into `SpooledBarycentres` and builds from that.
//! LEAF defaults to 1024 triangles per leaf, CAP to 65536 per bucket, TEMP to /tmp. With
//! `NO_PEAK_RESET=1` the peak is not reset: the figures are then the whole process's.

use std::path::{Path, PathBuf};
use std::time::Instant;

use tessera_preprocess::frame::LatticeFrame;
use tessera_preprocess::hierarchy::{
    build_hierarchy, build_hierarchy_bucketed, build_hierarchy_bucketed_with_stats, BucketBudget,
    Hierarchy, MeshBarycentres, SpooledBarycentres,
};
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::Construction;

/// A line of /proc/self/status, in KiB.
fn status_kib(field: &str) -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with(field))
                .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
        })
        .unwrap_or(0)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: bucketed_hierarchy INPUT incore|bucketed|spooled|check [LEAF] [CAP] [TEMP]";
    let input = args.get(1).expect(usage);
    let mode = args.get(2).expect(usage).as_str();
    let leaf: usize = args.get(3).map_or(1024, |s| s.parse().expect(usage));
    let cap: usize = args.get(4).map_or(65536, |s| s.parse().expect(usage));
    let temp = args.get(5).map_or(PathBuf::from("/tmp"), PathBuf::from);

    let t = Instant::now();
    let mesh = load_mesh(Path::new(input)).expect("load").mesh;
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &mesh.positions {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    let frame = LatticeFrame::around_box(lo, hi, 20, 3);
    println!(
        "loaded {} triangles in {:.2} s; VmRSS {} KiB, VmHWM {} KiB",
        mesh.triangles.len(),
        t.elapsed().as_secs_f64(),
        status_kib("VmRSS:"),
        status_kib("VmHWM:")
    );
    // NO_PEAK_RESET=1 keeps the loading's peak in the figures (whole-process peak).
    let reset = std::env::var_os("NO_PEAK_RESET").is_none()
        && std::fs::write("/proc/self/clear_refs", "5").is_ok();
    let base = status_kib("VmRSS:");
    println!("peak reset: {reset}; VmRSS {base} KiB");

    let construction = Construction::LeafTriangles(leaf);
    let t = Instant::now();
    let hierarchy: Hierarchy = match mode {
        "incore" => {
            let barycentres: Vec<[f64; 3]> = mesh
                .triangles
                .iter()
                .map(|tri| frame.location(tri.map(|v| mesh.positions[v as usize])))
                .collect();
            build_hierarchy(frame, &barycentres, construction)
        }
        "bucketed" => {
            let budget = BucketBudget::new(cap, temp);
            let source = MeshBarycentres {
                frame: &frame,
                mesh: &mesh,
            };
            let (h, stats) =
                build_hierarchy_bucketed_with_stats(frame, &source, construction, &budget)
                    .expect("bucketed construction");
            println!("{stats:?}");
            h
        }
        "spooled" => {
            // The mesh streamed once into a temporary file, the passes reading that.
            let budget = BucketBudget::new(cap, temp);
            let source = MeshBarycentres {
                frame: &frame,
                mesh: &mesh,
            };
            let spooled = SpooledBarycentres::new(&source, &budget.temp_dir).expect("spool");
            let (h, stats) =
                build_hierarchy_bucketed_with_stats(frame, &spooled, construction, &budget)
                    .expect("bucketed construction");
            println!("{stats:?}");
            h
        }
        "check" => {
            // Both, compared (diamonds, leaves, leaf lists); the figures are then both's.
            let barycentres: Vec<[f64; 3]> = mesh
                .triangles
                .iter()
                .map(|tri| frame.location(tri.map(|v| mesh.positions[v as usize])))
                .collect();
            let expected = build_hierarchy(frame, &barycentres, construction);
            drop(barycentres);
            let source = MeshBarycentres {
                frame: &frame,
                mesh: &mesh,
            };
            let got = build_hierarchy_bucketed(
                frame,
                &source,
                construction,
                &BucketBudget::new(cap, temp),
            )
            .expect("bucketed construction");
            assert_eq!(expected.diamonds, got.diamonds, "diamonds differ");
            assert_eq!(expected.leaf_triangles, got.leaf_triangles, "leaves differ");
            println!("check: equal");
            got
        }
        _ => panic!("{usage}"),
    };
    let seconds = t.elapsed().as_secs_f64();
    let hwm = status_kib("VmHWM:");
    let listed: usize = hierarchy.leaf_triangles.values().map(Vec::len).sum();
    let peak = if reset {
        format!(
            "construction peak VmHWM {hwm} KiB, {} KiB over the loaded mesh",
            hwm.saturating_sub(base)
        )
    } else {
        format!("process peak VmHWM {hwm} KiB (loading included)")
    };
    println!(
        "{mode}: {seconds:.2} s; {} diamonds, {} leaves, {listed} triangles listed; {peak}",
        hierarchy.diamonds.len(),
        hierarchy.mesh.leaf_count(),
    );
}
