//! Edge use counts of a diamond's local mesh (vertices numbered `0..n`), in linear time: every
//! edge is bucketed under its smaller endpoint (a counting sort), then each bucket is
//! deduplicated with a marker array. This replaces sorting every edge key of every diamond,
//! for the lock rule and again for the count changes, which cost more than meshopt did.

/// The distinct edges of a triangle list and how many triangles use each, grouped by smaller
/// endpoint.
pub(super) struct LocalEdges {
    /// The edges with smaller endpoint `a` are `first[a]..first[a + 1]`.
    first: Vec<u32>,
    smaller: Vec<u32>,
    larger: Vec<u32>,
    uses: Vec<u32>,
}

impl LocalEdges {
    /// Counts the edges of `indices` (three per triangle, each below `vertex_count`).
    pub fn count(vertex_count: usize, indices: &[u32]) -> LocalEdges {
        let edges = |t: &[u32]| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])];
        let mut start = vec![0u32; vertex_count + 1];
        for t in indices.chunks_exact(3) {
            for (a, b) in edges(t) {
                start[a.min(b) as usize + 1] += 1;
            }
        }
        for i in 0..vertex_count {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut bucketed = vec![0u32; start[vertex_count] as usize];
        for t in indices.chunks_exact(3) {
            for (a, b) in edges(t) {
                let lo = a.min(b) as usize;
                bucketed[fill[lo] as usize] = a.max(b);
                fill[lo] += 1;
            }
        }
        // Deduplicate each bucket: seen[b] is the last distinct edge with larger endpoint b, of
        // the current bucket iff it is at or after the bucket's first distinct edge.
        let mut seen = fill;
        seen.fill(u32::MAX);
        let mut first = Vec::with_capacity(vertex_count + 1);
        let mut smaller = Vec::with_capacity(bucketed.len() / 2 + 1);
        let mut larger = Vec::with_capacity(bucketed.len() / 2 + 1);
        let mut uses: Vec<u32> = Vec::with_capacity(bucketed.len() / 2 + 1);
        for lo in 0..vertex_count {
            let group = larger.len() as u32;
            first.push(group);
            for &hi in &bucketed[start[lo] as usize..start[lo + 1] as usize] {
                let i = seen[hi as usize];
                if i != u32::MAX && i >= group {
                    uses[i as usize] += 1;
                } else {
                    seen[hi as usize] = larger.len() as u32;
                    smaller.push(lo as u32);
                    larger.push(hi);
                    uses.push(1);
                }
            }
        }
        first.push(larger.len() as u32);
        LocalEdges {
            first,
            smaller,
            larger,
            uses,
        }
    }

    /// Number of distinct edges.
    pub fn len(&self) -> usize {
        self.larger.len()
    }

    /// Triangles using edge `i`.
    pub fn uses(&self, i: usize) -> u32 {
        self.uses[i]
    }

    /// The index of edge `(a, b)` (either order), if the triangles use it.
    pub fn find(&self, a: u32, b: u32) -> Option<usize> {
        let (lo, hi) = (a.min(b) as usize, a.max(b));
        let group = self.first[lo] as usize..self.first[lo + 1] as usize;
        self.larger[group.clone()]
            .iter()
            .position(|&x| x == hi)
            .map(|i| group.start + i)
    }

    /// (index, smaller endpoint, larger endpoint, uses) of every distinct edge.
    pub fn iter(&self) -> impl Iterator<Item = (usize, u32, u32, u32)> + '_ {
        self.smaller
            .iter()
            .zip(&self.larger)
            .zip(&self.uses)
            .enumerate()
            .map(|(i, ((&a, &b), &n))| (i, a, b, n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[test]
    fn counts_match_a_map() {
        let indices = [0, 1, 2, 2, 1, 3, 3, 1, 0, 4, 0, 2, 0, 1, 2, 2, 1, 4];
        let e = LocalEdges::count(5, &indices);
        let mut expected: BTreeMap<(u32, u32), u32> = BTreeMap::new();
        for t in indices.chunks_exact(3) {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *expected.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let got: BTreeMap<(u32, u32), u32> = e.iter().map(|(_, a, b, n)| ((a, b), n)).collect();
        assert_eq!(got, expected);
        assert_eq!(e.len(), expected.len());
        for (i, a, b, _) in e.iter() {
            assert_eq!(e.find(b, a), Some(i));
        }
        assert_eq!(e.find(3, 4), None);
    }
}
