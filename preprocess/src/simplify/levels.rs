//! The simplification's levels, finest first, and the state between two levels
//! (`LevelState`): the live patches, the current mesh's counts and what the levels merged so
//! far found. A build's checkpoint saves that state after each level (`encode`, with the live
//! store's records) and a resumed build continues from it with the levels left: every level
//! depends only on that state, so the bytes are those of an uninterrupted build.

use rayon::prelude::*;
use rustc_hash::FxHashSet as HashSet;
use tessera_core::leb::SimplexKey;

use super::attribute_error::AttributeError;
use super::batches::{query_edges, split_batch, Pending};
use super::edge_census::count_edges;
use super::live_store::{LiveStore, StoreCheckpoint};
use super::partial_level;
use super::positions::SimplifierScale;
use super::result_spill::{Held, Payload, ResultSpill};
use super::{
    coarsest_triangles, gather_patches, numbering_table, simplify_diamond, Context, CurrentMesh,
    DiamondResult, FinishedPatchSink, LeafSource, Simplified, SimplifyError, SimplifySettings,
    MERGE_GROUP,
};
use crate::checkpoint::{Dec, Enc};
use crate::frame::LatticeFrame;
use crate::hierarchy::Hierarchy;
use crate::packed_key::PackedKey;
use crate::vertex_table::LivePatch;

fn invalid(what: &str) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidData, what.to_string())
}

/// A key read from a checkpoint, packed, or damage.
fn packed_or_invalid(key: SimplexKey) -> std::io::Result<PackedKey> {
    PackedKey::of(key).ok_or_else(|| invalid("a simplex key no hierarchy makes"))
}

/// The simplification between two levels.
pub struct LevelState {
    /// The current mesh's patches: the leaves, then each merged diamond's simplices in place of
    /// their children.
    patches: LiveStore,
    /// The simplices of the current mesh (some have no patch: no triangle).
    live: HashSet<PackedKey>,
    current: CurrentMesh,
    own_error: Vec<f32>,
    /// Indexed like `own_error` (`Simplified::attribute_error`).
    attribute_error: Vec<AttributeError>,
    locked_vertices: usize,
    resimplified: usize,
    /// Levels merged so far.
    levels_done: usize,
    /// Whether the leaves' patches went to `finished` (`finish_leaves`).
    leaves_finished: bool,
    vertex_count: usize,
    /// The input's triangles: the leaves' (`SimplifySettings::coarsest_share` is of these).
    input_triangles: usize,
}

impl LevelState {
    /// The state before the first level: every leaf's patch (from `leaves`, a group at a time)
    /// kept in `patches`. They go to `finished` when the levels start (`finish_leaves`), not
    /// here: under a budget the staged mesh is still on disk while the leaves are made, and
    /// their encoded bytes beside it and the live store made the build's temporary peak.
    /// `leaf_count`: the hierarchy's leaves, so that the live set and index are made at their
    /// size (growing, a table holds its old and its new buckets at once: at a 4097² height
    /// field the index's last doubling was the simplification's peak).
    pub(super) fn from_leaves(
        leaves: &mut LeafSource,
        leaf_count: usize,
        vertex_count: usize,
        current: CurrentMesh,
        mut patches: LiveStore,
    ) -> Result<LevelState, SimplifyError> {
        let mut live: HashSet<PackedKey> =
            HashSet::with_capacity_and_hasher(leaf_count, Default::default());
        patches.reserve(leaf_count);
        let mut input_triangles = 0;
        while let Some(group) = leaves()? {
            input_triangles += group.iter().map(|(_, p)| p.triangles.len()).sum::<usize>();
            live.extend(group.iter().map(|(key, _)| PackedKey::of_hierarchy(*key)));
            patches.insert_all(group)?;
        }
        crate::external::allocator::release_freed_memory();
        Ok(LevelState {
            patches,
            live,
            current,
            own_error: Vec::new(),
            attribute_error: Vec::new(),
            locked_vertices: 0,
            resimplified: 0,
            levels_done: 0,
            leaves_finished: false,
            vertex_count,
            input_triangles,
        })
    }

    /// `from_leaves` with the live patches in a named file of the checkpoint directory `dir`
    /// (with `hierarchy`'s frame and leaf count).
    pub fn from_leaves_in(
        leaves: &mut LeafSource,
        vertex_count: usize,
        current: CurrentMesh,
        (dir, hierarchy): (&std::path::Path, &Hierarchy),
    ) -> Result<LevelState, SimplifyError> {
        let store = LiveStore::new_named(dir, SimplifierScale::of(&hierarchy.frame))?;
        let leaf_count = hierarchy.mesh.leaf_count();
        Self::from_leaves(leaves, leaf_count, vertex_count, current, store)
    }

    /// Levels merged so far.
    pub fn levels_done(&self) -> usize {
        self.levels_done
    }

    /// Which wedges start a vertex (the current mesh's, `mesh.rs`).
    pub fn vertex_starts(&self) -> &crate::mesh::VertexStarts {
        self.current.vertex_starts()
    }

    /// Whether a checkpoint is due whatever its pacing: the live store holds removed patches,
    /// kept on disk until a commit no longer names them.
    pub fn checkpoint_wanted(&self) -> bool {
        self.patches.holds_dead_records()
    }

    /// The live store's file (name, valid bytes), `None` unless it is named. Its records are
    /// checked one by one against the CRC-32s in the state (`encode`), not as a whole file.
    pub fn store_file(&self) -> Option<(String, u64)> {
        let c = self.patches.checkpoint()?;
        Some((super::live_store::LIVE_FILE.to_string(), c.end))
    }

    /// Everything but the live store's records' bytes (which stay in its named file).
    pub(crate) fn encode(&self, e: &mut Enc) -> std::io::Result<()> {
        let store = self.patches.checkpoint().ok_or_else(|| {
            std::io::Error::other("the live patches are not in the checkpoint directory")
        })?;
        e.u64(self.vertex_count as u64);
        e.u64(self.input_triangles as u64);
        e.u64(self.levels_done as u64);
        e.u8(self.leaves_finished as u8);
        e.u64(self.locked_vertices as u64);
        e.u64(self.resimplified as u64);
        e.list(&self.own_error, |e, &x| e.f32(x));
        e.list(&self.attribute_error, |e, a| {
            e.f32(a.colour);
            e.f32(a.normal_degrees);
            e.f32(a.uv);
        });
        let mut live: Vec<PackedKey> = self.live.iter().copied().collect();
        live.sort_unstable();
        e.list(&live, |e, &k| e.key(k.key()));
        e.u64(store.end);
        e.list(&store.records, |e, &(k, at, bytes, triangles, crc)| {
            e.key(k.key());
            e.u64(at);
            e.u64(bytes as u64);
            e.u32(triangles);
            e.u32(crc);
        });
        self.current.encode(e);
        Ok(())
    }

    /// The state `encode` wrote, its live store reopened in `dir` (its hierarchy's `frame`'s).
    pub(crate) fn decode(
        d: &mut Dec,
        dir: &std::path::Path,
        frame: &LatticeFrame,
    ) -> std::io::Result<LevelState> {
        let vertex_count = d.u64()? as usize;
        let input_triangles = d.u64()? as usize;
        let levels_done = d.u64()? as usize;
        let leaves_finished = match d.u8()? {
            0 => false,
            1 => true,
            _ => return Err(invalid("a flag neither 0 nor 1")),
        };
        let locked_vertices = d.u64()? as usize;
        let resimplified = d.u64()? as usize;
        let own_error = d.list(4, |d| d.f32())?;
        let attribute_error = d.list(12, |d| {
            Ok(AttributeError {
                colour: d.f32()?,
                normal_degrees: d.f32()?,
                uv: d.f32()?,
            })
        })?;
        let live = d.list(21, |d| d.key().and_then(packed_or_invalid))?;
        let live = live.into_iter().collect();
        let end = d.u64()?;
        let records = d.list(45, |d| {
            let key = packed_or_invalid(d.key()?)?;
            let (at, bytes, triangles, crc) = (d.u64()?, d.u64()?, d.u32()?, d.u32()?);
            let bytes = u32::try_from(bytes).map_err(|_| invalid("a live record too long"))?;
            Ok((key, at, bytes, triangles, crc))
        })?;
        if records
            .iter()
            .any(|&(_, at, bytes, _, _)| at.saturating_add(bytes as u64) > end)
        {
            return Err(invalid("a live patch beyond its file"));
        }
        let current = CurrentMesh::decode(d, vertex_count)?;
        let patches = LiveStore::reopen(
            dir,
            StoreCheckpoint { end, records },
            SimplifierScale::of(frame),
        )?;
        Ok(LevelState {
            patches,
            live,
            current,
            own_error,
            attribute_error,
            locked_vertices,
            resimplified,
            levels_done,
            leaves_finished,
            vertex_count,
            input_triangles,
        })
    }
}

/// Live patches `finish_leaves` reads and hands on at once.
const FINISH_CHUNK: usize = 64;

/// Hands every live patch to `finished`: before the first level, the leaves' (a resumed build
/// whose checkpoint has not recorded them does it again; the finished patches it recorded are
/// then none).
fn finish_leaves(state: &LevelState, finished: &mut FinishedPatchSink) -> std::io::Result<()> {
    let mut keys: Vec<PackedKey> = state.live.iter().copied().collect();
    keys.sort_unstable();
    for chunk in keys.chunks(FINISH_CHUNK) {
        let patches: Vec<(SimplexKey, std::borrow::Cow<'_, LivePatch>)> = chunk
            .par_iter()
            .map(|k| {
                let patch = state.patches.get(&k.key())?;
                Ok(patch.map(|p| (k.key(), p)))
            })
            .collect::<std::io::Result<Vec<_>>>()?
            .into_iter()
            .flatten()
            .collect();
        let list: Vec<(SimplexKey, &LivePatch)> =
            patches.iter().map(|(k, p)| (*k, p.as_ref())).collect();
        finished(&list)?;
    }
    Ok(())
}

/// What a build's checkpoint does while the levels merge: `after_level` after each level;
/// `after_part` while a level's diamonds are simplified a part at a time (before any merge,
/// `in_parts` only): given the state, the level's diamonds done so far and an encoder of the
/// results made since the last part it saved, it saves them or not
/// (`checkpoint::save_level_part`) and says where; `resumed_parts`: the part files a resumed
/// build's checkpoint holds of the level after `state`'s.
pub(crate) struct LevelCheckpoints<'a> {
    pub in_parts: bool,
    pub after_level: &'a mut dyn FnMut(&LevelState) -> std::io::Result<()>,
    pub after_part: &'a mut PartSink<'a>,
    /// Called once a level with saved parts is about to merge (`checkpoint::drop_level_parts`):
    /// the bytes of the parts the checkpoint no longer names.
    pub drop_parts: &'a mut dyn FnMut() -> std::io::Result<u64>,
    pub resumed_parts: Vec<std::path::PathBuf>,
}

/// See [`LevelCheckpoints::after_part`].
#[rustfmt::skip]
pub(crate) type PartSink<'a> =
    dyn FnMut(&LevelState, usize, &dyn Fn(&mut Enc) -> std::io::Result<()>)
        -> std::io::Result<Option<std::path::PathBuf>> + 'a;

impl LevelCheckpoints<'_> {
    /// Nothing saved (a build without a checkpoint): each level simplified at once.
    pub(crate) fn none<R>(f: impl FnOnce(&mut LevelCheckpoints) -> R) -> R {
        let mut after_level = |_: &LevelState| Ok(());
        let mut after_part =
            |_: &LevelState, _: usize, _: &dyn Fn(&mut Enc) -> std::io::Result<()>| Ok(None);
        let mut drop_parts = || Ok(0);
        f(&mut LevelCheckpoints {
            in_parts: false,
            after_level: &mut after_level,
            after_part: &mut after_part,
            drop_parts: &mut drop_parts,
            resumed_parts: Vec::new(),
        })
    }
}

/// The parts a level's diamonds are simplified in (each a checkpoint's chance).
const PARTS_PER_LEVEL: usize = 8;

/// Merges the levels `state` has not merged yet, finest first, saving what `checkpoints` asks.
pub(crate) fn simplify_levels(
    mut state: LevelState,
    hierarchy: &Hierarchy,
    settings: &SimplifySettings,
    spill_dir: Option<&std::path::Path>,
    finished: &mut FinishedPatchSink,
    checkpoints: &mut LevelCheckpoints,
) -> Result<Simplified, SimplifyError> {
    let frame = &hierarchy.frame;
    let ctx = Context {
        frame,
        numbering_table: numbering_table(state.vertex_count, spill_dir.is_some()),
        settings: *settings,
        coarsest_triangles: coarsest_triangles(
            settings.coarsest_share,
            state.input_triangles,
            hierarchy.mesh.roots().len(),
        ),
    };
    if !state.leaves_finished {
        finish_leaves(&state, finished)?;
        state.leaves_finished = true;
    }
    if state.own_error.is_empty() {
        state.own_error = vec![0.0f32; hierarchy.diamonds.len()];
        state.attribute_error = vec![AttributeError::default(); hierarchy.diamonds.len()];
    }
    if state.own_error.len() != hierarchy.diamonds.len()
        || state.attribute_error.len() != hierarchy.diamonds.len()
    {
        return Err(SimplifyError::Finished(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "the simplification's state is not this hierarchy's",
        )));
    }
    let mut by_level: Vec<usize> = (0..hierarchy.diamonds.len()).collect();
    by_level.sort_by_key(|&i| std::cmp::Reverse(hierarchy.diamonds[i].level));
    let levels: Vec<&[usize]> = by_level
        .chunk_by(|&a, &b| hierarchy.diamonds[a].level == hierarchy.diamonds[b].level)
        .collect();
    let mut resumed_parts = std::mem::take(&mut checkpoints.resumed_parts);
    for level_group in levels.into_iter().skip(state.levels_done) {
        let no_extra = HashSet::default();
        let spill = ResultSpill::new(spill_dir, SimplifierScale::of(frame))?;
        // Results a resumed build's checkpoint holds: the level's first diamonds.
        let mut pending: Vec<Pending> = Vec::with_capacity(level_group.len());
        for path in resumed_parts.drain(..) {
            let results =
                partial_level::decode_results(&path).map_err(SimplifyError::Checkpoint)?;
            for result in results {
                if level_group.get(pending.len()) != Some(&result.diamond) {
                    return Err(SimplifyError::Checkpoint(std::io::Error::new(
                        std::io::ErrorKind::InvalidData,
                        "a level's part is not this hierarchy's",
                    )));
                }
                pending.push(Pending {
                    result,
                    extra_locks: HashSet::default(),
                    attempts: 0,
                });
            }
        }
        let mut saved = pending.len();
        let part = match checkpoints.in_parts {
            true => level_group.len().div_ceil(PARTS_PER_LEVEL).max(1),
            false => level_group.len().max(1),
        };
        while pending.len() < level_group.len() {
            let next = &level_group[pending.len()..(pending.len() + part).min(level_group.len())];
            let made: Vec<Pending> = next
                .par_iter()
                .map(|&d| {
                    Ok(Pending {
                        result: simplify_diamond(
                            &ctx,
                            d,
                            &hierarchy.diamond(d),
                            &state.patches,
                            &state.current,
                            &no_extra,
                            &spill,
                        )?,
                        extra_locks: HashSet::default(),
                        attempts: 0,
                    })
                })
                .collect::<std::io::Result<_>>()?;
            pending.extend(made);
            if pending.len() < level_group.len() {
                let unsaved: Vec<&DiamondResult> =
                    pending[saved..].iter().map(|p| &p.result).collect();
                let spans = std::cell::RefCell::new(Vec::new());
                let write = |e: &mut Enc| {
                    *spans.borrow_mut() = partial_level::encode_results(&unsaved, &spill, e)?;
                    Ok(())
                };
                if let Some(path) = (checkpoints.after_part)(&state, pending.len(), &write)? {
                    // The saved payloads are read from the part from now on; the spill's
                    // copies go.
                    let file = std::sync::Arc::new(partial_level::open_part(&path)?);
                    for (p, (at, bytes)) in pending[saved..].iter_mut().zip(spans.take()) {
                        let moved = Held::InPart {
                            file: file.clone(),
                            at,
                            bytes,
                        };
                        spill.release(&std::mem::replace(&mut p.result.payload, moved));
                    }
                    saved = pending.len();
                }
            }
        }
        if pending
            .iter()
            .any(|p| matches!(p.result.payload, Held::InPart { .. }))
        {
            // The merges change the state the parts were made against: the checkpoint goes
            // back to the level's start, and the parts' payloads are freed as they are taken.
            spill.adopt_parts((checkpoints.drop_parts)()?);
        }
        while !pending.is_empty() {
            // The rest of the mesh's counts of the edges the pending diamonds share with it.
            // Packed (16 B a key, not 32): the level's first list is every live simplex.
            let live_list: Vec<PackedKey> = state.live.iter().copied().collect();
            // By vertex, not by wedge (`current_mesh.rs`).
            let current = &state.current;
            let counts = count_edges(&query_edges(&pending), &live_list, &|k| {
                Ok(state
                    .patches
                    .triangles(k)?
                    .map(|t| current.vertex_triangles(t)))
            })?;
            for p in &mut pending {
                p.result.resolve(&counts);
            }
            if let Some(error) = pending
                .iter()
                .find_map(|p| p.result.conformity_error(hierarchy))
            {
                return Err(error.into());
            }
            let (clean, dirty) = split_batch(pending, &counts);
            state.resimplified += dirty.len();
            // The batch merges a group of diamonds at a time (their payloads back in memory):
            // count changes are sums, so the counts do not depend on the grouping.
            let mut clean = clean.into_iter().peekable();
            while clean.peek().is_some() {
                let group: Vec<Pending> = clean.by_ref().take(MERGE_GROUP).collect();
                let mut merged = Vec::with_capacity(group.len());
                for p in group {
                    let mut r = p.result;
                    let Payload {
                        patches: made,
                        vertices,
                    } = spill.take(std::mem::replace(
                        &mut r.payload,
                        Held::Memory(Payload::default()),
                    ))?;
                    r.effect.changes.vertices = vertices;
                    merged.push((r, made));
                }
                state
                    .current
                    .merge(merged.iter().map(|(r, _)| &r.effect.changes));
                let list: Vec<(SimplexKey, &LivePatch)> = merged
                    .iter()
                    .flat_map(|(_, made)| made.iter().map(|(k, patch)| (*k, patch)))
                    .collect();
                finished(&list)?;
                drop(list);
                let mut all_made = Vec::new();
                for (r, made) in merged {
                    state.own_error[r.diamond] = r.error;
                    state.attribute_error[r.diamond] = r.attribute_error;
                    state.locked_vertices += r.locked;
                    for s in &hierarchy.diamond(r.diamond).simplices {
                        for c in s.children() {
                            state.live.remove(&PackedKey::of_hierarchy(c.key));
                            state.patches.remove(&c.key)?;
                        }
                        state.live.insert(PackedKey::of_hierarchy(s.key));
                    }
                    all_made.extend(made);
                }
                // The new patches' simplices are a level above the removed children.
                state.patches.insert_all(all_made)?;
            }
            // Simplify the others again against the mesh with the batch merged, with more
            // locks.
            pending = dirty
                .into_par_iter()
                .map(|(mut p, blocked)| {
                    let d = p.result.diamond;
                    let diamond = hierarchy.diamond(d);
                    // Its children are still live: what it gathered is theirs.
                    let (gathered, ..) = gather_patches(&diamond, &state.patches)?;
                    let gathered = state.current.vertex_triangles(gathered.into());
                    p.lock_more(&blocked, &gathered);
                    let again = simplify_diamond(
                        &ctx,
                        d,
                        &diamond,
                        &state.patches,
                        &state.current,
                        &p.extra_locks,
                        &spill,
                    )?;
                    spill.release(&std::mem::replace(&mut p.result, again).payload);
                    Ok(p)
                })
                .collect::<std::io::Result<_>>()?;
        }
        crate::external::allocator::release_freed_memory();
        state.levels_done += 1;
        (checkpoints.after_level)(&state)?;
        // Removed patches' bytes go once no commit names them (the one just made, if one was).
        state.patches.release_dead()?;
    }
    Ok(Simplified {
        own_error: state.own_error,
        attribute_error: state.attribute_error,
        locked_vertices: state.locked_vertices,
        resimplified: state.resimplified,
    })
}
