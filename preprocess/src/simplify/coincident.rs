//! Back-to-back triangle pairs that a simplification made, cancelled (see
//! `cancel_coincident_pairs`).

use rustc_hash::FxHashMap as HashMap;

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
///
/// With `vertex_of` (a diamond with a seam, `vertices.rs`), `indices` are local wedges and a
/// triangle's vertex set is its wedges' vertices (`gathered` and `vertex_count` are by vertex):
/// a flap is a flap whatever attributes its two copies carry.
pub(super) fn cancel_coincident_pairs(
    indices: &mut Vec<u32>,
    gathered: &[u32],
    vertex_count: usize,
    vertex_of: Option<&[u32]>,
) {
    let by_vertex: Vec<u32>;
    let vertices = match vertex_of {
        Some(map) => {
            by_vertex = indices.iter().map(|&w| map[w as usize]).collect();
            &by_vertex[..]
        }
        None => &indices[..],
    };
    let runs = coincident_runs(vertices, vertex_count);
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
        cancel_coincident_pairs(&mut indices, &gathered, 8, None);
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

    /// With wedges, copies are found by vertex: wedges 4 and 5 are one vertex.
    #[test]
    fn flaps_are_found_by_vertex() {
        let vertex_of = [0, 1, 2, 3, 4, 4, 5, 6];
        let mut indices = vec![0, 1, 2, 4, 6, 7, 7, 6, 5];
        cancel_coincident_pairs(&mut indices, &[0, 1, 2, 2, 1, 3], 7, Some(&vertex_of));
        assert_eq!(indices, vec![0, 1, 2]);
    }
}
