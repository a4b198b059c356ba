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
//! the rest of the mesh's counts: each round asks for exactly those (`query_edges`) and counts
//! them over the live patches (`edge_census.rs`). Merging a batch is a sum of count changes
//! (`CurrentMesh::merge`), so the result depends neither on the order within a batch nor on
//! the number of threads.

mod attribute_error;
mod batches;
mod coincident;
mod conformity;
mod current_mesh;
mod distribute;
mod edge_census;
mod input_edges;
mod levels;
mod live_record;
mod live_store;
mod local_edges;
mod partial_level;
mod positions;
mod result_spill;
mod vertices;
mod weighed;

use std::borrow::Cow;

use rustc_hash::FxHashSet as HashSet;

use rayon::prelude::*;
use tessera_core::leb::{Diamond, SimplexKey};

use crate::frame::LatticeFrame;
use crate::hierarchy::Hierarchy;
use crate::local_mesh::local_mesh;
use crate::mesh::InputMesh;
use crate::vertex_table::{LivePatch, VertexTable};
use batches::{merge_effect, MergeEffect};
use coincident::cancel_coincident_pairs;
use conformity::{border_break, BorderBreak};
use current_mesh::{edge_key, triangle_edges};
use distribute::distribute;
use live_store::LiveStore;
use local_edges::LocalEdges;
pub(crate) use positions::numbering_table;
use positions::separate_coincident;
pub use positions::{simplifier_position, ulp_step};
use result_spill::{Held, Payload, ResultSpill};
use vertices::ByVertex;
use weighed::{simplify_locked, weighs_more_than_normals, LocalWedges};

pub use attribute_error::AttributeError;
pub use current_mesh::CurrentMesh;
pub use levels::LevelState;
pub(crate) use levels::{simplify_levels, LevelCheckpoints};

/// The simplifier's own error of every split diamond (the patches went to the caller's
/// `finished` as they were made).
pub struct Simplified {
    /// Object-space error of each diamond's own simplification (model units), indexed like
    /// `Hierarchy::diamonds`.
    pub own_error: Vec<f32>,
    /// Each diamond's own attribute error (`attribute_error.rs`), indexed like `own_error`;
    /// all zero where the input has neither colours nor texture coordinates (not measured).
    pub attribute_error: Vec<AttributeError>,
    /// Vertices locked, summed over all diamonds (a statistic).
    pub locked_vertices: usize,
    /// Simplifications redone because a diamond was held back from its level's batch (a
    /// statistic; each needs the rest of the mesh's edge counts, `edge_census.rs`).
    pub resimplified: usize,
}

/// What simplifying one diamond produced.
struct DiamondResult {
    diamond: usize,
    /// Its new patches and vertex count changes (`effect.changes.vertices` is left empty),
    /// in memory or spilled (`result_spill.rs`).
    payload: Held,
    error: f32,
    attribute_error: AttributeError,
    locked: usize,
    effect: MergeEffect,
    /// Where the output does not keep the gathered set's border (global ids): the build fails.
    border_break: Option<BorderBreak>,
    /// Where it does not if the rest of the mesh also uses the edge (`conformity.rs`).
    border_break_if_used_outside: Vec<BorderBreak>,
}

/// Why a simplification stopped.
#[derive(Debug, thiserror::Error)]
pub enum SimplifyError {
    #[error(transparent)]
    Conformity(#[from] ConformityError),
    /// The caller's `finished` failed (writing the patches out).
    #[error(transparent)]
    Finished(#[from] std::io::Error),
    /// A resumed build's checkpoint holds a part of a level that does not read back.
    #[error("a level's part: {0}")]
    Checkpoint(std::io::Error),
}

/// The leaves' patches, a group at a time (every leaf of the hierarchy once, each carrying its
/// vertices); `None` after the last group.
pub type LeafSource<'a> = dyn FnMut() -> std::io::Result<Option<Vec<(SimplexKey, LivePatch)>>> + 'a;

/// Patches whose triangles are final, handed to the caller as they are made.
pub type FinishedPatchSink<'a> = dyn FnMut(&[(SimplexKey, &LivePatch)]) -> std::io::Result<()> + 'a;

/// A diamond whose simplification did not keep the border of the region it replaces
/// (`conformity.rs`): the build stops rather than write a repository with cracks.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "conformity broken at diamond {diamond:?} (level {level}): edge ({}, {}) had {} triangles \
     in the patches it replaces and {} in its new patch, so the border with the rest of the \
     mesh would open (a simplifier bug)",
    edge.0, edge.1, gathered_uses, output_uses
)]
pub struct ConformityError {
    /// The diamond's id: its split edge's midpoint on the lattice.
    pub diamond: tessera_core::leb::DiamondId,
    pub level: u16,
    /// The edge, by global vertex id.
    pub edge: (u32, u32),
    pub gathered_uses: u32,
    pub output_uses: u32,
}

/// Everything a diamond's simplification reads besides its patches (shared by the parallel
/// workers).
struct Context<'a> {
    frame: &'a LatticeFrame,
    /// The input's vertex count (every global id is below it) where `local_mesh` may number
    /// through a per-thread table of that size; `None` under a tight memory budget.
    numbering_table: Option<usize>,
    settings: SimplifySettings,
    /// What a top diamond keeps at most (`coarsest_triangles`).
    coarsest_triangles: usize,
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
    /// every model whatever its units. 0: normals are not weighed.
    pub normal_weight: f32,
    /// Weight of colours (R, G, B in [0, 1]) against positions (in model sizes), where the
    /// input has colours: at 0.2 black against white (a distance of √3) weighs like a
    /// displacement of 35 % of the model. 0: colours are not weighed.
    pub colour_weight: f32,
    /// Weight of texture coordinates (UV units) against positions (in model sizes), where the
    /// input has them. 0: texture coordinates are not weighed.
    pub uv_weight: f32,
    /// Keep the input's border edges (hole and outline edges inside a diamond) exactly, or let
    /// meshopt shorten border chains (it collapses a border vertex only along its border).
    /// `BuildConfig::for_domain` keeps them for meshes and frees them for height fields, whose outline otherwise
    /// fills every coarse patch with slivers fanned between the outline's samples. Either way
    /// every vertex shared with the rest of the mesh stays locked, so cuts stay crack-free;
    /// the check accepts a cut border that simplifies an input border loop
    /// (`geometric_check.rs`).
    pub keep_borders: bool,
    /// Stored errors that are bounds (issue 13): each diamond's own error is an upper bound on
    /// the two-sided Hausdorff distance between what it gathers and what it keeps
    /// (`tessera_core::hausdorff`), and saturation sums own errors down the DAG
    /// (`saturate.rs`), so a drawn cut is within its diamonds' errors of the input. Off,
    /// the own error is meshoptimizer's estimate and saturation takes the maximum: cheaper
    /// (the bound costs most of the build's time) and about 3× smaller at the root, but not a
    /// bound.
    pub bounded_errors: bool,
    /// Share of the input's triangles the coarsest cut (the roots' patches) holds at most:
    /// the top diamond (level 0, whose simplices are the roots) keeps the smaller of `keep` of
    /// what it gathers and this share of the input. With the levels above the model's cube
    /// (`BuildConfig::headroom`) each keeping half, the cap binds only on small models
    /// (issue 46: the coarsest cut ≤ 1 % of every test scan) and finer levels are unchanged.
    pub coarsest_share: f32,
    /// Fault injection for the conformity test: meshopt gets no locks, so diamonds may move
    /// their borders and the build must stop (`ConformityError`). Never set in a real build.
    pub fault_ignore_locks: bool,
}

impl Default for SimplifySettings {
    fn default() -> Self {
        SimplifySettings {
            keep: 0.5,
            normal_weight: 0.05,
            colour_weight: DEFAULT_COLOUR_WEIGHT,
            uv_weight: DEFAULT_UV_WEIGHT,
            keep_borders: true,
            bounded_errors: false,
            // 1: no cap (off with `BuildConfig::headroom`; 0.01 with it reaches 1 %).
            coarsest_share: 1.0,
            fault_ignore_locks: false,
        }
    }
}

/// `SimplifySettings::colour_weight`'s default. Measured on `testdata/mesh/bunny-astronaut.ply`
/// (a scan coloured by a projected photograph) at 0, 0.01, 0.05, 0.2 and 1: the finest
/// simplified level's largest colour error 176, 156, 110, 45 and 23 (8-bit RGB), the root's
/// geometric error 0.136, 0.132, 0.183, 0.204 and 0.543: 0.2 cuts the colour error 4× for half
/// again the root's error, where 1 triples it (CHANGELOG.md, 2026-12-07).
pub const DEFAULT_COLOUR_WEIGHT: f32 = 0.2;
/// `SimplifySettings::uv_weight`'s default: on a 256² grid with a non-linear UV map and a colour
/// checker (`tools/tests/attribute_errors.rs`'s input, larger), 0.2 halves the finest level's
/// UV error against 0.05, and 1 lets the colour checker go at level 8 (CHANGELOG.md).
pub const DEFAULT_UV_WEIGHT: f32 = 0.2;

/// Simplifies every split diamond of `hierarchy`, finest level first.
/// Positions go to meshopt relative to the model origin and in model sizes (`LatticeFrame`), in
/// f32; normals (if any) are simplification attributes; errors come back in model units.
/// `current` is `CurrentMesh::new(mesh)` (built by the caller so that it can overlap with the
/// hierarchy's construction).
///
/// Guarantee: after each diamond's merge (in the order of the batches, any order within a
/// batch), no edge of the current mesh has more than two triangles unless it had that many
/// before (the input's own non-manifold edges). The output is the same for any number of
/// threads. Every diamond's output keeps the border of the region it replaces, or the
/// simplification stops with the first diamond (in level order) that does not.
///
/// Every simplex's patch goes to `finished` once, when it is final: the leaves' first, then
/// each merged diamond's simplices'. Only the live patches (the current mesh's) are kept here,
/// so memory follows the current mesh, not every level's patches.
pub fn simplify_hierarchy(
    mesh: &InputMesh,
    hierarchy: &Hierarchy,
    current: CurrentMesh,
    settings: &SimplifySettings,
    spill_dir: Option<&std::path::Path>,
    finished: &mut FinishedPatchSink,
) -> Result<Simplified, SimplifyError> {
    let frame = &hierarchy.frame;
    let mut positions: Vec<[f32; 3]> = mesh
        .positions
        .par_iter()
        .map(|&p| simplifier_position(frame, p))
        .collect();
    separate_coincident(&mut positions, current.vertex_starts());
    let leaves: Vec<(SimplexKey, LivePatch)> = hierarchy
        .leaf_triangles
        .par_iter()
        .map(|(k, tris)| {
            let triangles: Vec<[u32; 3]> =
                tris.iter().map(|&t| mesh.triangles[t as usize]).collect();
            let mut ids: Vec<u32> = triangles.iter().flatten().copied().collect();
            ids.sort_unstable();
            ids.dedup();
            let vertices = VertexTable::from_mesh(mesh, &positions, ids);
            (
                *k,
                LivePatch {
                    triangles,
                    vertices,
                },
            )
        })
        .collect();
    drop(positions);
    let mut leaves = Some(leaves);
    simplify_from_leaves(
        &mut || Ok(leaves.take()),
        mesh.positions.len(),
        hierarchy,
        current,
        settings,
        spill_dir,
        finished,
    )
}

/// `simplify_hierarchy` from the leaves' patches (`leaves`: every leaf of `hierarchy`, a group
/// at a time) of a mesh of `vertex_count` vertices. With `spill_dir`, the live patches wait in
/// an unnamed file there (`live_store.rs`), not in memory, and the leaves need never be in
/// memory all at once.
pub fn simplify_from_leaves(
    leaves: &mut LeafSource,
    vertex_count: usize,
    hierarchy: &Hierarchy,
    current: CurrentMesh,
    settings: &SimplifySettings,
    spill_dir: Option<&std::path::Path>,
    finished: &mut FinishedPatchSink,
) -> Result<Simplified, SimplifyError> {
    let store = LiveStore::new(spill_dir, positions::SimplifierScale::of(&hierarchy.frame))?;
    let leaf_count = hierarchy.mesh.leaf_count();
    let state = LevelState::from_leaves(leaves, leaf_count, vertex_count, current, store)?;
    LevelCheckpoints::none(|checkpoints| {
        simplify_levels(state, hierarchy, settings, spill_dir, finished, checkpoints)
    })
}

fn simplify_diamond(
    ctx: &Context,
    index: usize,
    diamond: &Diamond,
    patches: &LiveStore,
    current: &CurrentMesh,
    extra_locks: &HashSet<u32>,
    spill: &ResultSpill,
) -> std::io::Result<DiamondResult> {
    let (gathered, source, vertices) = gather(diamond, patches)?;
    // `local` numbers wedges (what meshopt simplifies, what patches draw); `by_vertex` the
    // vertices where a seam makes them differ, and everything about connectivity is theirs.
    let local = local_mesh(&gathered, ctx.numbering_table);
    let by_vertex = ByVertex::of(&local, current);
    let vmesh = by_vertex.as_ref().map_or(&local, |b| &b.mesh);
    let vertex_of = by_vertex.as_ref().map(|b| &b.vertex_of[..]);
    // Interior vertices: every triangle using them is in the gathered set.
    let interior: Vec<bool> = vmesh
        .global_of
        .iter()
        .zip(&vmesh.uses)
        .map(|(&g, &n)| n == current.use_count(g))
        .collect();
    let gathered_edges = LocalEdges::count(interior.len(), &vmesh.indices);
    let mut lock = lock_vertices(&gathered_edges, &interior, ctx.settings.keep_borders);
    if !extra_locks.is_empty() {
        for (l, g) in lock.iter_mut().zip(&vmesh.global_of) {
            *l |= extra_locks.contains(g);
        }
    }
    // Keep the triangles around non-manifold edges exactly: with only the edge's endpoints
    // locked, meshopt may fold two of the sheets onto each other and drop them both, leaving
    // the edge with one triangle where the input has three.
    if current.may_have_nonmanifold() {
        for (t, tri) in vmesh.indices.chunks_exact(3).zip(&gathered) {
            if triangle_edges(&current.starts_of(*tri))
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
    if ctx.settings.fault_ignore_locks {
        lock.fill(false);
    }
    // A locked vertex locks all its wedges.
    let wedge_lock: Vec<bool> = match vertex_of {
        Some(v) => v.iter().map(|&l| lock[l as usize]).collect(),
        None => lock,
    };
    let target = target_triangles(ctx, diamond, local.indices.len() / 3);
    let wedges = LocalWedges::of(&local.global_of, &vertices);
    let (mut simplified, estimate) = simplify_locked(
        &local.indices,
        &wedges,
        &wedge_lock,
        &vertices,
        &ctx.settings,
        target,
    );
    if let Some(b) = &by_vertex {
        b.drop_degenerate(&mut simplified);
    }
    cancel_coincident_pairs(&mut simplified, &vmesh.indices, interior.len(), vertex_of);
    let error = if own_error_is_bound(ctx, diamond) {
        if simplified.is_empty() {
            // Everything went (a small piece with no vertex shared or locked): no output
            // would be near it to bound its distance, so the piece stays as it is.
            simplified = local.indices.clone();
        }
        bounded_error(
            ctx.frame,
            &local.global_of,
            &vertices,
            &local.indices,
            &simplified,
        )
    } else {
        // meshopt's absolute error is in model sizes.
        (estimate as f64 * ctx.frame.model_size()) as f32
    };
    // Measured only where colours or texture coordinates are (what the table is written for).
    let measured = match vertices.colors.is_some() || vertices.uvs.is_some() {
        true => attribute_error::measure(
            &wedges.positions,
            &wedges.rows,
            &vertices,
            &local.indices,
            &simplified,
        ),
        false => attribute_error::Measured::default(),
    };
    let error = match (own_error_is_bound(ctx, diamond), measured.distance) {
        // meshopt's estimate mixes the weighed colours' and UVs' error into the geometric one
        // (in model sizes, where colour steps would outweigh every fine level's error): the
        // geometric estimate is then the vertex-sampled distance from what D gathers to what
        // it keeps.
        (false, Some(d)) if weighs_more_than_normals(&vertices, &ctx.settings) => {
            (d * ctx.frame.model_size()) as f32
        }
        _ => error,
    };
    let simplified_vertices = by_vertex.as_ref().map(|b| b.vertices(&simplified));
    let vsimplified = simplified_vertices.as_deref().unwrap_or(&simplified);
    let output_edges = LocalEdges::count(interior.len(), vsimplified);
    let check = border_break(
        &gathered_edges,
        &output_edges,
        &interior,
        ctx.settings.keep_borders,
    );
    let global = |b: BorderBreak| BorderBreak {
        a: vmesh.global_of[b.a as usize],
        b: vmesh.global_of[b.b as usize],
        ..b
    };
    let patches = distribute(ctx, diamond, &local, &source, &simplified, &vertices);
    let mut effect = merge_effect(
        vmesh,
        &interior,
        &gathered_edges,
        &output_edges,
        vsimplified,
        current,
    );
    let vertices = std::mem::take(&mut effect.changes.vertices);
    Ok(DiamondResult {
        diamond: index,
        payload: spill.hold(Payload { patches, vertices })?,
        error,
        attribute_error: measured.error,
        locked,
        effect,
        border_break: check.broken.map(global),
        border_break_if_used_outside: check
            .broken_if_used_outside
            .into_iter()
            .map(global)
            .collect(),
    })
}

/// The triangles of the patches of the children of D's simplices, for each the index of the
/// simplex of D it came from, and the vertices they carry.
fn gather(
    diamond: &Diamond,
    patches: &LiveStore,
) -> std::io::Result<(Vec<[u32; 3]>, Vec<u8>, VertexTable)> {
    let (gathered, source, children) = gather_patches(diamond, patches)?;
    let tables: Vec<&VertexTable> = children.iter().map(|p| &p.vertices).collect();
    Ok((gathered, source, VertexTable::merge(&tables)))
}

/// What a diamond gathers: its children's triangles, for each the slot of the simplex of D it
/// came from, and the children's patches.
type Gathered<'p> = (Vec<[u32; 3]>, Vec<u8>, Vec<Cow<'p, LivePatch>>);

/// `gather` without merging the vertex tables.
fn gather_patches<'p>(diamond: &Diamond, patches: &'p LiveStore) -> std::io::Result<Gathered<'p>> {
    let mut gathered: Vec<[u32; 3]> = Vec::new();
    let mut source: Vec<u8> = Vec::new();
    let mut children = Vec::new();
    for (slot, s) in diamond.simplices.iter().enumerate() {
        for c in s.children() {
            if let Some(patch) = patches.get(&c.key)? {
                gathered.extend_from_slice(&patch.triangles);
                children.push(patch);
            }
            source.resize(gathered.len(), slot as u8);
        }
    }
    Ok((gathered, source, children))
}

/// Locks a vertex when the rest of the current mesh also uses it (it is not interior), or when
/// it lies on a non-manifold edge of the gathered set, or (with `keep_borders`) on a border
/// edge (holes of the scan): all keep every conforming cut's borders where the input has them.
///
/// With free borders, an interior vertex on a border edge whose other end is shared is locked
/// too: collapsing it along its border onto the shared end would drop the triangle it shares
/// with an edge the rest of the mesh also uses (where a hole's outline meets the region's
/// border), and the region's border would move (`conformity.rs`).
fn lock_vertices(gathered_edges: &LocalEdges, interior: &[bool], keep_borders: bool) -> Vec<bool> {
    let mut lock: Vec<bool> = interior.iter().map(|&i| !i).collect();
    for (_, a, b, uses) in gathered_edges.iter() {
        let (a, b) = (a as usize, b as usize);
        let border = uses == 1 && (keep_borders || interior[a] != interior[b]);
        if uses > 2 || border {
            lock[a] = true;
            lock[b] = true;
        }
    }
    lock
}

/// The diamond's own error with `bounded_errors`: an upper bound on the two-sided Hausdorff
/// distance between what it gathered and what it keeps, on the input's positions (model
/// units), rounded up to f32. Saturation adds the children's errors to it, which keeps it a
/// bound on the distance to the input surface (`saturate.rs`).
///
/// Computed on the positions snapped to a grid of 1/`BOUND_GRID_STEPS` of a lattice unit, in
/// grid units: integers that are the same for the model scaled or moved (its lattice
/// coordinates are, up to their last bits), so the adaptive bound, whose refinement order
/// follows its values' last bits, makes the same decisions and a scaled model gets the same
/// errors up to one rounding (`tests/tests/numerical_extremes.rs`). Snapping moves each point
/// of either surface by at most half a grid cell's diagonal: twice that is added.
fn bounded_error(
    frame: &LatticeFrame,
    global_of: &[u32],
    vertices: &VertexTable,
    gathered: &[u32],
    kept: &[u32],
) -> f32 {
    let positions: Vec<[f64; 3]> = global_of
        .iter()
        .map(|&g| {
            let r = frame.relative(vertices.positions[vertices.row(g)]);
            // Every axis, z too for a height field (whose lattice is the x, y square).
            [0, 1, 2].map(|i| ((r[i] - frame.origin[i]) / frame.unit * BOUND_GRID_STEPS).round())
        })
        .collect();
    let h = tessera_core::hausdorff::two_sided_bound(&positions, gathered, kept);
    let cell = frame.unit / BOUND_GRID_STEPS;
    // A few f64 roundings (the sum and the products) covered before rounding up to f32.
    let bound = (h + 3f64.sqrt()) * cell * (1.0 + 8.0 * f64::EPSILON);
    let rounded = bound as f32;
    if (rounded as f64) < bound {
        rounded.next_up()
    } else {
        rounded
    }
}

/// Grid cells per lattice unit of `bounded_error`'s snapped positions: 2^28 across a model's
/// cube at the default 2^20 lattice, far below any stored error (at least the position step,
/// 2^-21 of the box).
const BOUND_GRID_STEPS: f64 = 256.0;

/// Whether D's own error is the bound of `bounded_error` rather than meshopt's estimate: with
/// `bounded_errors`, and for the diamonds above the model's cube (`BuildConfig::headroom`).
/// Those simplify a version made from the one below, not the input, and meshopt's estimate is
/// of that one step: saturated by the maximum, a far eye drew them where the chain from the
/// input did not fit τ (the lion head's dense max 3.71 px at τ = 2.8), and at equal dense
/// error the cuts drew up to 16 % more triangles than with the roots alone. With the step's
/// bound, summed along the chain from the roots' error (`saturate.rs`), they are drawn only
/// where the whole chain fits, and the fronts below the roots' error are as before. Cheap:
/// those levels hold a few times the roots' triangles.
fn own_error_is_bound(ctx: &Context, diamond: &Diamond) -> bool {
    ctx.settings.bounded_errors || ctx.frame.is_above_model(diamond.level)
}

/// The triangles a top diamond keeps at most: `share` of the input's `input_triangles` over
/// the hierarchy's `roots` (6 tetrahedra, 2 triangles), at least one a root.
fn coarsest_triangles(share: f32, input_triangles: usize, roots: usize) -> usize {
    ((input_triangles as f64 * share as f64) as usize).max(roots)
}

/// The triangles D aims to keep of the `gathered` it simplifies: `keep` of them, and for the
/// top diamond (its simplices the roots) no more than the coarsest cut's share of the input.
fn target_triangles(ctx: &Context, diamond: &Diamond, gathered: usize) -> usize {
    let kept = (gathered as f64 * ctx.settings.keep as f64) as usize;
    match diamond.level {
        0 => kept.min(ctx.coarsest_triangles),
        _ => kept,
    }
}

/// Diamonds of a batch whose payloads are back in memory at once while they merge.
const MERGE_GROUP: usize = 256;
