//! Diamonds of the bintree named by their centre sample point, and the cluster diamond edges
//! of the adaptive merge.
//!
//! Every sample point of the square except its four corners is the midpoint of exactly one
//! bintree hypotenuse: the point where the diamond of that hypotenuse (the triangle and its base
//! neighbour, or the lone triangle on the square's boundary) inserts a vertex when it splits.
//! So a conforming bintree triangulation is a set of split diamonds, one flag per sample point,
//! closed under parents; the parents of a diamond are the diamonds centred at its apexes and
//! its children those centred at the midpoints of its legs. Working on points instead of
//! triangle ids makes base neighbours, parents and children O(1) lattice arithmetic.
//!
//! With `h` the largest power of two dividing both coordinates (0 counts as divisible):
//! - both coordinates odd multiples of `h`: a *square* diamond, the diagonal of a cell of side
//!   2h, at an even level; its hypotenuse joins the cell corner whose coordinates are both
//!   multiples of 4h to the opposite one (the other two corners are the apexes, midpoints of
//!   the parent level's axis-aligned hypotenuses);
//! - one coordinate an odd multiple of `h`, the other a multiple of 2h: an *edge* diamond, an
//!   axis-aligned hypotenuse of length 2h, at the odd level below.

/// Direction of a diamond's hypotenuse.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hypotenuse {
    /// Diagonal along +x+y (square diamond).
    Rising,
    /// Diagonal along +x−y (square diamond).
    Falling,
    /// Along x (edge diamond).
    Horizontal,
    /// Along y (edge diamond).
    Vertical,
}

/// The diamond centred at a sample point of a square of side `side` (a power of two).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Diamond {
    pub centre: [i32; 2],
    /// Half the hypotenuse's extent along each axis it spans.
    pub half: i32,
    pub hypotenuse: Hypotenuse,
}

impl Diamond {
    /// The diamond centred at `p`; `None` for the square's corners and points outside it.
    pub fn at(side: i32, p: [i32; 2]) -> Option<Diamond> {
        let [x, y] = p;
        if !(0..=side).contains(&x) || !(0..=side).contains(&y) {
            return None;
        }
        let bits = x | y;
        if bits == 0 {
            return None;
        }
        let half = bits & bits.wrapping_neg();
        if half >= side {
            return None; // a corner: (side, 0), (0, side) or (side, side)
        }
        let hypotenuse = match (x & half != 0, y & half != 0) {
            (true, true) => {
                // The hypotenuse's end whose coordinates are both multiples of 4h.
                let quad = 4 * half as i64;
                let ax = if (x as i64 - half as i64).rem_euclid(quad) == 0 {
                    -1
                } else {
                    1
                };
                let ay = if (y as i64 - half as i64).rem_euclid(quad) == 0 {
                    -1
                } else {
                    1
                };
                if ax == ay {
                    Hypotenuse::Rising
                } else {
                    Hypotenuse::Falling
                }
            }
            (true, false) => Hypotenuse::Horizontal,
            (false, true) => Hypotenuse::Vertical,
            (false, false) => unreachable!("h divides both coordinates"),
        };
        Some(Diamond {
            centre: p,
            half,
            hypotenuse,
        })
    }

    /// Whether the hypotenuse is diagonal (a square diamond, even level).
    pub fn is_square(&self) -> bool {
        matches!(self.hypotenuse, Hypotenuse::Rising | Hypotenuse::Falling)
    }

    /// Bintree level of the diamond's triangles (roots: 0).
    pub fn level(&self, side: i32) -> u32 {
        let k = side.trailing_zeros();
        let pair = 2 * (k - 1 - self.half.trailing_zeros());
        if self.is_square() {
            pair
        } else {
            pair + 1
        }
    }

    /// Offset from the centre to one end of the hypotenuse (the other is its negation).
    fn along(&self) -> [i32; 2] {
        let h = self.half;
        match self.hypotenuse {
            Hypotenuse::Rising => [h, h],
            Hypotenuse::Falling => [h, -h],
            Hypotenuse::Horizontal => [h, 0],
            Hypotenuse::Vertical => [0, h],
        }
    }

    #[cfg(test)]
    /// The two ends of the hypotenuse.
    pub fn ends(&self) -> [[i32; 2]; 2] {
        let [c, d] = [self.centre, self.along()];
        [[c[0] - d[0], c[1] - d[1]], [c[0] + d[0], c[1] + d[1]]]
    }

    /// The two apexes (right-angle corners) of the diamond's triangles, some possibly outside
    /// the square: the centres of the parent diamonds.
    pub fn apexes(&self) -> [[i32; 2]; 2] {
        let [c, d] = [self.centre, self.along()];
        // The hypotenuse's half-extent turned by 90°.
        let n = [-d[1], d[0]];
        [[c[0] + n[0], c[1] + n[1]], [c[0] - n[0], c[1] - n[1]]]
    }

    /// Centres of the child diamonds (midpoints of the legs), some possibly outside the
    /// square; none for the finest splittable diamonds (legs of length one cell diagonal).
    pub fn children(&self) -> Option<[[i32; 2]; 4]> {
        let [x, y] = self.centre;
        let h = self.half;
        if self.is_square() {
            Some([[x - h, y], [x + h, y], [x, y - h], [x, y + h]])
        } else if h >= 2 {
            let q = h / 2;
            Some([
                [x - q, y - q],
                [x + q, y - q],
                [x - q, y + q],
                [x + q, y + q],
            ])
        } else {
            None
        }
    }

    /// Whether the hypotenuse lies on a *cluster diamond edge* of cluster level `level`: on a
    /// leg of a level-`level` triangle. Merging such a diamond would remove a vertex from an
    /// edge that a level-`level` cluster shares with a level-`level + 1` one (its leg is their
    /// hypotenuse), so the adaptive merge at that level leaves it split. Legs on the square's
    /// boundary are shared with nobody and stay mergeable.
    ///
    /// The legs of even level 2j are the grid lines of spacing g = side / 2^j; those of odd
    /// level 2j + 1 are both diagonals of every cell of that grid (lines x ± y ∈ gℤ). Only
    /// meaningful for diamonds at level ≥ `level` (coarser ones are corners of the clusters).
    pub fn on_cluster_edge(&self, level: u32, side: i32) -> bool {
        let g = side >> (level / 2);
        let [x, y] = self.centre;
        match (level % 2, self.hypotenuse) {
            (0, Hypotenuse::Horizontal) => y % g == 0 && y != 0 && y != side,
            (0, Hypotenuse::Vertical) => x % g == 0 && x != 0 && x != side,
            (1, Hypotenuse::Rising) => (x - y).rem_euclid(g) == 0,
            (1, Hypotenuse::Falling) => (x + y) % g == 0,
            _ => false,
        }
    }
}

/// Whether a point lies in the closed square.
pub fn in_square(side: i32, p: [i32; 2]) -> bool {
    (0..=side).contains(&p[0]) && (0..=side).contains(&p[1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::terrain::grid::BinTri;

    fn all_triangles(s: i32) -> Vec<BinTri> {
        let mut out = Vec::new();
        let mut stack = crate::terrain::grid::roots_of_side(s).to_vec();
        while let Some(t) = stack.pop() {
            out.push(t);
            if t.can_split() {
                stack.extend(t.children());
            }
        }
        out
    }

    fn same_set(a: [[i32; 2]; 2], b: [[i32; 2]; 2]) -> bool {
        a == b || a == [b[1], b[0]]
    }

    #[test]
    fn diamonds_match_the_bintree() {
        for s in [2, 4, 16, 32] {
            for t in all_triangles(s) {
                if !t.can_split() {
                    continue;
                }
                let d = Diamond::at(s, t.split_point()).expect("a split point is a diamond");
                assert_eq!(d.level(s), t.level(), "{t:?}");
                assert!(same_set(d.ends(), [t.left, t.right]), "{t:?} {d:?}");
                assert!(d.apexes().contains(&t.apex), "{t:?} {d:?}");
                for c in t.children() {
                    if c.can_split() {
                        let kids = d.children().expect("split children have diamonds");
                        assert!(kids.contains(&c.split_point()), "{t:?} {d:?}");
                    } else {
                        assert!(d.children().is_none());
                    }
                }
            }
            // Every non-corner point is exactly one diamond, and corners none.
            let mut seen = std::collections::HashSet::new();
            for t in all_triangles(s) {
                if t.can_split() {
                    seen.insert(t.split_point());
                }
            }
            assert_eq!(seen.len(), ((s + 1) * (s + 1) - 4) as usize);
            for c in [[0, 0], [s, 0], [0, s], [s, s]] {
                assert!(Diamond::at(s, c).is_none());
            }
        }
    }

    #[test]
    fn cluster_edges_are_the_legs_of_the_cluster_level() {
        // A hypotenuse lies on a cluster edge of level l exactly when both its ends lie on one
        // leg of some level-l triangle that is not on the square's boundary.
        let s = 32;
        let tris = all_triangles(s);
        for l in 0..s.trailing_zeros() * 2 {
            let legs: Vec<[[i32; 2]; 2]> = tris
                .iter()
                .filter(|t| t.level() == l)
                .flat_map(|t| [[t.apex, t.left], [t.apex, t.right]])
                .filter(|[a, b]| {
                    !((a[0] == b[0] && (a[0] == 0 || a[0] == s))
                        || (a[1] == b[1] && (a[1] == 0 || a[1] == s)))
                })
                .collect();
            let on_leg = |p: [i32; 2], [a, b]: [[i32; 2]; 2]| {
                let cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
                let dot = (p[0] - a[0]) * (b[0] - a[0]) + (p[1] - a[1]) * (b[1] - a[1]);
                let len = (b[0] - a[0]).pow(2) + (b[1] - a[1]).pow(2);
                cross == 0 && (0..=len).contains(&dot)
            };
            for t in &tris {
                if t.level() < l || !t.can_split() {
                    continue;
                }
                let d = Diamond::at(s, t.split_point()).unwrap();
                let expected = legs
                    .iter()
                    .any(|&leg| on_leg(t.left, leg) && on_leg(t.right, leg));
                assert_eq!(d.on_cluster_edge(l, s), expected, "level {l} {t:?}");
            }
        }
    }
}
