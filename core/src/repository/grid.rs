//! The global position grid chosen from the error (issue 49): a repository built on the full
//! 2^21 lattice moved to a grid 2^s coarser per axis, s chosen so that the step is at most
//! Nexus's default for the same model, 2^trunc(log2(0.05 e)) with e the smallest error of the
//! first level of diamonds above the leaves (the leaves' error is 0).
//!
//! The build encodes a patch as soon as its diamond is simplified, leaves first, before any
//! level's error is known; so the grid is applied after the build, by one pass over the
//! patches (`repack::repack_on_grid`), which decodes each, rounds its coordinates to the
//! coarser grid and codes it again. Still one grid for the whole model: a vertex shared by two
//! patches has the same lattice coordinates in both, so the same coarse ones. What the grid
//! moves, the directory says:
//! - `Header::position_step` becomes the lattice's step × 2^s per axis;
//! - every stored error grows by the new grid's half-diagonal (a vertex moves at most that far
//!   from its lattice position, which was within the old half-diagonal of the input, which the
//!   errors already counted), then is saturated again over the diamond DAG (a parent's error at
//!   least (1 + 1e-5) × each child's, as the build saturates them);
//! - every sphere (diamonds' and tets') grows by both half-diagonals, so each still holds its
//!   patches' vertices, and nested spheres stay nested.

use super::format::{DiamondRecord, Header, TetRecord, NO_INDEX, POSITION_BITS, POSITION_MAX};
use super::reader::Repository;

/// Nexus's fraction of the first-level error: its default step is 2^trunc(log2(0.05 e)).
pub const NEXUS_FRACTION: f64 = 0.05;
/// A parent diamond's error is at least this factor times each child's (the build's
/// `saturate::ERROR_MARGIN`).
const ERROR_MARGIN: f64 = 1e-5;

/// Half the diagonal of a grid step: how far a vertex rounded to it may move.
pub fn half_diagonal(step: [f64; 3]) -> f64 {
    0.5 * step.iter().map(|s| s * s).sum::<f64>().sqrt()
}

/// The smallest stored error of the diamonds whose every simplex has two leaf children (the
/// first level above the leaves), less the quantisation error every stored error holds;
/// `None` when no diamond has only leaves below it.
pub fn first_level_error(repo: &Repository) -> Option<f64> {
    let tets = repo.tets();
    let mut first_level = vec![true; repo.diamonds().len()];
    let mut seen = vec![false; repo.diamonds().len()];
    for t in tets {
        if t.diamond == NO_INDEX {
            continue;
        }
        let d = t.diamond as usize;
        seen[d] = true;
        let c = t.first_child as usize;
        let leaves = tets[c].diamond == NO_INDEX && tets[c + 1].diamond == NO_INDEX;
        first_level[d] &= leaves;
    }
    let q = half_diagonal(repo.header().position_step);
    repo.diamonds()
        .iter()
        .enumerate()
        .filter(|&(d, _)| seen[d] && first_level[d])
        .map(|(_, r)| (r.error as f64 - q).max(0.0))
        .min_by(f64::total_cmp)
}

/// Nexus's step for first-level error `e` and `fraction` (`NEXUS_FRACTION` by default):
/// 2^trunc(log2(fraction × e)), as `nxsbuild` picks it.
pub fn nexus_step(e: f64, fraction: f64) -> f64 {
    2f64.powi((fraction * e).log2().trunc() as i32)
}

/// Per axis, the largest s (< `POSITION_BITS`) whose step 2^s × `step` is at most `target`:
/// the coarsest power-of-two multiple of the lattice's step that is no coarser than it (0 on
/// an axis whose step is 0, a flat model's).
pub fn shifts_for(step: [f64; 3], target: f64) -> [u32; 3] {
    step.map(|s| {
        let mut shift = 0;
        while s > 0.0 && shift + 1 < POSITION_BITS && s * (2u64 << shift) as f64 <= target {
            shift += 1;
        }
        shift
    })
}

/// A lattice coordinate on the grid 2^`shift` coarser (rounded half up; at most
/// `POSITION_MAX`).
#[inline]
pub fn coarsen(c: u32, shift: u32) -> u32 {
    match shift {
        0 => c,
        s => ((c + (1 << (s - 1))) >> s).min(POSITION_MAX),
    }
}

/// The directory of `source` moved to the grid `shifts` coarser (module doc): its header,
/// diamonds and tets, the patches' placement left to the writer.
pub fn coarsened_directory(
    source: &Repository,
    shifts: [u32; 3],
) -> (Header, Vec<DiamondRecord>, Vec<TetRecord>) {
    let mut header = *source.header();
    let old = half_diagonal(header.position_step);
    for (s, shift) in header.position_step.iter_mut().zip(shifts) {
        *s *= (1u64 << shift) as f64;
    }
    let new = half_diagonal(header.position_step);
    let grow = |r: f32, by: f64| up(r as f64 + by);
    let mut diamonds = source.diamonds().to_vec();
    let mut error: Vec<f64> = diamonds.iter().map(|d| d.error as f64 + new).collect();
    // Children come after their parents in table order: the reverse visits children first.
    for i in (0..diamonds.len()).rev() {
        let e = error[i] * (1.0 + ERROR_MARGIN);
        let d = &diamonds[i];
        for &p in &d.parents[..d.parent_count as usize] {
            error[p as usize] = error[p as usize].max(e);
        }
    }
    for (d, e) in diamonds.iter_mut().zip(error) {
        d.error = up(e);
        d.radius = grow(d.radius, old + new);
    }
    let mut tets = source.tets().to_vec();
    for t in &mut tets {
        t.radius = grow(t.radius, old + new);
    }
    (header, diamonds, tets)
}

/// `x` as the nearest f32 at or above it.
fn up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f.next_up()
    } else {
        f
    }
}

/// Rounds the positions of a decoded patch (the first 8 × `vertex_count` bytes, packed as
/// `format::pack_position`) to the grid `shifts` coarser, in place.
pub fn coarsen_patch(decoded: &mut [u8], vertex_count: usize, shifts: [u32; 3]) {
    use super::format::{pack_position, unpack_position};
    for w in decoded[..8 * vertex_count].chunks_exact_mut(8) {
        let word = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        let q = unpack_position([word(&w[..4]), word(&w[4..])]);
        let coarse = pack_position([0, 1, 2].map(|a| coarsen(q[a], shifts[a])));
        w[..4].copy_from_slice(&coarse[0].to_le_bytes());
        w[4..].copy_from_slice(&coarse[1].to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nexus_steps_truncate_the_log_towards_zero() {
        // log2(0.05 × 6.57e-6) = −21.54: trunc gives −21.
        assert_eq!(nexus_step(6.57e-6, NEXUS_FRACTION), 2f64.powi(-21));
        assert_eq!(nexus_step(160.0, NEXUS_FRACTION), 8.0);
    }

    #[test]
    fn shifts_stay_at_or_below_the_target() {
        let step = [9.77e-8, 6.89e-8, 4.37e-8];
        let target = 2f64.powi(-21);
        let s = shifts_for(step, target);
        assert_eq!(s, [2, 2, 3]);
        for a in 0..3 {
            assert!(step[a] * (1u64 << s[a]) as f64 <= target);
            assert!(step[a] * (2u64 << s[a]) as f64 > target);
        }
        assert_eq!(shifts_for([0.0, 1.0, 1.0], 0.5), [0, 0, 0]);
        assert_eq!(shifts_for([1.0; 3], 1e30), [POSITION_BITS - 1; 3]);
    }

    #[test]
    fn coarsening_rounds_and_keeps_shared_coordinates_equal() {
        assert_eq!(coarsen(5, 0), 5);
        assert_eq!((coarsen(5, 1), coarsen(6, 2), coarsen(5, 2)), (3, 2, 1));
        assert_eq!(coarsen(POSITION_MAX, 1), 1 << (POSITION_BITS - 1));
        assert!(coarsen(POSITION_MAX, 20) <= POSITION_MAX);
        let mut a = [0u8; 16];
        let p = super::super::format::pack_position([7, 8, POSITION_MAX]);
        a[..4].copy_from_slice(&p[0].to_le_bytes());
        a[4..8].copy_from_slice(&p[1].to_le_bytes());
        coarsen_patch(&mut a, 1, [1, 2, 3]);
        let word = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        let q = super::super::format::unpack_position([word(&a[..4]), word(&a[4..8])]);
        assert_eq!(q, [4, 2, coarsen(POSITION_MAX, 3)]);
        assert_eq!(&a[8..], &[0; 8]);
    }
}
