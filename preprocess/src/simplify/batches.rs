//! Merging a level in batches (the module comment of `simplify` says why): what merging a
//! diamond would change (`merge_effect`), the counts it needs from the rest of the mesh
//! (`query_edges`, `DiamondResult::resolve`), the batch that can merge at once
//! (`split_batch`) and the locks a held-back diamond gets for its next attempt.

use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use super::current_mesh::{edge_key, CountChanges, CurrentMesh};
use super::local_edges::LocalEdges;
use super::{ConformityError, DiamondResult};
use crate::hierarchy::Hierarchy;
use crate::local_mesh::LocalMesh;

/// What merging a diamond would do to the current mesh it was simplified against.
pub(super) struct MergeEffect {
    /// The count changes.
    pub(super) changes: CountChanges,
    /// Edges with an interior endpoint the merge would give more than two triangles, and more
    /// than they have (their counts are all local).
    pub(super) local_conflicts: Vec<u64>,
    /// (edge, growth) of the edges whose use count the merge raises and whose endpoints are
    /// both shared with the rest of the current mesh: the only edges another diamond of the
    /// level can also change, and the only ones whose counts need the rest of the mesh.
    pub(super) shared_growth: Vec<(u64, i32)>,
    /// All edges the merge would give more than two triangles, and more than they have:
    /// `local_conflicts` and the shared edges so raised (`DiamondResult::resolve`).
    pub(super) conflicts: Vec<u64>,
}

/// A diamond not merged yet, with the locks its earlier conflicts added.
pub(super) struct Pending {
    pub(super) result: DiamondResult,
    pub(super) extra_locks: HashSet<u32>,
    pub(super) attempts: usize,
}

/// The edges whose counts in the rest of the mesh the pending diamonds need, sorted.
pub(super) fn query_edges(pending: &[Pending]) -> Vec<u64> {
    let mut query: Vec<u64> = pending
        .iter()
        .flat_map(|p| {
            let r = &p.result;
            let growth = r.effect.shared_growth.iter().map(|&(e, _)| e);
            let border = r
                .border_break_if_used_outside
                .iter()
                .map(|b| edge_key(b.a, b.b));
            growth.chain(border)
        })
        .collect();
    query.sort_unstable();
    query.dedup();
    query
}

impl DiamondResult {
    /// Completes the conflicts and the conformity check with the current mesh's counts of the
    /// edges this diamond shares with the rest (`counts`, from `query_edges`).
    pub(super) fn resolve(&mut self, counts: &HashMap<u64, u32>) {
        let count = |e: u64| counts.get(&e).copied().unwrap_or(0);
        let effect = &mut self.effect;
        effect.conflicts.clear();
        effect.conflicts.extend_from_slice(&effect.local_conflicts);
        // The counts include this diamond's own gathered triangles.
        effect.conflicts.extend(
            effect
                .shared_growth
                .iter()
                .filter(|&&(e, growth)| count(e) as i64 + growth as i64 > 2)
                .map(|&(e, _)| e),
        );
        if self.border_break.is_none() {
            self.border_break = self
                .border_break_if_used_outside
                .iter()
                .find(|b| count(edge_key(b.a, b.b)) > b.gathered_uses)
                .copied();
        }
    }

    pub(super) fn conformity_error(&self, hierarchy: &Hierarchy) -> Option<ConformityError> {
        self.border_break.map(|b| {
            let diamond = &hierarchy.diamonds[self.diamond];
            ConformityError {
                diamond: diamond.id,
                level: diamond.level,
                edge: (b.a, b.b),
                gathered_uses: b.gathered_uses,
                output_uses: b.output_uses,
            }
        })
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
    /// `gathered`: the triangles it replaces (its children's patches).
    pub(super) fn lock_more(&mut self, blocked: &[u64], gathered: &[[u32; 3]]) {
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
pub(super) fn split_batch(
    pending: Vec<Pending>,
    counts: &HashMap<u64, u32>,
) -> (Vec<Pending>, Vec<HeldBack>) {
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
        let mut count = counts.get(&run[0].0).copied().unwrap_or(0) as i64;
        for &(e, i, d) in run {
            if count + d as i64 > 2 {
                blocked[i].push(e);
            } else {
                count += d as i64;
            }
        }
    }
    // The held back leave `pending`, and the clean stay in its buffer, in order: a level's
    // pending diamonds can be many, and a copy of them all was the simplification's peak.
    let mut clean = pending;
    let mut at = 0;
    let held: Vec<Pending> = clean
        .extract_if(.., |_| {
            at += 1;
            !blocked[at - 1].is_empty()
        })
        .collect();
    let dirty = held
        .into_iter()
        .zip(blocked.into_iter().filter(|b| !b.is_empty()))
        .collect();
    (clean, dirty)
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

/// What merging D (its gathered triangles `local` replaced by `simplified`) does to the
/// current mesh: the count changes, and the edges it could over-fill.
pub(super) fn merge_effect(
    local: &LocalMesh,
    interior: &[bool],
    gathered_edges: &LocalEdges,
    output_edges: &LocalEdges,
    simplified: &[u32],
    current: &CurrentMesh,
) -> MergeEffect {
    let global_of = &local.global_of;
    let mut effect = MergeEffect {
        changes: CountChanges {
            vertices: Vec::new(),
            tracked_edges: Vec::new(),
        },
        local_conflicts: Vec::new(),
        shared_growth: Vec::new(),
        conflicts: Vec::new(),
    };
    let mut track = |key: u64, change: i32| {
        if current.is_tracked(key) {
            effect.changes.tracked_edges.push((key, change));
        }
    };
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
        track(key, growth);
        if growth > 0 {
            // An edge with an interior endpoint has all its triangles here; the others' counts
            // come from the rest of the mesh (`DiamondResult::resolve`).
            if !interior[a as usize] && !interior[b as usize] {
                effect.shared_growth.push((key, growth));
            } else if before as i64 + growth as i64 > 2 {
                effect.local_conflicts.push(key);
            }
        }
    }
    for (i, a, b, before) in gathered_edges.iter() {
        if !kept[i] {
            let key = edge_key(global_of[a as usize], global_of[b as usize]);
            track(key, -(before as i32));
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
