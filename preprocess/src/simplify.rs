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
//!
//! Merging a level: meshopt ignores the link condition at times, and two diamonds can both
//! close a fin onto the same locked vertices, so a merge could give an edge more than two
//! triangles. The build never lets one do that to an edge that had at most two. The diamonds
//! of a level are simplified in parallel against the same current mesh, each checking its own
//! output against it; a batch is then merged at once, holding back every diamond that conflicts
//! alone or would over-fill an edge together with diamonds before it in level order
//! (`split_batch`). The held-back ones are simplified again against the mesh with the batch
//! merged, with the vertices around the blocking edges locked (finally all of their vertices,
//! which changes nothing), and merged in a later batch. A vertex with all its triangles in D's
//! gathered set (an *interior* vertex) has its edges' counts known locally, and no other
//! diamond of the level can touch those edges, so only edges between two shared vertices need
//! the global counts. Merging a batch is a sum of count changes (`CurrentMesh::merge`), so the
//! result depends neither on the order within a batch nor on the number of threads.

mod current_mesh;
mod local_edges;

use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use meshopt::{SimplifyOptions, VertexDataAdapter};
use rayon::prelude::*;
use tessera_core::leb::{Diamond, PreparedSimplex, Simplex, SimplexKey};

use crate::frame::LatticeFrame;
use crate::hierarchy::Hierarchy;
use crate::local_mesh::{local_mesh, LocalMesh};
use crate::mesh::InputMesh;
use current_mesh::{edge_key, triangle_edges, CountChanges};
use local_edges::LocalEdges;

pub use current_mesh::CurrentMesh;

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
    effect: MergeEffect,
}

/// What merging a diamond would do to the current mesh it was simplified against.
struct MergeEffect {
    /// The count changes.
    changes: CountChanges,
    /// Edges the merge would give more than two triangles, and more than they have.
    conflicts: Vec<u64>,
    /// (edge, growth) of the edges whose use count the merge raises and whose endpoints are
    /// both shared with the rest of the current mesh: the only edges another diamond of the
    /// level can also change.
    shared_growth: Vec<(u64, i32)>,
}

/// A diamond not merged yet, with the locks its earlier conflicts added.
struct Pending {
    result: DiamondResult,
    extra_locks: HashSet<u32>,
    attempts: usize,
}

/// Everything a diamond's simplification reads (shared by the parallel workers).
struct Context<'a> {
    mesh: &'a InputMesh,
    frame: &'a LatticeFrame,
    /// f32 positions relative to the model origin, in model sizes: what meshopt sees.
    positions: Vec<[f32; 3]>,
    /// Model units per unit of `positions` (meshopt's errors are multiplied by it).
    size: f64,
    settings: SimplifySettings,
}

/// How each diamond is simplified.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimplifySettings {
    /// Share of its gathered triangles a diamond aims to keep. A diamond has half as many
    /// simplices as the children it replaces, so 0.5 keeps patches about the same size at
    /// every level; less makes coarse patches smaller (coarser faster), more larger.
    pub keep: f32,
    /// Weight of unit normals against positions (in model sizes) in meshopt's attribute
    /// metric, where the input has normals: at 0.05 a normal turned by one radian weighs like a
    /// displacement of 5 % of the model — a mild preference for keeping shading, the same for
    /// every model whatever its units.
    pub normal_weight: f32,
    /// Keep the input's border edges (hole and outline edges inside a diamond) exactly, or let
    /// meshopt shorten border chains (it collapses a border vertex only along its border).
    /// `BuildConfig::for_domain` keeps them for meshes and frees them for height fields, whose outline otherwise
    /// fills every coarse patch with slivers fanned between the outline's samples. Either way
    /// every vertex shared with the rest of the mesh stays locked, so cuts stay crack-free;
    /// the check accepts a cut border that simplifies an input border loop
    /// (`geometric_check.rs`).
    pub keep_borders: bool,
}

impl Default for SimplifySettings {
    fn default() -> Self {
        SimplifySettings {
            keep: 0.5,
            normal_weight: 0.05,
            keep_borders: true,
        }
    }
}

/// Simplifies every split diamond of `hierarchy`, finest level first.
/// Positions go to meshopt relative to the model origin and in model sizes (`LatticeFrame`), in
/// f32; normals (if any) are simplification attributes; errors come back in model units.
/// `current` is `CurrentMesh::new(mesh)` (built by the caller so that it can overlap with the
/// hierarchy's construction).
///
/// Guarantee: after each diamond's merge (in the order of the batches, any order within a
/// batch), no edge of the current mesh has more than two triangles unless it had that many
/// before (the input's own non-manifold edges). The output is the same for any number of
/// threads.
pub fn simplify_hierarchy(
    mesh: &InputMesh,
    hierarchy: &Hierarchy,
    mut current: CurrentMesh,
    settings: &SimplifySettings,
) -> Simplified {
    let frame = &hierarchy.frame;
    let size = frame.model_size();
    let mut positions: Vec<[f32; 3]> = mesh
        .positions
        .par_iter()
        .map(|&p| frame.relative(p).map(|x| (x / size) as f32))
        .collect();
    separate_coincident(&mut positions);
    let ctx = Context {
        mesh,
        frame,
        positions,
        size,
        settings: *settings,
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
        let mut pending: Vec<Pending> = level_group
            .par_iter()
            .map(|&d| Pending {
                result: simplify_diamond(
                    &ctx,
                    d,
                    &hierarchy.diamonds[d],
                    &patches,
                    &current,
                    &no_extra,
                ),
                extra_locks: HashSet::default(),
                attempts: 0,
            })
            .collect();
        while !pending.is_empty() {
            let (clean, dirty) = split_batch(pending, &current);
            current.merge(clean.iter().map(|p| &p.result.effect.changes));
            debug_assert!(
                clean
                    .iter()
                    .flat_map(|p| &p.result.effect.changes.edges)
                    .all(|&(e, d)| d <= 0 || current.edge_count(e) <= 2),
                "a merge raised an edge above two triangles"
            );
            for p in clean {
                let r = p.result;
                own_error[r.diamond] = r.error;
                locked_vertices += r.locked;
                patches.extend(r.patches);
            }
            // Simplify the others again against the mesh with the batch merged, with more
            // locks.
            pending = dirty
                .into_par_iter()
                .map(|(mut p, blocked)| {
                    p.lock_more(&blocked);
                    let d = p.result.diamond;
                    p.result = simplify_diamond(
                        &ctx,
                        d,
                        &hierarchy.diamonds[d],
                        &patches,
                        &current,
                        &p.extra_locks,
                    );
                    p
                })
                .collect();
        }
    }
    Simplified {
        patches,
        own_error,
        locked_vertices,
    }
}

/// Re-simplifications with a growing lock set before locking the whole diamond (which keeps
/// its gathered triangles as they are and so raises no edge's count).
const MAX_RESIMPLIFY: usize = 4;

/// A pending diamond kept out of a batch, and the edges that kept it out.
type HeldBack = (Pending, Vec<u64>);

impl Pending {
    /// Adds locks for another attempt: around the edges that blocked its merge, or, after
    /// `MAX_RESIMPLIFY` attempts, every vertex.
    fn lock_more(&mut self, blocked: &[u64]) {
        let gathered = &self.result.gathered;
        if self.attempts >= MAX_RESIMPLIFY {
            self.extra_locks.extend(gathered.iter().flatten().copied());
        } else {
            self.extra_locks.extend(one_ring(gathered, blocked));
        }
        self.attempts += 1;
    }
}

/// Splits the pending diamonds of a level into a batch that can be merged at once and the
/// others, each with the edges that block it: its own conflicts, and the shared edges that
/// diamonds before it (in level order) already raise to two triangles. Only shared edges can
/// be raised by two diamonds (see the module comment). A diamond counted here may still be
/// held back for another edge; counting it anyway only holds back more, never too few.
fn split_batch(pending: Vec<Pending>, current: &CurrentMesh) -> (Vec<Pending>, Vec<HeldBack>) {
    let mut growth: Vec<(u64, usize, i32)> = pending
        .iter()
        .enumerate()
        .flat_map(|(i, p)| {
            p.result
                .effect
                .shared_growth
                .iter()
                .map(move |&(e, d)| (e, i, d))
        })
        .collect();
    growth.sort_unstable();
    let mut blocked: Vec<Vec<u64>> = pending
        .iter()
        .map(|p| p.result.effect.conflicts.clone())
        .collect();
    for run in growth
        .chunk_by(|a, b| a.0 == b.0)
        .filter(|run| run.len() > 1)
    {
        let mut count = current.edge_count(run[0].0) as i64;
        for &(e, i, d) in run {
            if count + d as i64 > 2 {
                blocked[i].push(e);
            } else {
                count += d as i64;
            }
        }
    }
    let (clean, dirty): (Vec<_>, Vec<_>) = pending
        .into_iter()
        .zip(blocked)
        .partition(|(_, blocked)| blocked.is_empty());
    (clean.into_iter().map(|(p, _)| p).collect(), dirty)
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
    let mesh = ctx.mesh;
    let (gathered, source) = gather(diamond, patches);
    let local = local_mesh(&gathered, mesh.positions.len());
    // Interior vertices: every triangle using them is in the gathered set.
    let interior: Vec<bool> = local
        .global_of
        .iter()
        .zip(&local.uses)
        .map(|(&g, &n)| n == current.use_count(g))
        .collect();
    let gathered_edges = LocalEdges::count(interior.len(), &local.indices);
    let mut lock = lock_vertices(&gathered_edges, &interior, ctx.settings.keep_borders);
    if !extra_locks.is_empty() {
        for (l, g) in lock.iter_mut().zip(&local.global_of) {
            *l |= extra_locks.contains(g);
        }
    }
    // Keep the triangles around non-manifold edges exactly: with only the edge's endpoints
    // locked, meshopt may fold two of the sheets onto each other and drop them both, leaving
    // the edge with one triangle where the input has three.
    if current.may_have_nonmanifold() {
        for (t, tri) in local.indices.chunks_exact(3).zip(&gathered) {
            if triangle_edges(tri)
                .iter()
                .any(|&(a, b)| current.is_nonmanifold(edge_key(a, b)))
            {
                for &l in t {
                    lock[l as usize] = true;
                }
            }
        }
    }
    let locked = lock.iter().filter(|&&l| l).count();
    let (mut simplified, error) = simplify_locked(
        &local.indices,
        &local.global_of,
        &lock,
        &ctx.positions,
        mesh,
        &ctx.settings,
    );
    // meshopt's absolute error is in model sizes.
    let error = (error as f64 * ctx.size) as f32;
    cancel_coincident_pairs(&mut simplified, &local.indices, interior.len());
    let patches = distribute(ctx, diamond, &local, &source, &simplified);
    let effect = merge_effect(&local, &interior, &gathered_edges, &simplified, current);
    DiamondResult {
        diamond: index,
        patches,
        error,
        locked,
        gathered,
        effect,
    }
}

/// The triangles of the patches of the children of D's simplices, and for each the index of
/// the simplex of D it came from.
fn gather(
    diamond: &Diamond,
    patches: &HashMap<SimplexKey, Vec<[u32; 3]>>,
) -> (Vec<[u32; 3]>, Vec<u8>) {
    let mut gathered: Vec<[u32; 3]> = Vec::new();
    let mut source: Vec<u8> = Vec::new();
    for (slot, s) in diamond.simplices.iter().enumerate() {
        for c in s.children() {
            let tris = patches.get(&c.key).map(Vec::as_slice).unwrap_or(&[]);
            gathered.extend_from_slice(tris);
            source.resize(gathered.len(), slot as u8);
        }
    }
    (gathered, source)
}

/// Hands the simplified triangles (`simplified`, local ids) to the simplices of D: a triangle
/// the simplifier kept stays with the simplex it came from (`source`; its barycentre is in
/// that simplex's child), a new one goes to the simplex holding its barycentre.
fn distribute(
    ctx: &Context,
    diamond: &Diamond,
    local: &LocalMesh,
    source: &[u8],
    simplified: &[u32],
) -> Vec<(SimplexKey, Vec<[u32; 3]>)> {
    let mut out: Vec<(SimplexKey, Vec<[u32; 3]>)> = diamond
        .simplices
        .iter()
        .map(|s| {
            let share = simplified.len() / 3 / diamond.simplices.len();
            (s.key, Vec::with_capacity(share + 8))
        })
        .collect();
    // Keys are local ids in the triangle's own rotation; a repeated triangle keeps its last
    // source.
    let key = |t: &[u32]| ((t[0] as u128) << 64) | ((t[1] as u128) << 32) | t[2] as u128;
    let came_from: HashMap<u128, u8> = local
        .indices
        .chunks_exact(3)
        .zip(source)
        .map(|(t, &slot)| (key(t), slot))
        .collect();
    let prepared: Vec<PreparedSimplex> = diamond.simplices.iter().map(Simplex::prepared).collect();
    for t in simplified.chunks_exact(3) {
        let tri = [0, 1, 2].map(|k| local.global_of[t[k] as usize]);
        let slot = match came_from.get(&key(t)) {
            Some(&slot) => slot as usize,
            None => holder(
                &diamond.simplices,
                &prepared,
                barycenter_lattice(&tri, ctx.mesh, ctx.frame),
            ),
        };
        out[slot].1.push(tri);
    }
    out
}

/// What merging D (its gathered triangles `local` replaced by `simplified`) does to the
/// current mesh: the count changes, and the edges it could over-fill.
fn merge_effect(
    local: &LocalMesh,
    interior: &[bool],
    gathered_edges: &LocalEdges,
    simplified: &[u32],
    current: &CurrentMesh,
) -> MergeEffect {
    let global_of = &local.global_of;
    let mut effect = MergeEffect {
        changes: CountChanges {
            vertices: Vec::new(),
            edges: Vec::new(),
        },
        conflicts: Vec::new(),
        shared_growth: Vec::new(),
    };
    let output_edges = LocalEdges::count(interior.len(), simplified);
    let mut kept = vec![false; gathered_edges.len()];
    for (_, a, b, after) in output_edges.iter() {
        let before = match gathered_edges.find(a, b) {
            Some(i) => {
                kept[i] = true;
                gathered_edges.uses(i)
            }
            None => 0,
        };
        if before == after {
            continue;
        }
        let growth = after as i32 - before as i32;
        let key = edge_key(global_of[a as usize], global_of[b as usize]);
        effect.changes.edges.push((key, growth));
        if growth > 0 {
            // An edge with an interior endpoint has all its triangles here.
            let shared = !interior[a as usize] && !interior[b as usize];
            let before = if shared {
                current.edge_count(key)
            } else {
                before
            };
            if before as i64 + growth as i64 > 2 {
                effect.conflicts.push(key);
            }
            if shared {
                effect.shared_growth.push((key, growth));
            }
        }
    }
    for (i, a, b, before) in gathered_edges.iter() {
        if !kept[i] {
            let key = edge_key(global_of[a as usize], global_of[b as usize]);
            effect.changes.edges.push((key, -(before as i32)));
        }
    }
    let mut out_uses = vec![0u32; global_of.len()];
    for &l in simplified {
        out_uses[l as usize] += 1;
    }
    effect.changes.vertices = (0..global_of.len())
        .filter(|&l| out_uses[l] != local.uses[l])
        .map(|l| (global_of[l], out_uses[l] as i32 - local.uses[l] as i32))
        .collect();
    effect.changes.sort_by_shard();
    effect
}

/// Locks a vertex when the rest of the current mesh also uses it (it is not interior), or when
/// it lies on a non-manifold edge of the gathered set, or (with `keep_borders`) on a border
/// edge (holes of the scan): all keep every conforming cut's borders where the input has them.
fn lock_vertices(gathered_edges: &LocalEdges, interior: &[bool], keep_borders: bool) -> Vec<bool> {
    let mut lock: Vec<bool> = interior.iter().map(|&i| !i).collect();
    for (_, a, b, uses) in gathered_edges.iter() {
        if uses > 2 || (uses == 1 && keep_borders) {
            lock[a as usize] = true;
            lock[b as usize] = true;
        }
    }
    lock
}

/// Removes triangles that come in pairs on the same three vertices where the simplification
/// made them. meshopt's collapses can fold a valence-3 fan into two back-to-back copies of one
/// triangle: a zero-volume flap that makes its edges non-manifold. Dropping copies two at a
/// time keeps every edge's use count parity, so borders (odd counts) are untouched.
///
/// Copies the gathered set already had (`gathered`, local ids: the input's own duplicate
/// triangles, which a caller may pass to the build) are the input's and stay: a vertex set
/// with k copies in `gathered` and m > k in `indices` keeps k + (m − k) mod 2 of them (the
/// first ones), one with m ≤ k keeps all m. Dropping the input's duplicates in pairs, as this
/// once did, left their edges with one triangle where the input has three: a crack at every
/// coarse cut (19,362 cracked edges over 80 bunny cuts with 100 triangles doubled,
/// `tests/numerical_extremes.rs`).
fn cancel_coincident_pairs(indices: &mut Vec<u32>, gathered: &[u32], vertex_count: usize) {
    let runs = coincident_runs(indices, vertex_count);
    if runs.is_empty() {
        return; // the common case: no repeated triangle
    }
    // How many copies of each repeated vertex set the gathered set had.
    let mut had: HashMap<[u32; 3], usize> = runs.iter().map(|(k, _)| (*k, 0)).collect();
    for t in gathered.chunks_exact(3) {
        if let Some(n) = had.get_mut(&sorted(&[t[0], t[1], t[2]])) {
            *n += 1;
        }
    }
    let mut drop: Vec<u32> = Vec::new();
    for (key, run) in &runs {
        let keep = run.len().min(had[key]);
        let excess = run.len() - keep;
        // The run is in triangle order: keep its first `keep + excess % 2`.
        drop.extend(run.iter().skip(keep + excess % 2));
    }
    if drop.is_empty() {
        return;
    }
    drop.sort_unstable();
    let mut kept = Vec::with_capacity(indices.len());
    let mut next_drop = drop.iter().peekable();
    for (t, tri) in indices.chunks_exact(3).enumerate() {
        if next_drop.peek() == Some(&&(t as u32)) {
            next_drop.next();
        } else {
            kept.extend_from_slice(tri);
        }
    }
    *indices = kept;
}

/// The vertex sets used by more than one triangle of `indices` (local ids below
/// `vertex_count`), each with its triangles in order.
fn coincident_runs(indices: &[u32], vertex_count: usize) -> Vec<([u32; 3], Vec<u32>)> {
    // Copies share their smallest vertex: bucket the triangles by it (counting sort), then
    // look for equal vertex sets inside each (small) bucket.
    let triangles = indices.len() / 3;
    let mut start = vec![0u32; vertex_count + 1];
    let sorted_of = |t: usize| sorted(&[indices[3 * t], indices[3 * t + 1], indices[3 * t + 2]]);
    for t in 0..triangles {
        start[sorted_of(t)[0] as usize + 1] += 1;
    }
    for i in 0..vertex_count {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut bucketed = vec![0u32; triangles];
    for t in 0..triangles {
        let lo = sorted_of(t)[0] as usize;
        bucketed[fill[lo] as usize] = t as u32;
        fill[lo] += 1;
    }
    let mut runs = Vec::new();
    let mut bucket: Vec<([u32; 3], u32)> = Vec::new();
    for lo in 0..vertex_count {
        let range = start[lo] as usize..start[lo + 1] as usize;
        if range.len() < 2 {
            continue;
        }
        bucket.clear();
        bucket.extend(bucketed[range].iter().map(|&t| (sorted_of(t as usize), t)));
        bucket.sort_unstable();
        for run in bucket
            .chunk_by(|a, b| a.0 == b.0)
            .filter(|run| run.len() > 1)
        {
            runs.push((run[0].0, run.iter().map(|&(_, t)| t).collect()));
        }
    }
    runs
}

/// meshopt simplification to `settings.keep` of the triangles with the given locks; returns
/// local indices and the absolute error (in the units of `positions`).
fn simplify_locked(
    indices: &[u32],
    global_of: &[u32],
    lock: &[bool],
    positions: &[[f32; 3]],
    mesh: &InputMesh,
    settings: &SimplifySettings,
) -> (Vec<u32>, f32) {
    if indices.is_empty() {
        return (Vec::new(), 0.0);
    }
    let local_positions: Vec<[f32; 3]> = global_of.iter().map(|&g| positions[g as usize]).collect();
    let bytes: &[u8] = bytemuck::cast_slice(&local_positions);
    let adapter = VertexDataAdapter::new(bytes, 12, 0).expect("tightly packed f32x3 positions");
    let target = ((indices.len() / 3) as f64 * settings.keep as f64) as usize * 3;
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
                &[settings.normal_weight; 3],
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

fn barycenter_lattice(tri: &[u32; 3], mesh: &InputMesh, frame: &LatticeFrame) -> [f64; 3] {
    frame.barycentre(tri.map(|v| mesh.positions[v as usize]))
}

/// Moves apart, by a few f32 ulps, distinct vertices whose f32 positions coincide (detail
/// below f32 resolution; the welded input has no two vertices at the same f64 position).
///
/// Why: meshopt identifies vertices by position (attribute "wedges") and drops every triangle
/// with two corners at one position, even a triangle no collapse touched, so a closed surface
/// of such detail would come out open — a crack by ids. With every position unique, meshopt
/// sees only the topology we give it. The nudge (a relative 1e-7 of the model) changes the
/// simplifier's decisions, not the stored positions, which come from the f64 input.
fn separate_coincident(positions: &mut [[f32; 3]]) {
    let key = |p: &[f32; 3]| p.map(f32::to_bits);
    let mut order: Vec<u32> = (0..positions.len() as u32).collect();
    order.par_sort_unstable_by_key(|&v| (key(&positions[v as usize]), v));
    let duplicates: Vec<u32> = order
        .chunk_by(|&a, &b| key(&positions[a as usize]) == key(&positions[b as usize]))
        .flat_map(|run| run[1..].iter().copied())
        .collect();
    if duplicates.is_empty() {
        return; // the common case
    }
    let mut taken: HashSet<[u32; 3]> = positions.iter().map(key).collect();
    for v in duplicates {
        // Step x, then y, then z up one ulp at a time until the position is free.
        let mut p = positions[v as usize];
        for k in 0.. {
            let axis = k % 3;
            p[axis] = p[axis].next_up();
            if taken.insert(key(&p)) {
                break;
            }
        }
        positions[v as usize] = p;
    }
}

/// The simplex of the diamond that holds `b` (`prepared` are the simplices' facet planes);
/// when simplification moved a triangle's barycentre outside the diamond, the simplex with the
/// nearest centroid.
fn holder(simplices: &[Simplex], prepared: &[PreparedSimplex], b: [f64; 3]) -> usize {
    if let Some(i) = prepared.iter().position(|s| s.contains_point(b)) {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn cancelled(output: &[[u32; 3]], gathered: &[[u32; 3]]) -> Vec<[u32; 3]> {
        let mut indices: Vec<u32> = output.iter().flatten().copied().collect();
        let gathered: Vec<u32> = gathered.iter().flatten().copied().collect();
        cancel_coincident_pairs(&mut indices, &gathered, 8);
        indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect()
    }

    #[test]
    fn pairs_the_simplifier_made_are_cancelled() {
        let base = [[0, 1, 2], [2, 1, 3]];
        // A flap: two back-to-back copies of a triangle the gathered set did not have.
        let out = cancelled(&[[0, 1, 2], [4, 5, 6], [6, 5, 4]], &base);
        assert_eq!(out, vec![[0, 1, 2]]);
        // Three copies: the first stays (edge use parity kept).
        let out = cancelled(&[[4, 5, 6], [6, 5, 4], [5, 6, 4]], &base);
        assert_eq!(out, vec![[4, 5, 6]]);
    }

    /// The input's own duplicates (the builder accepts them) are kept: dropping them in pairs
    /// opened a crack at every coarse cut.
    #[test]
    fn duplicates_the_input_had_are_kept() {
        let gathered = [[0, 1, 2], [0, 1, 2], [2, 1, 3], [3, 1, 2]];
        let out = cancelled(&gathered, &gathered);
        assert_eq!(out, gathered.to_vec());
        // One more pair on top of the input's two copies: only the new pair goes.
        let out = cancelled(&[[0, 1, 2], [0, 1, 2], [1, 2, 0], [2, 0, 1]], &gathered);
        assert_eq!(out, vec![[0, 1, 2], [0, 1, 2]]);
        // Fewer copies than the input had: nothing is added or dropped.
        let out = cancelled(&[[0, 1, 2]], &gathered);
        assert_eq!(out, vec![[0, 1, 2]]);
    }
}
