//! `bench breakdown`'s counterfactuals per level (issue 13, item 7): what the locked border
//! costs and how far saturation raises the stored errors, measured by simplifying each
//! diamond's gathered patches again from the repository.
//!
//! For each split diamond: its children's patches (what it gathered, by global vertex id,
//! positions dequantised and scaled to the model's size as the simplifier sees them) are
//! simplified by meshoptimizer as the build does (absolute error, no other option):
//! - **locked**: with the vertices of the gathered set's boundary locked (edges used by one
//!   gathered triangle: the diamond's border, and the input's own holes, which the build locks
//!   by default too), down to the triangles the diamond kept; its error is the build's own
//!   error recomputed (the build's positions were the input's, not the lattice's: close, not
//!   equal);
//! - **free**: without locks, down to the same count (its error), and down to the locked
//!   arm's error (its triangles): what the diamond would keep at equal error if its border
//!   could move. An unlocked diamond does not conform to its neighbours, so this is a
//!   measurement, not a build.
//!
//! Saturation: the stored error against the recomputed own error (model units), per diamond.
//! That is the raise only where the build's own error is meshoptimizer's geometric estimate:
//! the default build of a model without normals (with normals, the build's error includes
//! them, and none is reported; a `--bounded-errors` build stores a Hausdorff bound instead,
//! which the repository does not record, so its ratios are not raises). The build also locks
//! non-manifold edges' vertices, which the locked arm does not.

use rayon::prelude::*;
use std::collections::HashMap;

use meshopt::{SimplifyOptions, VertexDataAdapter};
use tessera_core::repository::format::{dequantize_position, ATTR_NORMALS};
use tessera_core::repository::{Repository, NO_INDEX};

/// One level's counterfactuals.
#[derive(Clone, Debug, Default)]
pub struct LockRow {
    pub level: u32,
    /// Diamonds with gathered triangles.
    pub diamonds: usize,
    pub gathered: u64,
    /// Triangles the locked arm kept (the build's count, where meshoptimizer reaches it).
    pub kept_locked: u64,
    /// Triangles the free arm keeps at the locked arm's error.
    pub kept_free_at_equal_error: u64,
    /// Median over the level's diamonds of the locked arm's error over the free arm's at the
    /// same count (diamonds where both are positive).
    pub error_ratio_median: Option<f64>,
    /// Median and 90th percentile of stored error ÷ recomputed own error (diamonds whose own
    /// error is positive; none for a model with normals).
    pub raise_median: Option<f64>,
    pub raise_p90: Option<f64>,
}

/// What one diamond's arms gave.
struct Arms {
    level: u32,
    gathered: u64,
    kept_locked: u64,
    kept_free_at_equal_error: u64,
    error_locked: f32,
    error_free: f32,
    stored: f32,
}

/// The counterfactuals, per LEB level.
pub fn lock_counterfactuals(repo: &Repository) -> anyhow::Result<Vec<LockRow>> {
    let h = repo.header();
    let model_size = (0..3)
        .map(|k| h.bbox_max[k] - h.bbox_min[k])
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    // With normals the build's own error is meshoptimizer's with attributes: not the one
    // recomputed here, so no raise is reported.
    let comparable = h.attributes & ATTR_NORMALS == 0;
    let diamonds = repo.diamonds();
    let mut own: Vec<u64> = vec![0; diamonds.len()];
    let mut created: Vec<Vec<usize>> = vec![Vec::new(); diamonds.len()];
    for (i, t) in repo.tets().iter().enumerate() {
        if t.diamond != NO_INDEX {
            own[t.diamond as usize] += t.triangle_count as u64;
        }
        if t.parent_diamond != NO_INDEX {
            created[t.parent_diamond as usize].push(i);
        }
    }
    let arms: Vec<Option<Arms>> = (0..diamonds.len())
        .into_par_iter()
        .map(|d| {
            let (indices, positions) = gather(repo, &created[d], model_size)?;
            if indices.is_empty() {
                return Ok(None);
            }
            let lock = boundary(&indices, positions.len());
            let target = own[d] as usize * 3;
            let (kept, error_locked) = simplify(&indices, &positions, &lock, target, f32::MAX);
            let free = vec![false; positions.len()];
            // At the count the locked arm reached (it may stop above the target).
            let (_, error_free) = simplify(&indices, &positions, &free, kept, f32::MAX);
            let (free_at_error, _) = simplify(&indices, &positions, &free, 0, error_locked);
            Ok(Some(Arms {
                level: diamonds[d].level,
                gathered: indices.len() as u64 / 3,
                kept_locked: kept as u64 / 3,
                kept_free_at_equal_error: free_at_error as u64 / 3,
                error_locked: (error_locked as f64 * model_size) as f32,
                error_free: (error_free as f64 * model_size) as f32,
                stored: diamonds[d].error,
            }))
        })
        .collect::<anyhow::Result<_>>()?;
    let mut rows: Vec<LockRow> = Vec::new();
    let mut ratios: Vec<Vec<f64>> = Vec::new();
    let mut raises: Vec<Vec<f64>> = Vec::new();
    for a in arms.into_iter().flatten() {
        let level = a.level as usize;
        while rows.len() <= level {
            rows.push(LockRow {
                level: rows.len() as u32,
                ..LockRow::default()
            });
            ratios.push(Vec::new());
            raises.push(Vec::new());
        }
        let row = &mut rows[level];
        row.diamonds += 1;
        row.gathered += a.gathered;
        row.kept_locked += a.kept_locked;
        row.kept_free_at_equal_error += a.kept_free_at_equal_error;
        if a.error_locked > 0.0 && a.error_free > 0.0 {
            ratios[level].push(a.error_locked as f64 / a.error_free as f64);
        }
        if a.error_locked > 0.0 && comparable {
            raises[level].push(a.stored as f64 / a.error_locked as f64);
        }
    }
    for ((row, r), s) in rows.iter_mut().zip(&mut ratios).zip(&mut raises) {
        row.error_ratio_median = quantile(r, 0.5);
        row.raise_median = quantile(s, 0.5);
        row.raise_p90 = quantile(s, 0.9);
    }
    Ok(rows)
}

/// The nearest-rank quantile `q` of `values` (None when empty).
fn quantile(values: &mut [f64], q: f64) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let rank = ((q * values.len() as f64).ceil() as usize).clamp(1, values.len());
    Some(values[rank - 1])
}

/// The triangles of `tets`' patches as local indices, and their vertices' positions
/// relative to the repository origin in model sizes (as f32, the simplifier's units).
fn gather(
    repo: &Repository,
    tets: &[usize],
    model_size: f64,
) -> anyhow::Result<(Vec<u32>, Vec<[f32; 3]>)> {
    let h = repo.header();
    let mut local: HashMap<u32, u32> = HashMap::new();
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut indices: Vec<u32> = Vec::new();
    for &t in tets {
        let patch = repo.patch(t)?;
        let view = patch.view();
        let ids: Vec<u32> = view.global_ids().collect();
        let rows: Vec<u32> = ids
            .iter()
            .enumerate()
            .map(|(v, &g)| {
                *local.entry(g).or_insert_with(|| {
                    let p = dequantize_position(view.position(v), h.bbox_min, h.position_step);
                    positions.push([0, 1, 2].map(|k| ((p[k] - h.origin[k]) / model_size) as f32));
                    positions.len() as u32 - 1
                })
            })
            .collect();
        for tri in view.triangles() {
            indices.extend(tri.map(|l| rows[l as usize]));
        }
    }
    Ok((indices, positions))
}

/// Vertices on an edge that one triangle of `indices` uses.
fn boundary(indices: &[u32], vertices: usize) -> Vec<bool> {
    let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
    for t in indices.chunks_exact(3) {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut lock = vec![false; vertices];
    for (&(a, b), &n) in &uses {
        if n == 1 {
            lock[a as usize] = true;
            lock[b as usize] = true;
        }
    }
    lock
}

/// meshoptimizer's simplification as the build calls it; returns the indices kept and the
/// error (in the positions' units).
fn simplify(
    indices: &[u32],
    positions: &[[f32; 3]],
    lock: &[bool],
    target_indices: usize,
    target_error: f32,
) -> (usize, f32) {
    let adapter = VertexDataAdapter::new(bytemuck::cast_slice(positions), 12, 0)
        .expect("tightly packed f32x3 positions");
    let mut error = 0.0f32;
    let out = meshopt::simplify_with_locks(
        indices,
        &adapter,
        lock,
        target_indices,
        target_error,
        SimplifyOptions::ErrorAbsolute,
        Some(&mut error),
    );
    (out.len(), error)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_quantiles() {
        assert_eq!(quantile(&mut [], 0.5), None);
        assert_eq!(quantile(&mut [3.0, 1.0, 2.0], 0.5), Some(2.0));
        assert_eq!(quantile(&mut [4.0, 1.0, 3.0, 2.0], 0.5), Some(2.0));
        assert_eq!(
            quantile(&mut (1..=10).map(f64::from).collect::<Vec<_>>(), 0.9),
            Some(9.0)
        );
    }

    #[test]
    fn the_boundary_of_a_square_is_its_outline() {
        // A 3 × 3 grid of vertices, 8 triangles: every vertex but the centre is on the
        // outline.
        let mut indices = Vec::new();
        for y in 0..2u32 {
            for x in 0..2u32 {
                let v = y * 3 + x;
                indices.extend([v, v + 1, v + 4, v, v + 4, v + 3]);
            }
        }
        let lock = boundary(&indices, 9);
        assert_eq!(lock.iter().filter(|&&l| l).count(), 8);
        assert!(!lock[4]);
    }
}
