//! The build's first steps from a mesh staged on disk (`build --memory` with a mesh file),
//! never loading it: the input's checks and bounding box by streaming its files, the
//! hierarchy from joined barycentres, the use counts from the triangle stream, and the
//! leaves' patches by joins (`external/joins.rs`). Each gives what the in-memory steps give
//! from the loaded mesh, so the repository is the same bytes.

use crate::build::{BuildError, MemoryBudget, MAX_EXTENT};
use crate::external::{coincident_nudges, JoinedBarycentres, StagedMesh};
use crate::frame::LatticeFrame;
use crate::hierarchy::{
    build_hierarchy_bucketed_spooled, BucketBudget, Construction, Hierarchy, LeafCorners,
    SpooledBarycentres,
};
use crate::mesh::VertexStarts;
use crate::simplify::{simplifier_position, CurrentMesh};

fn temporary(memory: &MemoryBudget) -> impl Fn(std::io::Error) -> BuildError + '_ {
    |source| BuildError::Temporary {
        dir: memory.temp_dir.clone(),
        source,
    }
}

/// `build_checks::validate`'s checks of the mesh, in the same order and with the same errors, by
/// streaming the staged files; returns the bounding box.
pub(crate) fn validate_staged(
    staged: &StagedMesh,
    memory: &MemoryBudget,
) -> Result<([f64; 3], [f64; 3]), BuildError> {
    let io = temporary(memory);
    if staged.triangles.is_empty() {
        return Err(BuildError::EmptyMesh);
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    // A chunk at a time: a record at a time through the readers' iterators cost most of the
    // pass (0.5 s of a 10 M-triangle build).
    let mut first = 0usize;
    let mut positions = staged.positions.read_chunks(VALIDATE_CHUNK).map_err(&io)?;
    let mut chunk = Vec::new();
    while positions.read_into(&mut chunk).map_err(&io)? {
        for (i, p) in chunk.iter().enumerate() {
            if p.iter().any(|x| !x.is_finite()) {
                return Err(BuildError::NonFinite { index: first + i });
            }
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        first += chunk.len();
    }
    if let Some(axis) = (0..3).find(|&i| hi[i] - lo[i] > MAX_EXTENT) {
        return Err(BuildError::TooLarge {
            axis,
            extent: hi[axis] - lo[axis],
        });
    }
    let count = staged.positions.len() as usize;
    let mut first = 0usize;
    let mut triangles = staged.triangles.read_chunks(VALIDATE_CHUNK).map_err(&io)?;
    let mut chunk = Vec::new();
    while triangles.read_into(&mut chunk).map_err(&io)? {
        for (i, t) in chunk.iter().enumerate() {
            let index = first + i;
            if let Some(&vertex) = t.iter().find(|&&v| v as usize >= count) {
                return Err(BuildError::IndexOutOfRange {
                    index,
                    vertex,
                    count,
                });
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                let vertex = if t[1] == t[2] { t[1] } else { t[0] };
                return Err(BuildError::RepeatedVertex { index, vertex });
            }
        }
        first += chunk.len();
    }
    Ok((lo, hi))
}

/// Records `validate_staged` reads at a time (1.5 MiB of f32 positions).
const VALIDATE_CHUNK: usize = 1 << 17;

/// The hierarchy (bucketed, from barycentres joined once into a spool), its leaves' triangles
/// (on disk, read out of the staged triangle file, which is then discarded) and the use
/// counts.
pub(crate) fn hierarchy_and_counts(
    staged: &StagedMesh,
    frame: LatticeFrame,
    construction: Construction,
    leaf_triangles: usize,
    memory: &MemoryBudget,
) -> Result<(Hierarchy, LeafCorners, CurrentMesh), BuildError> {
    let io = temporary(memory);
    let dir = memory.temp_dir.as_path();
    let sort_budget = memory.bytes as usize / 4;
    // The use counts' sort of every edge (8 bytes an edge, three a triangle) spills runs to
    // disk (about 7 bytes a triangle) unless it fits its budget. Then the counts go first,
    // before the barycentres' spool and the buckets (about 7 bytes a triangle more): side by
    // side with the staged mesh they made the stage's temporary peak 1.7x the input. Where
    // the sort fits, the counts are counted beside the bucketed hierarchy (which runs on one
    // thread), as the in-memory build does.
    let edges_fit = staged.triangles.len().saturating_mul(3 * 8) <= sort_budget as u64;
    let starts = staged.vertex_starts().map_err(&io)?;
    let counts = || CurrentMesh::from_staged(staged, starts.clone(), sort_budget, dir);
    let early = if edges_fit {
        None
    } else {
        Some(counts().map_err(&io)?)
    };
    let barycentres = SpooledBarycentres::new(
        &JoinedBarycentres {
            staged,
            frame: &frame,
            budget: sort_budget,
        },
        dir,
    )
    .map_err(&io)?;
    let budget = BucketBudget::new(memory.bucket_triangles(leaf_triangles), dir);
    let hierarchy = || build_hierarchy_bucketed_spooled(frame, &barycentres, construction, &budget);
    let (hierarchy, current) = match early {
        Some(current) => (hierarchy(), current),
        None => {
            let (hierarchy, current) = rayon::join(hierarchy, counts);
            (hierarchy, current.map_err(&io)?)
        }
    };
    let (hierarchy, lists, _) = hierarchy.map_err(&io)?;
    drop(barycentres);
    let corners =
        crate::external::leaf_corners(&staged.triangles, lists, leaf_group_triangles(memory), dir)
            .map_err(&io)?;
    // Nothing reads the staged triangles again (a checkpoint's copy stays until its
    // `hierarchy` stage, which holds the leaves' triangles, is committed).
    staged.triangles.discard().map_err(&io)?;
    Ok((hierarchy, corners, current))
}

/// The simplifier's position of each wedge as `simplify_hierarchy` computes it in memory
/// (relative to the model, in model sizes, coincident vertices moved apart, a wedge at its
/// vertex's, `starts`): `(id, position)` → f32 position, for `LeafGroups`.
pub(crate) fn simplifier_positions<'f>(
    staged: &StagedMesh,
    starts: &VertexStarts,
    frame: &'f LatticeFrame,
    memory: &MemoryBudget,
) -> Result<impl Fn(u32, [f64; 3]) -> [f32; 3] + 'f, BuildError> {
    let f32_of = move |p: [f64; 3]| simplifier_position(frame, p);
    let budget = memory.bytes as usize / 4;
    let nudged = coincident_nudges(staged, starts, &f32_of, budget, &memory.temp_dir)
        .map_err(temporary(memory))?;
    // A copy of the starts only where a vertex was moved (a bit a wedge; none without seams).
    let starts = (!nudged.is_empty()).then(|| starts.clone());
    Ok(move |v: u32, p: [f64; 3]| {
        let v = starts.as_ref().map_or(v, |s| s.canonical(v));
        nudged.get(&v).copied().unwrap_or_else(|| f32_of(p))
    })
}

/// Triangles a group of leaves may hold while it is joined (about 60 bytes a triangle: the
/// triangle, its share of vertex rows and join pairs): two groups are alive at once (the next
/// one is joined while this one is encoded, `external::prefetch`), within a quarter of the
/// budget together.
pub(crate) fn leaf_group_triangles(memory: &MemoryBudget) -> usize {
    (memory.bytes as usize / 8 / 60).max(1 << 12)
}
