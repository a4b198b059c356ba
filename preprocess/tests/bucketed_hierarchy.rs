//! The bucketed (out-of-core) hierarchy construction against the in-core one: equal in every
//! field on scans, a height field, generated meshes whose density varies 1000x and random point
//! clouds, with bucket caps small enough for many buckets and many forced splits across their
//! borders; and the temporary file gone on success and on failure.

use std::io;
use std::path::{Path, PathBuf};

use proptest::prelude::*;

use tessera_core::leb::SimplexKey;
use tessera_preprocess::dem::{load_dem, DemOptions, TerrainOptions};
use tessera_preprocess::frame::LatticeFrame;
use tessera_preprocess::gen_mesh::{GenMesh, MeshParams};
use tessera_preprocess::hierarchy::{
    build_hierarchy, build_hierarchy_bucketed, build_hierarchy_bucketed_with_stats,
    BarycentreSource, BucketBudget, BucketStats, Hierarchy, MeshBarycentres, SpooledBarycentres,
};
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::mesh::InputMesh;
use tessera_preprocess::Construction;

// ------------------------------------------------------------------------------------ helpers

fn testdata(relative: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata")
        .join(relative);
    assert!(path.exists(), "{} is missing", path.display());
    path
}

/// The frame `build` makes for a mesh (bounding box, 20 lattice bits).
fn frame_of(mesh: &InputMesh, dim: u8) -> LatticeFrame {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &mesh.positions {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    LatticeFrame::around_box(lo, hi, 20, dim)
}

fn barycentres(frame: &LatticeFrame, mesh: &InputMesh) -> Vec<[f64; 3]> {
    mesh.triangles
        .iter()
        .map(|t| frame.location(t.map(|v| mesh.positions[v as usize])))
        .collect()
}

/// Every field equal: frame, split diamonds (ids, levels, simplices, parents, children, in
/// order), the mesh's split set and leaves, and each leaf's triangles in order.
fn assert_same(expected: &Hierarchy, got: &Hierarchy, what: &str) {
    assert_eq!(expected.frame, got.frame, "{what}: frame");
    assert_eq!(
        expected.diamonds.len(),
        got.diamonds.len(),
        "{what}: split diamonds"
    );
    for (a, b) in expected.diamonds.iter().zip(&got.diamonds) {
        assert_eq!(a, b, "{what}: diamond");
    }
    assert_eq!(
        expected.mesh.split_count(),
        got.mesh.split_count(),
        "{what}: mesh splits"
    );
    assert!(
        expected.diamonds.iter().all(|d| got.mesh.is_split(d.id)),
        "{what}: mesh split set"
    );
    let leaves = |h: &Hierarchy| {
        let mut l: Vec<_> = h.mesh.leaves().collect();
        l.sort_by_key(|s| s.key);
        l
    };
    assert_eq!(leaves(expected), leaves(got), "{what}: leaves");
    fn lists(h: &Hierarchy) -> Vec<(SimplexKey, &Vec<u32>)> {
        let mut l: Vec<(SimplexKey, &Vec<u32>)> =
            h.leaf_triangles.iter().map(|(k, v)| (*k, v)).collect();
        l.sort_by_key(|(k, _)| *k);
        l
    }
    let (a, b) = (lists(expected), lists(got));
    assert_eq!(a.len(), b.len(), "{what}: leaf_triangles entries");
    for ((ka, la), (kb, lb)) in a.iter().zip(&b) {
        assert_eq!(ka, kb, "{what}: leaf_triangles keys");
        assert!(la == lb, "{what}: triangles of leaf {ka:?} differ");
    }
}

/// Both constructions from the same barycentres; the bucketed one with each cap, from the
/// slice and (when given) from a mesh streamed on the fly. Returns each run's stats.
fn check(
    what: &str,
    frame: LatticeFrame,
    barycentres: &[[f64; 3]],
    mesh: Option<&InputMesh>,
    construction: Construction,
    caps: &[usize],
) -> Vec<BucketStats> {
    let expected = build_hierarchy(frame, barycentres, construction);
    let mut all = Vec::new();
    for (i, &cap) in caps.iter().enumerate() {
        let dir = tempfile::tempdir().unwrap();
        let mut budget = BucketBudget::new(cap, dir.path());
        // Tiny buffers for one cap in two: many runs per bucket.
        if i % 2 == 1 {
            budget.buffer_bytes = 4096;
        }
        let what = format!(
            "{what}, {construction:?}, bucket cap {cap}, buffers {}",
            budget.buffer_bytes
        );
        let (got, stats) =
            build_hierarchy_bucketed_with_stats(frame, barycentres, construction, &budget).unwrap();
        assert_same(&expected, &got, &what);
        assert!(
            stats.largest_split_bucket <= cap as u64,
            "{what}: {stats:?}"
        );
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "{what}: temporary files left"
        );
        if let Some(mesh) = mesh {
            let source = MeshBarycentres {
                frame: &frame,
                mesh,
            };
            let again = build_hierarchy_bucketed(frame, &source, construction, &budget).unwrap();
            assert_same(
                &expected,
                &again,
                &format!("{what}, streamed from the mesh"),
            );
        }
        eprintln!(
            "{what}: {} leaves, {} diamonds; {stats:?}",
            got.mesh.leaf_count(),
            got.diamonds.len()
        );
        all.push(stats);
    }
    all
}

fn check_mesh(
    what: &str,
    mesh: &InputMesh,
    dim: u8,
    leaf: usize,
    multiples: &[usize],
) -> Vec<BucketStats> {
    let frame = frame_of(mesh, dim);
    let b = barycentres(&frame, mesh);
    let caps: Vec<usize> = multiples.iter().map(|m| m * leaf).collect();
    check(
        what,
        frame,
        &b,
        Some(mesh),
        Construction::LeafTriangles(leaf),
        &caps,
    )
}

fn generated(triangles: u64, density_range: f64, seed: u64) -> InputMesh {
    GenMesh::new(MeshParams {
        triangles,
        seed,
        shuffle_vertices: true,
        density_range,
        colour: false,
    })
    .unwrap()
    .to_input_mesh()
}

/// Many buckets, and splits forced across bucket borders, somewhere among the runs.
fn assert_exercised(stats: &[BucketStats]) {
    assert!(stats.iter().any(|s| s.buckets > 50), "{stats:?}");
    assert!(stats.iter().any(|s| s.cross_splits > 0), "{stats:?}");
    assert!(stats.iter().any(|s| s.dirty_buckets > 0), "{stats:?}");
}

// -------------------------------------------------------------------------------- real inputs

#[test]
fn bunny_matches_in_core() {
    let mesh = load_mesh(&testdata("mesh/bunny00.off")).unwrap().mesh;
    let mut stats = check_mesh("bunny", &mesh, 3, 1024, &[2, 5, 50]);
    stats.extend(check_mesh("bunny", &mesh, 3, 16, &[1, 2, 5, 50]));
    assert_exercised(&stats);
    let frame = frame_of(&mesh, 3);
    let b = barycentres(&frame, &mesh);
    check(
        "bunny",
        frame,
        &b,
        None,
        Construction::Levels(12),
        &[100, 2000, 100_000],
    );
}

#[test]
fn dragon_matches_in_core() {
    let mesh = load_mesh(&testdata("mesh/dragon_vrip.ply.gz"))
        .unwrap()
        .mesh;
    let stats = check_mesh("dragon", &mesh, 3, 1024, &[2, 5, 50]);
    assert_exercised(&stats);
}

#[test]
fn height_field_matches_in_core() {
    let grid = load_dem(&testdata("dem/volcano.json"), &DemOptions::default()).unwrap();
    let mesh = grid.to_mesh(&TerrainOptions::default());
    let mut stats = check_mesh("volcano", &mesh, 2, 256, &[2, 5, 50]);
    stats.extend(check_mesh("volcano", &mesh, 2, 8, &[1, 2, 5, 50]));
    assert_exercised(&stats);
    let frame = frame_of(&mesh, 2);
    let b = barycentres(&frame, &mesh);
    check(
        "volcano",
        frame,
        &b,
        None,
        Construction::Levels(14),
        &[50, 1000, 100_000],
    );
}

#[test]
fn varying_density_matches_in_core() {
    // Density varies 1000x over the surface; vertices shuffled.
    let mesh = generated(300_000, 1000.0, 7);
    let mut stats = check_mesh("generated 300k, density 1000x", &mesh, 3, 1024, &[2, 5, 50]);
    stats.extend(check_mesh(
        "generated 300k, density 1000x",
        &mesh,
        3,
        64,
        &[1, 2, 5],
    ));
    assert_exercised(&stats);
    let frame = frame_of(&mesh, 3);
    let b = barycentres(&frame, &mesh);
    check(
        "generated 300k, density 1000x",
        frame,
        &b,
        None,
        Construction::Levels(15),
        &[500, 20_000],
    );
}

// ------------------------------------------------------------------------------- edge cases

#[test]
fn empty_and_trivial_inputs_match_in_core() {
    let frame = LatticeFrame::around_box([0.0; 3], [1.0; 3], 8, 3);
    for construction in [
        Construction::LeafTriangles(4),
        Construction::Levels(0),
        Construction::Levels(5),
    ] {
        check("empty", frame, &[], None, construction, &[1, 10]);
        check(
            "one point",
            frame,
            &[[100.5, 3.25, 7.0]],
            None,
            construction,
            &[1, 10],
        );
    }
    // Coincident points: a leaf at the lattice resolution over every cap.
    let same = vec![[17.0, 17.0, 17.0]; 500];
    for cap in [1, 8, 100, 1000] {
        check(
            "coincident",
            frame,
            &same,
            None,
            Construction::LeafTriangles(cap),
            &[1, 3, 100, 10_000],
        );
    }
}

/// A source that streams out of order, or fails half way.
struct Broken {
    out_of_order: bool,
}

impl BarycentreSource for Broken {
    fn for_each_barycentre(&self, f: &mut dyn FnMut(u32, [f64; 3])) -> io::Result<()> {
        for t in 0..10_000u32 {
            let q = [
                (t % 97) as f64 + 0.5,
                (t % 89) as f64 + 0.25,
                (t % 83) as f64,
            ];
            if self.out_of_order && t == 5000 {
                f(t + 1, q);
                continue;
            }
            if !self.out_of_order && t == 9000 {
                return Err(io::Error::other("disk on fire"));
            }
            f(t, q);
        }
        Ok(())
    }
}

#[test]
fn errors_leave_no_temporary_files() {
    let frame = LatticeFrame::around_box([0.0; 3], [100.0; 3], 8, 3);
    for out_of_order in [true, false] {
        let dir = tempfile::tempdir().unwrap();
        let budget = BucketBudget::new(100, dir.path());
        let err = build_hierarchy_bucketed(
            frame,
            &Broken { out_of_order },
            Construction::LeafTriangles(16),
            &budget,
        )
        .err()
        .expect("a broken source fails the build");
        if out_of_order {
            assert_eq!(err.kind(), io::ErrorKind::InvalidData, "{err}");
        } else {
            assert!(err.to_string().contains("disk on fire"), "{err}");
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        assert!(SpooledBarycentres::new(&Broken { out_of_order }, dir.path()).is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
    let missing = BucketBudget::new(100, "/nonexistent/tessera-buckets");
    assert!(build_hierarchy_bucketed(
        frame,
        &[[1.0, 2.0, 3.0]][..],
        Construction::LeafTriangles(16),
        &missing
    )
    .is_err());
}

// --------------------------------------------------------------------------------- proptest

/// Clustered random points (a few Gaussian-ish blobs of very different spreads, some points
/// repeated), on a small lattice so that leaves at the resolution occur.
fn cloud(dim: u8, seed: u64, n: usize, bits: u32) -> Vec<[f64; 3]> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let side = (1u64 << bits) as f64;
    let blobs: Vec<([f64; 3], f64)> = (0..4)
        .map(|k| {
            let c = [next(), next(), next()].map(|x| (0.1 + 0.8 * x) * side);
            (c, side * 0.3 / 8f64.powi(k))
        })
        .collect();
    let mut points: Vec<[f64; 3]> = Vec::with_capacity(n);
    for i in 0..n {
        if i > 0 && next() < 0.05 {
            let j = (next() * i as f64) as usize;
            points.push(points[j]);
            continue;
        }
        let (c, r) = blobs[(next() * 4.0) as usize % 4];
        let mut p = [0, 1, 2].map(|a| {
            let x = c[a] + r * (next() + next() + next() - 1.5);
            x.clamp(0.0, side)
        });
        if next() < 0.1 {
            p = p.map(f64::round); // on lattice planes: the tie rules
        }
        if dim == 2 {
            p[2] = 0.0;
        }
        points.push(p);
    }
    points
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_clouds_match_in_core(
        dim in 2u8..=3,
        seed in any::<u64>(),
        n in 0usize..4000,
        bits in 3u32..12,
        leaf in 1usize..64,
        multiple in 1usize..8,
        levels in proptest::option::of(0u16..14),
    ) {
        let frame = LatticeFrame::around_box([0.0; 3], [1.0; 3], bits, dim);
        let points = cloud(dim, seed, n, bits);
        let construction = match levels {
            Some(l) => Construction::Levels(l.min(dim as u16 * bits as u16)),
            None => Construction::LeafTriangles(leaf),
        };
        check("cloud", frame, &points, None, construction, &[leaf * multiple]);
    }
}
