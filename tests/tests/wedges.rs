//! Wedges (issue 47 item 1, `preprocess/src/mesh.rs`): corners at one position that differ in
//! normal or texture coordinate stay distinct wedges of one vertex through import, build and
//! every cut, sharing its global id, so that texture seams and hard edges survive while the
//! crack check by global id stays clean.

use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;

use tessera_core::cut::{diamond_rhos, select_stateless};
use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_core::repository::format::oct_decode_normal;
use tessera_preprocess::import::{load_mesh, weld, RawMesh};
use tessera_preprocess::normals::compute_missing_normals_creased;
use tessera_preprocess::{BuildConfig, Construction, InputMesh};
use tessera_runtime::geometric_check::{check_cuts, decode_all_patches, CheckConfig};
use tessera_tests::{build, Built};

/// A cube face: its normal, its u and v axes and its origin.
type Face = ([f64; 3], [f64; 3], [f64; 3], [f64; 3]);

/// A wedge's normal and texture coordinate.
type Wedge = ([f32; 3], [f32; 2]);

/// A cube of side 1 as an OBJ, each face an `n` x `n` grid: positions shared along the cube's
/// edges, each face its own normal (hard edges) and its own texture chart (a seam on every
/// edge): `f v/vt/vn` corners.
fn cube_obj(n: usize) -> String {
    let mut obj = String::new();
    let mut vertex_of: HashMap<[i64; 3], usize> = HashMap::new();
    let mut vertices = 0;
    let mut texcoords = 0;
    // (normal, u axis, v axis, origin) of each face, counter-clockwise seen from outside.
    let faces: [Face; 6] = [
        ([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [1., 0., 0.]),
        ([-1., 0., 0.], [0., 0., 1.], [0., 1., 0.], [0., 0., 0.]),
        ([0., 1., 0.], [0., 0., 1.], [1., 0., 0.], [0., 1., 0.]),
        ([0., -1., 0.], [1., 0., 0.], [0., 0., 1.], [0., 0., 0.]),
        ([0., 0., 1.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]),
        ([0., 0., -1.], [0., 1., 0.], [1., 0., 0.], [0., 0., 0.]),
    ];
    for (f, (normal, u, v, origin)) in faces.iter().enumerate() {
        writeln!(obj, "vn {} {} {}", normal[0], normal[1], normal[2]).unwrap();
        let mut corner = vec![vec![(0, 0); n + 1]; n + 1];
        for (i, row) in corner.iter_mut().enumerate() {
            for (j, c) in row.iter_mut().enumerate() {
                let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
                let p = [0, 1, 2].map(|k| origin[k] + a * u[k] + b * v[k]);
                let key = p.map(|x| (x * n as f64).round() as i64);
                let id = *vertex_of.entry(key).or_insert_with(|| {
                    writeln!(obj, "v {} {} {}", p[0], p[1], p[2]).unwrap();
                    vertices += 1;
                    vertices
                });
                // Each face's chart in its own sixth of the texture.
                writeln!(obj, "vt {} {}", (f as f64 + a) / 6.0, b).unwrap();
                texcoords += 1;
                *c = (id, texcoords);
            }
        }
        let vn = f + 1;
        for i in 0..n {
            for j in 0..n {
                let [a, b, c, d] = [
                    corner[i][j],
                    corner[i + 1][j],
                    corner[i + 1][j + 1],
                    corner[i][j + 1],
                ];
                for t in [[a, b, c], [a, c, d]] {
                    let [x, y, z] = t.map(|(v, vt)| format!("{v}/{vt}/{vn}"));
                    writeln!(obj, "f {x} {y} {z}").unwrap();
                }
            }
        }
    }
    obj
}

/// The mesh of `cube_obj(n)`, read and welded as `tessera build` does.
fn cube(n: usize) -> InputMesh {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.obj");
    std::fs::write(&path, cube_obj(n)).unwrap();
    load_mesh(&path).expect("the cube reads").mesh
}

fn small_leaves() -> BuildConfig {
    BuildConfig {
        construction: Construction::LeafTriangles(64),
        ..Default::default()
    }
}

/// How many wedges (patch vertices) and how many distinct global ids each patch holds, summed.
fn wedges_and_ids(built: &Built) -> (usize, usize) {
    let repo = &built.repo;
    let (mut wedges, mut ids) = (0, 0);
    for i in 0..repo.tets().len() {
        let patch = repo.patch(i).unwrap();
        let view = patch.view();
        let distinct: HashSet<u32> = view.global_ids().collect();
        wedges += view.global_ids().count();
        ids += distinct.len();
    }
    (wedges, ids)
}

/// The simplices the rule draws at τ = ∞ from a far eye: the coarsest cut.
fn coarsest_cut(built: &Built) -> Vec<u32> {
    let repo = &built.repo;
    let eye = [1e6, 0.3, 0.2];
    let metric = ScreenSpaceMetric::new(1080, 60.0, 1e-6);
    let rhos = diamond_rhos(
        repo.diamonds(),
        eye_local(eye, repo.header().origin),
        &metric,
    );
    select_stateless(repo.tets(), &rhos, f32::MAX)
}

#[test]
fn a_cube_with_hard_edges_and_a_seam_on_every_edge_keeps_them_and_has_no_crack() {
    let n = 24;
    let mesh = cube(n);
    let starts = mesh.vertex_starts();
    let vertices = starts.vertex_count(mesh.positions.len());
    // 6 n² + 2 vertices; every one on an edge has a wedge a face (2), a corner 3.
    assert_eq!(vertices, 6 * n * n + 2);
    assert_eq!(mesh.positions.len(), 6 * (n + 1) * (n + 1));
    assert_eq!(mesh.triangles.len(), 12 * n * n);

    let built = build(&mesh, &small_leaves());
    let report = check_cuts(
        &built.repo,
        &decode_all_patches(&built.repo).unwrap(),
        &CheckConfig::default(),
    );
    assert!(report.is_clean(), "{report:?}");
    assert!(report.cuts_checked > 0);

    // Wedges in the repository: patches hold more vertices than distinct ids.
    let (wedges, ids) = wedges_and_ids(&built);
    assert!(wedges > ids, "{wedges} patch vertices, {ids} ids");

    // Every stored wedge is one of its vertex's input wedges (normal and texture coordinate
    // together), at every level: nothing averaged, nothing taken from the other side of a seam.
    let mut input: HashMap<u32, Vec<Wedge>> = HashMap::new();
    let (normals, uvs) = (mesh.normals.as_ref().unwrap(), mesh.uvs.as_ref().unwrap());
    for w in 0..mesh.positions.len() as u32 {
        let v = starts.canonical(w);
        input
            .entry(v)
            .or_default()
            .push((normals[w as usize], uvs[w as usize]));
    }
    let repo = &built.repo;
    for i in 0..repo.tets().len() {
        let patch = repo.patch(i).unwrap();
        let view = patch.view();
        let (pn, pu) = (view.normals().unwrap(), view.uvs().unwrap());
        for (l, g) in view.global_ids().enumerate() {
            let n = oct_decode_normal(pn[l]);
            let found = input[&g]
                .iter()
                .any(|(wn, wu)| *wu == pu[l] && (0..3).map(|k| n[k] * wn[k]).sum::<f32>() > 0.9999);
            assert!(found, "tet {i}: vertex {g} stored {n:?} {:?}", pu[l]);
        }
    }
    // The coarsest cut keeps the cube's hard edges: each face flat with its own normal, and
    // it is far coarser than the input (meshopt collapses along seams).
    let cut = coarsest_cut(&built);
    let triangles: usize = cut
        .iter()
        .map(|&t| repo.tets()[t as usize].triangle_count as usize)
        .sum();
    let (mut wedges, mut ids) = (0, HashSet::new());
    for &t in &cut {
        let patch = repo.patch(t as usize).unwrap();
        wedges += patch.view().global_ids().count();
        ids.extend(patch.view().global_ids());
    }
    assert!(wedges > ids.len(), "the coarsest cut keeps the seams");
    assert!(
        triangles * 20 < mesh.triangles.len(),
        "the coarsest cut has {triangles} of {} triangles",
        mesh.triangles.len()
    );
}

/// A UV sphere: `rings` x `segments` quads, the texture's u wrapping at longitude 0 (a seam
/// of `rings - 1` vertices with u = 0 on one side and u = 1 on the other), poles with a wedge
/// a segment; no normals.
fn uv_sphere(rings: usize, segments: usize) -> InputMesh {
    let mut raw = RawMesh {
        uvs: Some(Vec::new()),
        ..Default::default()
    };
    let mut index = vec![vec![0u32; segments + 1]; rings + 1];
    for (i, row) in index.iter_mut().enumerate() {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        for (j, at) in row.iter_mut().enumerate() {
            let phi = 2.0 * std::f64::consts::PI * (j % segments) as f64 / segments as f64;
            let p = match i {
                0 => [0.0, 0.0, 1.0],
                _ if i == rings => [0.0, 0.0, -1.0],
                _ => [
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ],
            };
            *at = raw.positions.len() as u32;
            raw.positions.push(p);
            let u = j as f32 / segments as f32;
            let v = i as f32 / rings as f32;
            raw.uvs.as_mut().unwrap().push([u, v]);
        }
    }
    for i in 0..rings {
        for j in 0..segments {
            let [a, b, c, d] = [
                index[i][j],
                index[i + 1][j],
                index[i + 1][j + 1],
                index[i][j + 1],
            ];
            raw.triangles.push([a, b, c]);
            raw.triangles.push([a, c, d]);
        }
    }
    weld(raw).mesh
}

/// The triangles of the coarsest cut of `mesh` built with the defaults, checked crack-free.
fn coarsest_triangles(mesh: &InputMesh) -> (usize, Built) {
    let built = build(mesh, &BuildConfig::default());
    let report = check_cuts(
        &built.repo,
        &decode_all_patches(&built.repo).unwrap(),
        &CheckConfig::default(),
    );
    assert!(report.is_clean(), "{report:?}");
    let repo = &built.repo;
    let triangles = coarsest_cut(&built)
        .iter()
        .map(|&t| repo.tets()[t as usize].triangle_count as usize)
        .sum();
    (triangles, built)
}

#[test]
fn a_sphere_simplifies_across_its_texture_seam_without_cracks() {
    // Long thin bands: a seam of many vertices for the triangles a coarse cut needs.
    let (rings, segments) = (400, 24);
    let mesh = uv_sphere(rings, segments);
    let starts = mesh.vertex_starts();
    let vertices = starts.vertex_count(mesh.positions.len());
    assert_eq!(vertices, (rings - 1) * segments + 2);
    // The seam's second wedges, and a wedge a pole triangle.
    assert_eq!(
        mesh.positions.len(),
        vertices + rings - 1 + 2 * (segments - 1)
    );

    let (seamed, built) = coarsest_triangles(&mesh);
    let (wedges, ids) = wedges_and_ids(&built);
    assert!(wedges > ids, "{wedges} patch vertices, {ids} ids");

    // The same sphere with its seam open (the seam's second wedges made vertices of their
    // own, numbered apart): the build then locks the seam as a border.
    let mut open = mesh.clone();
    let uvs = open.uvs.clone().unwrap();
    let mut moved = HashMap::new();
    for t in &mut open.triangles {
        for w in t.iter_mut() {
            if uvs[*w as usize][0] == 1.0 && starts.canonical(*w) != *w {
                *w = *moved.entry(*w).or_insert_with(|| {
                    open.positions.push(open.positions[*w as usize]);
                    open.uvs.as_mut().unwrap().push(uvs[*w as usize]);
                    open.positions.len() as u32 - 1
                });
            }
        }
    }
    let (locked, _) = coarsest_triangles(&open);
    // Without texture coordinates there is no seam at all.
    let plain = InputMesh {
        uvs: None,
        ..weld(RawMesh {
            positions: mesh.positions.clone(),
            triangles: mesh.triangles.clone(),
            ..Default::default()
        })
        .mesh
    };
    let (smooth, _) = coarsest_triangles(&plain);
    eprintln!("coarsest cut: {seamed} triangles with the seam, {locked} with it locked, {smooth} without it");
    assert!(
        seamed * 2 < locked && seamed < rings - 1,
        "{seamed} triangles with the seam, {locked} with it locked ({} seam vertices)",
        rings - 1
    );
    assert!(
        seamed <= smooth * 3 / 2,
        "{seamed} with the seam, {smooth} without"
    );

    // Its texture coordinates are the input's: both sides of the seam still there.
    let repo = &built.repo;
    let mut us: Vec<f32> = Vec::new();
    for &t in &coarsest_cut(&built) {
        let patch = repo.patch(t as usize).unwrap();
        us.extend(patch.view().uvs().unwrap().iter().map(|uv| uv[0]));
    }
    assert!(us.contains(&0.0) && us.contains(&1.0), "{us:?}");
}

#[test]
fn corners_differing_only_in_the_sign_of_a_zero_are_one_wedge() {
    let raw = RawMesh {
        positions: vec![
            [0.0; 3],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0; 3],
            [1.0, 1.0, 0.0],
        ],
        triangles: vec![[0, 1, 2], [3, 2, 4]],
        uvs: Some(vec![
            [0.0; 2],
            [1.0, 0.0],
            [0.0, 1.0],
            [-0.0, 0.0],
            [1.0; 2],
        ]),
        ..Default::default()
    };
    let welded = weld(raw).mesh;
    assert_eq!(welded.positions.len(), 4);
    assert!(welded.vertex_starts().is_identity());
}

/// A cube without normals, its computed normals split at 60°: every stored normal, at every
/// level, is its triangle's face normal where the cube is flat (hard edges at every cut), and
/// the cuts are crack-free.
#[test]
fn computed_normals_split_at_a_crease_angle_keep_a_cube_s_edges_hard() {
    let mut mesh = cube(12);
    mesh.normals = None;
    mesh.uvs = None;
    let mesh = weld(RawMesh {
        positions: mesh.positions,
        triangles: mesh.triangles,
        ..Default::default()
    })
    .mesh;
    assert!(mesh.vertex_starts().is_identity());
    let mut creased = mesh.clone();
    assert!(compute_missing_normals_creased(&mut creased, 60.0));
    assert_eq!(creased.positions.len(), 6 * 13 * 13);
    let built = build(&creased, &small_leaves());
    let report = check_cuts(
        &built.repo,
        &decode_all_patches(&built.repo).unwrap(),
        &CheckConfig::default(),
    );
    assert!(report.is_clean(), "{report:?}");
    let repo = &built.repo;
    let h = repo.header();
    for i in 0..repo.tets().len() {
        let patch = repo.patch(i).unwrap();
        let view = patch.view();
        let normals = view.normals().unwrap();
        let p = |l: u32| {
            tessera_core::repository::format::dequantize_position(
                view.position(l as usize),
                h.bbox_min,
                h.position_step,
            )
        };
        for t in view.triangles() {
            let [a, b, c] = t.map(p);
            let u = [0, 1, 2].map(|k| b[k] - a[k]);
            let v = [0, 1, 2].map(|k| c[k] - a[k]);
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            for l in t {
                let s = oct_decode_normal(normals[l as usize]);
                let dot: f64 = (0..3).map(|k| s[k] as f64 * n[k] / len).sum();
                assert!(dot > 0.999, "tet {i}: stored {s:?}, face {n:?}");
            }
        }
    }
}

/// Per-face colours (PLY `face` red/green/blue, OFF colours after a face's indices) become
/// wedges: a square of two triangles coloured differently keeps both colours at its shared
/// edge's vertices, one vertex (global id) each.
#[test]
fn face_colours_are_wedges() {
    let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
               property float z\nelement face 2\nproperty list uchar int vertex_indices\n\
               property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n\
               0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2 255 0 0\n3 0 2 3 0 0 255\n";
    let off = "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2 1.0 0.0 0.0\n3 0 2 3 0 0 255\n";
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in [("square.ply", ply), ("square.off", off)] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let mesh = load_mesh(&path).unwrap().mesh;
        // Vertices 0 and 2 have a red and a blue wedge; 1 is red, 3 blue.
        assert_eq!(mesh.positions.len(), 6, "{name}");
        assert_eq!(mesh.vertex_starts().vertex_count(6), 4, "{name}");
        let colors = mesh.colors.as_ref().unwrap();
        for (t, want) in mesh
            .triangles
            .iter()
            .zip([[255, 0, 0, 255], [0, 0, 255, 255]])
        {
            for &w in t {
                assert_eq!(colors[w as usize], want, "{name}");
            }
        }
        // Staged out of core (46871c3, `external/face_colors.rs`): the same wedges, never
        // welded to one colour.
        let staging = tempfile::tempdir().unwrap();
        let staged = tessera_preprocess::import::stage_mesh(&path, staging.path(), 1 << 20)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let loaded = staged.load().unwrap();
        assert_eq!(loaded.positions, mesh.positions, "{name}");
        assert_eq!(loaded.triangles, mesh.triangles, "{name}");
        assert_eq!(loaded.colors, mesh.colors, "{name}");
        assert_eq!(staged.vertex_starts().unwrap().vertex_count(6), 4, "{name}");
    }
}
