//! The input's border (edges used by one triangle) as directed chains, and the rule that says
//! whether a border edge of a cut is the input's border, simplified.
//!
//! Height fields are built with their border chains free to shorten (`SimplifySettings::
//! keep_borders`): meshopt collapses a border vertex only onto a neighbour along its border,
//! and never a vertex another diamond's patch uses. So a cut's border edge a → b (directed as
//! its triangle runs) is legitimate exactly when b is reached from a by following the input's
//! border forward through vertices the cut does not use at all. A crack is not: its edges run
//! through the surface (their ends are no border vertices, or the border between them is still
//! drawn), and a chord across the input's border leaves the border's own vertices in the cut.

use std::collections::{HashMap, HashSet};

/// The input's directed border edges: from each border vertex, where its border edges lead.
pub struct BorderLoops {
    next: HashMap<u32, Vec<u32>>,
}

/// Undirected edge key (the geometric check's).
pub fn edge_key(a: u32, b: u32) -> u64 {
    ((a.min(b) as u64) << 32) | a.max(b) as u64
}

/// Longest chain a cut border edge may replace (a bound on the walk; a patch's border is
/// far shorter).
const MAX_CHAIN: usize = 1 << 20;

impl BorderLoops {
    /// From the input's triangles (the leaves), orientation as stored.
    pub fn new<'a>(triangles: impl Iterator<Item = &'a [u32; 3]> + Clone) -> BorderLoops {
        let mut keys: Vec<u64> = triangles
            .clone()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(a, b)| edge_key(a, b))
            .collect();
        keys.sort_unstable();
        let border: HashSet<u64> = keys
            .chunk_by(|x, y| x == y)
            .filter(|run| run.len() == 1)
            .map(|run| run[0])
            .collect();
        BorderLoops::from_border(triangles, |a, b| border.contains(&edge_key(a, b)))
    }

    /// From the input's triangles and its border edges (`is_border(a, b)`, either order), for
    /// a caller that has counted the edges already.
    pub fn from_border<'a>(
        triangles: impl Iterator<Item = &'a [u32; 3]>,
        is_border: impl Fn(u32, u32) -> bool,
    ) -> BorderLoops {
        let mut next: HashMap<u32, Vec<u32>> = HashMap::new();
        for t in triangles {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                if is_border(a, b) {
                    next.entry(a).or_default().push(b);
                }
            }
        }
        BorderLoops { next }
    }

    /// Whether the input has border edges at all.
    pub fn is_empty(&self) -> bool {
        self.next.is_empty()
    }

    /// Whether the cut's border edge `a → b` (directed as its triangle runs) simplifies the
    /// input's border: following the border forward from `a`, `b` comes before any vertex the
    /// cut uses (`used`).
    pub fn accepts(&self, a: u32, b: u32, used: &impl Fn(u32) -> bool) -> bool {
        let Some(starts) = self.next.get(&a) else {
            return false;
        };
        starts.iter().any(|&first| {
            let mut v = first;
            for _ in 0..MAX_CHAIN {
                if v == b {
                    return true;
                }
                if used(v) {
                    return false;
                }
                // A vertex where several border chains meet is never collapsed (meshopt
                // keeps such "complex" vertices), so a walk does not pass one.
                match self.next.get(&v).map(Vec::as_slice) {
                    Some([only]) => v = *only,
                    _ => return false,
                }
            }
            false
        })
    }

    /// The cut's border edges, directed as their triangles run, split into those that simplify
    /// the input's border and the others (cracks).
    pub fn classify(&self, triangles: &[&[u32; 3]]) -> BorderEdges {
        let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
        let mut used = HashSet::new();
        for t in triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *uses.entry((a.min(b), a.max(b))).or_default() += 1;
                used.insert(a);
            }
        }
        let (mut border, mut cracks) = (Vec::new(), Vec::new());
        for t in triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if uses[&(a.min(b), a.max(b))] == 1 {
                    if self.accepts(a, b, &|v| used.contains(&v)) {
                        border.push((a, b));
                    } else {
                        cracks.push((a, b));
                    }
                }
            }
        }
        BorderEdges { border, cracks }
    }
}

/// A cut's border edges (directed as their triangles run), by `BorderLoops::classify`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BorderEdges {
    /// Edges that simplify the input's border.
    pub border: Vec<(u32, u32)>,
    /// The others: cracks.
    pub cracks: Vec<(u32, u32)>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3 × 2 strip of unit squares, two triangles each, counter-clockwise: vertices
    /// 0 1 2 3 on the bottom row, 4 5 6 7 on the top.
    fn strip() -> Vec<[u32; 3]> {
        let mut t = Vec::new();
        for c in 0..3 {
            t.push([c, c + 1, c + 5]);
            t.push([c, c + 5, c + 4]);
        }
        t
    }

    #[test]
    fn the_input_and_its_simplified_border_pass_and_cracks_do_not() {
        let input = strip();
        let loops = BorderLoops::new(input.iter());
        let refs: Vec<&[u32; 3]> = input.iter().collect();
        let BorderEdges { border, cracks } = loops.classify(&refs);
        assert_eq!((border.len(), cracks.len()), (8, 0));
        // Bottom vertices 1 and 2 collapsed away along the border: 0 → 3 replaces 0 → 1 → 2 → 3.
        let simplified = [[0, 3, 7], [0, 7, 6], [0, 6, 5], [0, 5, 4]];
        let refs: Vec<&[u32; 3]> = simplified.iter().collect();
        let BorderEdges { border, cracks } = loops.classify(&refs);
        assert!(cracks.is_empty(), "{cracks:?}");
        assert!(border.contains(&(0, 3)));
        // A chord 0 → 3 while vertex 1 is still drawn (the triangles below the chord missing):
        // a hole in the surface, not a simplified border.
        let holed = [[0, 3, 7], [0, 7, 6], [0, 6, 5], [0, 5, 4], [1, 2, 6]];
        let refs: Vec<&[u32; 3]> = holed.iter().collect();
        let cracks = loops.classify(&refs).cracks;
        assert!(cracks.contains(&(0, 3)), "{cracks:?}");
        // A gap between two halves: the interior edges 1-5 / 2-6 used once.
        let split: Vec<[u32; 3]> = input.iter().copied().filter(|t| *t != [1, 2, 6]).collect();
        let refs: Vec<&[u32; 3]> = split.iter().collect();
        assert!(!loops.classify(&refs).cracks.is_empty());
        // Against the border's direction: 3 → 0 is not the input's border simplified.
        assert!(!loops.accepts(3, 0, &|v| [3, 0, 7].contains(&v)));
    }
}
