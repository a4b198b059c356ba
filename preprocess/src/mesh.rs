//! The welded, cleaned input mesh every importer produces and the builder consumes, and its
//! wedges: which of its vertex indices share one position (`VertexStarts`).

/// A triangle mesh after welding. Index `i` is a *wedge*: one position and one set of
/// attributes (what a patch draws). Wedges with bit-identical positions (`-0.0` as `0.0`) that
/// are numbered consecutively form one *vertex* (what connectivity sees), whose id is the index
/// of its first wedge (`VertexStarts::canonical`): the global vertex id kept all the way into
/// the repository (the crack check compares cuts by these ids). An input without seams has one
/// wedge a vertex, and then wedge index = vertex id = global id, as before wedges.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct InputMesh {
    /// Model-space positions (f64 so that models far from the origin keep their precision).
    pub positions: Vec<[f64; 3]>,
    /// Counter-clockwise triangles of wedge indices; no repeated vertex within a triangle (the
    /// build refuses one: `BuildError::RepeatedVertex`). The importers also drop duplicate
    /// triangles (same vertex set) and weld identical positions, keeping the corners that
    /// differ in attributes as consecutive wedges of one vertex; the build accepts meshes that
    /// have duplicates, keeps a duplicate as the input has it, and keeps distinct vertices at
    /// one position distinct as long as they are not numbered consecutively.
    pub triangles: Vec<[u32; 3]>,
    /// Per-wedge normals, only if the input file has them.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Per-wedge RGBA8 colours, only if the input file has them.
    pub colors: Option<Vec<[u8; 4]>>,
    /// Per-wedge texture coordinates, only if the input file has them.
    pub uvs: Option<Vec<[f32; 2]>>,
}

impl InputMesh {
    /// Which wedges start a vertex (consecutive bit-identical positions are one vertex).
    pub fn vertex_starts(&self) -> VertexStarts {
        VertexStarts::from_positions(&self.positions)
    }
}

/// Which wedges start a vertex: one bit a wedge, or nothing at all when every wedge is its own
/// vertex (an input without seams, the common case: then `canonical` is the identity).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct VertexStarts {
    /// Bit `w` set where wedge `w` starts a vertex; empty for the identity.
    words: Vec<u64>,
}

impl VertexStarts {
    /// Every wedge its own vertex.
    pub fn identity() -> VertexStarts {
        VertexStarts::default()
    }

    /// Runs of consecutive bit-identical positions (`-0.0` as `0.0`) are one vertex.
    pub fn from_positions(positions: &[[f64; 3]]) -> VertexStarts {
        let key = |p: &[f64; 3]| p.map(crate::import::weld::canonical_bits);
        VertexStarts::from_flags(
            positions.len(),
            (0..positions.len()).map(|w| w == 0 || key(&positions[w]) != key(&positions[w - 1])),
        )
    }

    /// From one flag a wedge (`len` of them): whether it starts a vertex. The identity if all
    /// do.
    pub fn from_flags(len: usize, flags: impl Iterator<Item = bool>) -> VertexStarts {
        let mut words = vec![0u64; len.div_ceil(64)];
        let mut all = true;
        for (w, start) in flags.enumerate().take(len) {
            all &= start;
            words[w / 64] |= (start as u64) << (w % 64);
        }
        match all {
            true => VertexStarts::identity(),
            false => VertexStarts { words },
        }
    }

    /// The bit words (empty for the identity), for a checkpoint.
    pub(crate) fn words(&self) -> &[u64] {
        &self.words
    }

    /// From `words` (as `words` gave them).
    pub(crate) fn from_words(words: Vec<u64>) -> VertexStarts {
        VertexStarts { words }
    }

    /// Whether every wedge is its own vertex.
    pub fn is_identity(&self) -> bool {
        self.words.is_empty()
    }

    /// The vertex of wedge `w`: the index of the first wedge of its run.
    #[inline]
    pub fn canonical(&self, w: u32) -> u32 {
        if self.words.is_empty() {
            return w;
        }
        let mut word = w as usize / 64;
        // The bits at and below `w` in its word.
        let mut bits = self.words[word] & (u64::MAX >> (63 - w % 64));
        while bits == 0 {
            // Wedge 0 always starts a vertex, so a set bit exists below.
            word -= 1;
            bits = self.words[word];
        }
        (word * 64 + 63 - bits.leading_zeros() as usize) as u32
    }

    /// The number of vertices among `wedges` wedges.
    pub fn vertex_count(&self, wedges: usize) -> usize {
        match self.words.is_empty() {
            true => wedges,
            false => self.words.iter().map(|w| w.count_ones() as usize).sum(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_is_the_first_wedge_of_each_run() {
        let p = |x: f64| [x, 0.0, 0.0];
        let mut positions = vec![p(1.0), p(1.0), p(2.0), p(-0.0), p(0.0), p(3.0)];
        // A run across a word boundary.
        positions.extend((0..130).map(|_| p(4.0)));
        positions.push(p(5.0));
        let s = VertexStarts::from_positions(&positions);
        assert!(!s.is_identity());
        let canon: Vec<u32> = (0..positions.len() as u32)
            .map(|w| s.canonical(w))
            .collect();
        assert_eq!(&canon[..6], &[0, 0, 2, 3, 3, 5]);
        assert!(canon[6..136].iter().all(|&c| c == 6));
        assert_eq!(canon[136], 136);
        assert_eq!(s.vertex_count(positions.len()), 6);
        let distinct = VertexStarts::from_positions(&[p(1.0), p(2.0), p(1.0)]);
        assert!(distinct.is_identity());
        assert_eq!(distinct.canonical(2), 2);
        assert_eq!(distinct.vertex_count(3), 3);
    }
}
