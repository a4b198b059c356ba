//! Diamond-by-diamond simplification (seed 001, Algorithm 5; DESIGN.md "the crack-free
//! argument"), bottom-up by level, in parallel across the diamonds of one level.
//!
//! For each split diamond D: gather the patches of the simplices created by splitting D, lock
//! every vertex that the gathered set shares with the rest of the current mesh (and every
//! vertex on a border or non-manifold edge of the gathered set), simplify to half with meshopt
//! (absolute errors, model units), and hand each output triangle to the simplex of D that holds
//! its barycentre. Vertices keep their global ids (meshopt collapses onto existing vertices),
//! so a shared vertex is the same vertex in every patch.
//!
//! Why the lock rule is exact: the "current mesh" is the input with every processed diamond
//! merged; a vertex used both inside and outside D's gathered set there is used by a triangle
//! the merge does not touch, so it must survive. Since simplification only removes vertices,
//! any patch of any cut outside D uses a subset of what the current mesh uses outside D.

use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use meshopt::{SimplifyOptions, VertexDataAdapter};
use rayon::prelude::*;
use tessera_core::leb::{Diamond, Simplex, SimplexKey};

use crate::frame::LatticeFrame;
use crate::hierarchy::Hierarchy;
use crate::mesh::InputMesh;

/// Patches of every simplex and the simplifier's own error of every split diamond.
pub struct Simplified {
    /// Triangles (global vertex ids) of every simplex of the hierarchy, leaves included.
    pub patches: HashMap<SimplexKey, Vec<[u32; 3]>>,
    /// Object-space error of each diamond's own simplification (model units), indexed like
    /// `Hierarchy::diamonds`.
    pub own_error: Vec<f32>,
    /// Vertices locked, summed over all diamonds (a statistic).
    pub locked_vertices: usize,
}

/// What simplifying one diamond produced.
struct DiamondResult {
    diamond: usize,
    patches: Vec<(SimplexKey, Vec<[u32; 3]>)>,
    error: f32,
    locked: usize,
    /// The children's triangles it replaces.
    gathered: Vec<[u32; 3]>,
    /// How the swap changes edge use counts.
    edge_delta: Vec<(u64, i32)>,
}

/// Everything a diamond's simplification reads (shared by the parallel workers).
struct Context<'a> {
    mesh: &'a InputMesh,
    frame: &'a LatticeFrame,
    /// f32 positions relative to the local origin, as meshopt sees them.
    positions: Vec<[f32; 3]>,
}

/// Simplifies every split diamond of `hierarchy`, finest level first.
/// Positions go to meshopt relative to `local_origin` in f32; normals (if any) are
/// simplification attributes. `current` is `CurrentMesh::new(mesh)` (built by the caller so
/// that it can overlap with the hierarchy's construction).
pub fn simplify_hierarchy(
    mesh: &InputMesh,
    hierarchy: &Hierarchy,
    local_origin: [f64; 3],
    mut current: CurrentMesh,
) -> Simplified {
    let ctx = Context {
        mesh,
        frame: &hierarchy.frame,
        positions: mesh
            .positions
            .iter()
            .map(|p| [0, 1, 2].map(|i| (p[i] - local_origin[i]) as f32))
            .collect(),
    };
    let mut patches: HashMap<SimplexKey, Vec<[u32; 3]>> = hierarchy
        .leaf_triangles
        .iter()
        .map(|(k, tris)| {
            (
                *k,
                tris.iter().map(|&t| mesh.triangles[t as usize]).collect(),
            )
        })
        .collect();
    let mut own_error = vec![0.0f32; hierarchy.diamonds.len()];
    let mut locked_vertices = 0;
    let mut by_level: Vec<usize> = (0..hierarchy.diamonds.len()).collect();
    by_level.sort_by_key(|&i| std::cmp::Reverse(hierarchy.diamonds[i].level));
    for level_group in
        by_level.chunk_by(|&a, &b| hierarchy.diamonds[a].level == hierarchy.diamonds[b].level)
    {
        let no_extra = HashSet::default();
        let results: Vec<DiamondResult> = level_group
            .par_iter()
            .map(|&d| {
                simplify_diamond(
                    &ctx,
                    d,
                    &hierarchy.diamonds[d],
                    &patches,
                    &current,
                    &no_extra,
                )
            })
            .collect();
        // Apply in a fixed order. A diamond whose output would give an edge of the current
        // mesh more than two triangles (meshopt ignores the link condition at times, and two
        // diamonds can both close a fin onto the same locked vertices) is simplified again with
        // the vertices around those edges locked, until it introduces none.
        for mut r in results {
            let diamond = &hierarchy.diamonds[r.diamond];
            let mut extra: HashSet<u32> = HashSet::default();
            for attempt in 0.. {
                let conflicts = current.nonmanifold_introduced(&r.edge_delta);
                if conflicts.is_empty() {
                    break;
                }
                if attempt >= MAX_RESIMPLIFY {
                    extra.extend(r.gathered.iter().flatten().copied());
                } else {
                    extra.extend(one_ring(&r.gathered, &conflicts));
                }
                r = simplify_diamond(&ctx, r.diamond, diamond, &patches, &current, &extra);
            }
            current.apply(&r);
            own_error[r.diamond] = r.error;
            locked_vertices += r.locked;
            patches.extend(r.patches);
        }
    }
    Simplified {
        patches,
        own_error,
        locked_vertices,
    }
}

/// Re-simplifications with a growing lock set before locking the whole diamond (which keeps
/// its gathered triangles as they are and so changes no edge).
const MAX_RESIMPLIFY: usize = 4;

/// The current mesh (DESIGN.md): the input with every processed diamond merged, as sharing
/// counts per vertex and use counts per edge.
pub struct CurrentMesh {
    use_count: Vec<u32>,
    edges: HashMap<u64, u32>,
    /// Whether the input has an edge with more than two triangles (the build never adds one,
    /// so without any there is nothing to protect).
    had_nonmanifold: bool,
}

fn edge_key(a: u32, b: u32) -> u64 {
    ((a.min(b) as u64) << 32) | a.max(b) as u64
}

fn triangle_edges(t: &[u32; 3]) -> [u64; 3] {
    [
        edge_key(t[0], t[1]),
        edge_key(t[1], t[2]),
        edge_key(t[2], t[0]),
    ]
}

impl CurrentMesh {
    pub fn new(mesh: &InputMesh) -> Self {
        let mut use_count = vec![0u32; mesh.positions.len()];
        let mut edges =
            HashMap::with_capacity_and_hasher(mesh.triangles.len() * 3 / 2, Default::default());
        for tri in &mesh.triangles {
            for &v in tri {
                use_count[v as usize] += 1;
            }
            for e in triangle_edges(tri) {
                *edges.entry(e).or_default() += 1;
            }
        }
        let had_nonmanifold = edges.values().any(|&n| n > 2);
        CurrentMesh {
            use_count,
            edges,
            had_nonmanifold,
        }
    }

    /// Edges that the change would leave with more than two triangles, and more than before.
    fn nonmanifold_introduced(&self, delta: &[(u64, i32)]) -> Vec<u64> {
        delta
            .iter()
            .filter(|(e, d)| {
                let before = self.edges.get(e).copied().unwrap_or(0) as i64;
                *d > 0 && before + *d as i64 > 2
            })
            .map(|(e, _)| *e)
            .collect()
    }

    /// Merges a diamond: its gathered triangles leave, its output enters.
    fn apply(&mut self, r: &DiamondResult) {
        for t in &r.gathered {
            for &v in t {
                self.use_count[v as usize] -= 1;
            }
        }
        for t in r.patches.iter().flat_map(|(_, t)| t.iter()) {
            for &v in t {
                self.use_count[v as usize] += 1;
            }
        }
        for &(e, d) in &r.edge_delta {
            let n = self.edges.entry(e).or_default();
            *n = (*n as i64 + d as i64) as u32;
            if *n == 0 {
                self.edges.remove(&e);
            }
        }
    }
}

/// Net change of each edge's use count when `gathered` is replaced by `output` (non-zero only).
fn edge_delta<'a>(
    gathered: &[[u32; 3]],
    output: impl Iterator<Item = &'a [u32; 3]>,
) -> Vec<(u64, i32)> {
    let mut changes: Vec<(u64, i32)> = gathered
        .iter()
        .flat_map(|t| triangle_edges(t).map(|e| (e, -1)))
        .chain(output.flat_map(|t| triangle_edges(t).map(|e| (e, 1))))
        .collect();
    changes.sort_unstable_by_key(|&(e, _)| e);
    changes
        .chunk_by(|a, b| a.0 == b.0)
        .map(|run| (run[0].0, run.iter().map(|&(_, d)| d).sum::<i32>()))
        .filter(|&(_, d)| d != 0)
        .collect()
}

/// Vertices of `gathered` sharing a triangle with an endpoint of any of `edges`.
fn one_ring(gathered: &[[u32; 3]], edges: &[u64]) -> HashSet<u32> {
    let centre: HashSet<u32> = edges
        .iter()
        .flat_map(|e| [(e >> 32) as u32, *e as u32])
        .collect();
    gathered
        .iter()
        .filter(|t| t.iter().any(|v| centre.contains(v)))
        .flatten()
        .copied()
        .collect()
}

fn simplify_diamond(
    ctx: &Context,
    index: usize,
    diamond: &Diamond,
    patches: &HashMap<SimplexKey, Vec<[u32; 3]>>,
    current: &CurrentMesh,
    extra_locks: &HashSet<u32>,
) -> DiamondResult {
    let (mesh, frame) = (ctx.mesh, ctx.frame);
    // Gather the children's patches into one local mesh.
    let gathered: Vec<[u32; 3]> = diamond
        .simplices
        .iter()
        .flat_map(|s| s.children())
        .flat_map(|c| {
            patches
                .get(&c.key)
                .map(Vec::as_slice)
                .unwrap_or(&[])
                .iter()
                .copied()
        })
        .collect();
    let mut local_of: HashMap<u32, u32> =
        HashMap::with_capacity_and_hasher(gathered.len(), Default::default());
    let mut global_of: Vec<u32> = Vec::new();
    let mut local_count: Vec<u32> = Vec::new();
    let mut indices: Vec<u32> = Vec::with_capacity(gathered.len() * 3);
    for tri in &gathered {
        for &g in tri {
            let l = *local_of.entry(g).or_insert_with(|| {
                global_of.push(g);
                local_count.push(0);
                (global_of.len() - 1) as u32
            });
            local_count[l as usize] += 1;
            indices.push(l);
        }
    }
    let mut lock = lock_vertices(&indices, &global_of, &local_count, &current.use_count);
    for (l, g) in lock.iter_mut().zip(&global_of) {
        *l |= extra_locks.contains(g);
    }
    // Keep the triangles around non-manifold edges exactly: with only the edge's endpoints
    // locked, meshopt may fold two of the sheets onto each other and drop them both, leaving
    // the edge with one triangle where the input has three.
    if current.had_nonmanifold {
        for (t, tri) in indices.chunks_exact(3).zip(&gathered) {
            if triangle_edges(tri)
                .iter()
                .any(|e| current.edges.get(e).is_some_and(|&n| n > 2))
            {
                for &l in t {
                    lock[l as usize] = true;
                }
            }
        }
    }
    let locked = lock.iter().filter(|&&l| l).count();
    let (mut simplified, error) =
        simplify_locked(&indices, &global_of, &lock, &ctx.positions, mesh);
    cancel_coincident_pairs(&mut simplified);
    // Distribute the output triangles among the simplices of D by barycentre.
    let mut out: Vec<(SimplexKey, Vec<[u32; 3]>)> = diamond
        .simplices
        .iter()
        .map(|s| (s.key, Vec::new()))
        .collect();
    // A triangle the simplifier kept stays with the simplex it came from (its barycentre is
    // in that simplex's child); only new triangles need a point location.
    let mut came_from: HashMap<[u32; 3], usize> =
        HashMap::with_capacity_and_hasher(gathered.len(), Default::default());
    for (slot, s) in diamond.simplices.iter().enumerate() {
        for c in s.children() {
            for t in patches.get(&c.key).map(Vec::as_slice).unwrap_or(&[]) {
                came_from.insert(*t, slot);
            }
        }
    }
    for t in simplified.chunks_exact(3) {
        let tri = [
            global_of[t[0] as usize],
            global_of[t[1] as usize],
            global_of[t[2] as usize],
        ];
        let slot = came_from
            .get(&tri)
            .copied()
            .unwrap_or_else(|| holder(&diamond.simplices, barycenter_lattice(&tri, mesh, frame)));
        out[slot].1.push(tri);
    }
    let edge_delta = edge_delta(&gathered, out.iter().flat_map(|(_, t)| t.iter()));
    DiamondResult {
        diamond: index,
        patches: out,
        error,
        locked,
        gathered,
        edge_delta,
    }
}

/// Locks a vertex when the rest of the current mesh also uses it, or when it lies on an edge
/// of the gathered set that is not used by exactly two of its triangles (holes of the scan,
/// non-manifold edges): both keep every conforming cut's borders where the input has them.
fn lock_vertices(
    indices: &[u32],
    global_of: &[u32],
    local_count: &[u32],
    use_count: &[u32],
) -> Vec<bool> {
    let mut lock: Vec<bool> = global_of
        .iter()
        .zip(local_count)
        .map(|(&g, &n)| n < use_count[g as usize])
        .collect();
    // Count edges by sorting their keys (several times faster than hashing here).
    let mut edges: Vec<u64> = indices
        .chunks_exact(3)
        .flat_map(|t| triangle_edges(&[t[0], t[1], t[2]]))
        .collect();
    edges.sort_unstable();
    for run in edges.chunk_by(|a, b| a == b) {
        if run.len() != 2 {
            lock[(run[0] >> 32) as usize] = true;
            lock[run[0] as u32 as usize] = true;
        }
    }
    lock
}

/// Removes triangles that come in pairs on the same three vertices. meshopt's collapses can
/// fold a valence-3 fan into two back-to-back copies of one triangle: a zero-volume flap that
/// makes its edges non-manifold. Dropping copies two at a time keeps every edge's use count
/// parity, so borders (odd counts) are untouched.
fn cancel_coincident_pairs(indices: &mut Vec<u32>) {
    let mut keys: Vec<[u32; 3]> = indices
        .chunks_exact(3)
        .map(|t| sorted(&[t[0], t[1], t[2]]))
        .collect();
    keys.sort_unstable();
    if keys.windows(2).all(|w| w[0] != w[1]) {
        return; // the common case: no repeated triangle
    }
    let mut copies: HashMap<[u32; 3], u32> = HashMap::default();
    for k in keys {
        *copies.entry(k).or_default() += 1;
    }
    // Keep one copy of each odd-count triangle (the first), none of an even-count one.
    let mut kept = Vec::with_capacity(indices.len());
    for t in indices.chunks_exact(3) {
        let mut key = [t[0], t[1], t[2]];
        key.sort_unstable();
        let n = copies.get_mut(&key).expect("counted above");
        if *n % 2 == 1 {
            kept.extend_from_slice(t);
            *n = 0;
        }
    }
    *indices = kept;
}

/// meshopt simplification to half the triangles with the given locks; returns local indices
/// and the absolute error (model units).
fn simplify_locked(
    indices: &[u32],
    global_of: &[u32],
    lock: &[bool],
    positions: &[[f32; 3]],
    mesh: &InputMesh,
) -> (Vec<u32>, f32) {
    if indices.is_empty() {
        return (Vec::new(), 0.0);
    }
    let local_positions: Vec<[f32; 3]> = global_of.iter().map(|&g| positions[g as usize]).collect();
    let bytes: &[u8] = bytemuck::cast_slice(&local_positions);
    let adapter = VertexDataAdapter::new(bytes, 12, 0).expect("tightly packed f32x3 positions");
    let target = (indices.len() / 3 / 2) * 3;
    let options = SimplifyOptions::ErrorAbsolute;
    let mut error = 0.0f32;
    let out = match &mesh.normals {
        Some(normals) => {
            let attributes: Vec<f32> = global_of
                .iter()
                .flat_map(|&g| normals[g as usize])
                .collect();
            meshopt::simplify_with_attributes_and_locks(
                indices,
                &adapter,
                &attributes,
                &[NORMAL_WEIGHT; 3],
                12,
                lock,
                target,
                f32::MAX,
                options,
                Some(&mut error),
            )
        }
        None => meshopt::simplify_with_locks(
            indices,
            &adapter,
            lock,
            target,
            f32::MAX,
            options,
            Some(&mut error),
        ),
    };
    (out, error)
}

/// Weight of unit normals against positions in meshopt's attribute metric (meshopt's docs
/// suggest ~0.5 for normals with an absolute error in mesh units this is a mild preference).
const NORMAL_WEIGHT: f32 = 0.5;

fn barycenter_lattice(tri: &[u32; 3], mesh: &InputMesh, frame: &LatticeFrame) -> [f64; 3] {
    let p = tri.map(|v| mesh.positions[v as usize]);
    frame.to_lattice([0, 1, 2].map(|i| (p[0][i] + p[1][i] + p[2][i]) / 3.0))
}

/// The simplex of the diamond that holds `b`; when simplification moved a triangle's
/// barycentre outside the diamond, the simplex with the nearest centroid.
fn holder(simplices: &[Simplex], b: [f64; 3]) -> usize {
    if let Some(i) = simplices.iter().position(|s| s.contains_point(b)) {
        return i;
    }
    let centroid = |s: &Simplex| {
        let mut c = [0.0; 3];
        for v in &s.vertices[..4] {
            for i in 0..3 {
                c[i] += v[i] as f64 / 4.0;
            }
        }
        c
    };
    let dist2 = |c: [f64; 3]| (0..3).map(|i| (c[i] - b[i]).powi(2)).sum::<f64>();
    (0..simplices.len())
        .min_by(|&x, &y| dist2(centroid(&simplices[x])).total_cmp(&dist2(centroid(&simplices[y]))))
        .unwrap_or(0)
}

/// A triangle's vertex ids in ascending order: its identity regardless of rotation/winding.
fn sorted(t: &[u32; 3]) -> [u32; 3] {
    let mut k = *t;
    k.sort_unstable();
    k
}
