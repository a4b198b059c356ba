//! ROAM's nested wedgies: one thickness per bintree triangle, stored by heap id.
//!
//! A wedgie is the volume between the triangle's plane shifted down and up by its thickness
//! e(T). ROAM needs the wedgies *nested* (a child's inside its parent's), which the
//! bottom-up recurrence e(T) = max(e(children)) + |h(split point) − interpolated height|
//! guarantees: the child's corners lie within e(T) − e(child) of T's plane, so their own
//! ±e(child) slab stays inside T's. Nesting is what makes the priorities monotone (a child is
//! never more urgent than its parent), and the queues rely on that to converge.

use crate::terrain::grid::{BinGrid, BinTri};

/// Nested (saturated) error per bintree triangle, indexed by `BinTri::id`.
#[derive(Clone, Debug)]
pub struct WedgieErrors {
    max_level: u32,
    /// Whether the values nest as wedgies of the grid (`from_grid`): then a child's wedgie
    /// box lies inside its parent's and priorities are monotone without clamping.
    nested: bool,
    /// 2^(max_level + 2) entries, by heap id; 0 and 1 unused.
    values: Vec<f32>,
}

impl WedgieErrors {
    /// ROAM's nested wedgie thickness of every bintree triangle down to `grid.finest_level()`:
    /// e(T) = max(e(children)) + |h(split point) − (h(left) + h(right))/2|, 0 at the finest
    /// level.
    pub fn from_grid(grid: &BinGrid) -> WedgieErrors {
        let max_level = grid.finest_level();
        let mut values = vec![0.0f32; 1usize << (max_level + 2)];
        for root in grid.roots() {
            thickness(grid, root, max_level, &mut values);
        }
        WedgieErrors {
            max_level,
            nested: true,
            values,
        }
    }

    /// Given per-triangle values down to `max_level` (inclusive), a Vec of length
    /// 2^(max_level + 2) indexed by `BinTri::id` (entries 0 and 1 unused); saturated here so a
    /// parent ≥ each child. ROAM never splits a triangle at `max_level`.
    ///
    /// Negative and NaN values read as 0 (an error is a magnitude; NaN would break the
    /// queues' ordering); +∞ is kept and means "always worth splitting".
    pub fn from_values(max_level: u32, mut values: Vec<f32>) -> WedgieErrors {
        let len = 1usize << (max_level + 2);
        assert_eq!(
            values.len(),
            len,
            "WedgieErrors::from_values: 2^(max_level + 2) values for max_level {max_level}"
        );
        for v in values.iter_mut() {
            *v = v.max(0.0); // NaN.max(0) = 0
        }
        // Children (2i, 2i + 1) have larger ids than their parent: one descending pass
        // saturates every chain from the bottom up.
        for id in (2..len / 2).rev() {
            values[id] = values[id].max(values[2 * id]).max(values[2 * id + 1]);
        }
        WedgieErrors {
            max_level,
            nested: false,
            values,
        }
    }

    /// The deepest level the values cover; triangles there are never split.
    pub fn max_level(&self) -> u32 {
        self.max_level
    }

    /// Whether the wedgies nest exactly (`from_grid`), so priorities need no clamping.
    pub fn nested(&self) -> bool {
        self.nested
    }

    /// The thickness of `t` (0 below `max_level`, where nothing is ever split).
    pub fn get(&self, t: &BinTri) -> f32 {
        self.values.get(t.id as usize).copied().unwrap_or(0.0)
    }
}

/// Post-order: the children's thicknesses first, then this triangle's, stored by id. The sum
/// is taken in f64 and rounded *up* to f32, so the stored parent wedgie really contains its
/// children's (a rounded-down sum could leave a child's slab an ulp outside, and a child an
/// ulp more urgent than its parent).
fn thickness(grid: &BinGrid, t: BinTri, max_level: u32, values: &mut [f32]) -> f32 {
    if t.level() >= max_level || !t.can_split() {
        values[t.id as usize] = 0.0;
        return 0.0;
    }
    let [a, b] = t.children();
    let below = thickness(grid, a, max_level, values).max(thickness(grid, b, max_level, values));
    let mid = 0.5 * (grid.height(t.left) as f64 + grid.height(t.right) as f64);
    let sum = below as f64 + (grid.height(t.split_point()) as f64 - mid).abs();
    let mut e = sum as f32;
    if (e as f64) < sum {
        e = f32::from_bits(e.to_bits() + 1);
    }
    values[t.id as usize] = e;
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize, f: impl Fn(usize, usize) -> f32) -> BinGrid {
        crate::terrain::grid::test_grid(n, n, f)
    }

    fn all(t: BinTri, max_level: u32, out: &mut Vec<BinTri>) {
        out.push(t);
        if t.level() < max_level {
            for c in t.children() {
                all(c, max_level, out);
            }
        }
    }

    #[test]
    fn from_grid_is_nested_and_bounds_every_sample_below() {
        let g = grid(17, |r, c| ((r * 13 + c * 7) % 11) as f32 - 0.3 * (r as f32));
        let w = WedgieErrors::from_grid(&g);
        assert_eq!(w.max_level(), g.finest_level());
        assert!(w.nested());
        let mut tris = Vec::new();
        for root in g.roots() {
            all(root, w.max_level(), &mut tris);
        }
        for t in &tris {
            if t.level() == w.max_level() {
                assert_eq!(w.get(t), 0.0);
                continue;
            }
            let [a, b] = t.children();
            let d = (g.height(t.split_point()) as f64
                - 0.5 * (g.height(t.left) as f64 + g.height(t.right) as f64))
                .abs();
            let sum = w.get(&a).max(w.get(&b)) as f64 + d;
            let e = w.get(t) as f64;
            assert!(e >= sum && e - sum <= 1e-6 * sum, "{t:?}: {e} vs {sum}");
            // The wedgie contains the surface of every descendant: here, every sample the
            // triangle covers lies within e(T) of its plane.
            let e = w.get(t) as f64 + 1e-4;
            let tri = crate::terrain::grid::sample_triangle(&g, t.corners());
            let [p, q, r] = tri;
            let det = (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]);
            for y in 0..=16 {
                for x in 0..=16 {
                    let (x, y) = (x as f64, y as f64);
                    let wq = ((x - p[0]) * (r[1] - p[1]) - (y - p[1]) * (r[0] - p[0])) / det;
                    let wr = ((q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0])) / det;
                    let wp = 1.0 - wq - wr;
                    if wp < -1e-9 || wq < -1e-9 || wr < -1e-9 {
                        continue;
                    }
                    let plane = wp * p[2] + wq * q[2] + wr * r[2];
                    let h = g.height([x as i32, y as i32]) as f64;
                    assert!((plane - h).abs() <= e, "{t:?} at ({x}, {y})");
                }
            }
        }
        // A plane has no error at all.
        let flat = grid(9, |r, c| 2.0 * r as f32 - c as f32);
        let w = WedgieErrors::from_grid(&flat);
        assert!(flat.roots().iter().all(|t| w.get(t) == 0.0));
    }

    #[test]
    fn from_values_saturates_and_keeps_its_max_level() {
        let max_level = 5;
        let len = 1usize << (max_level + 2);
        // Deterministic scramble, with a NaN and a negative thrown in.
        let mut values: Vec<f32> = (0..len).map(|i| ((i * 37) % 23) as f32).collect();
        values[40] = f32::NAN;
        values[41] = -3.0;
        values[len - 1] = 1000.0;
        let w = WedgieErrors::from_values(max_level, values.clone());
        assert_eq!(w.max_level(), max_level);
        assert!(!w.nested());
        let tri = |id: u64| BinTri {
            apex: [0, 0],
            left: [0, 0],
            right: [0, 0],
            id,
        };
        for id in 2..len as u64 / 2 {
            let (p, a, b) = (
                w.get(&tri(id)),
                w.get(&tri(2 * id)),
                w.get(&tri(2 * id + 1)),
            );
            assert!(p >= a && p >= b, "id {id}: {p} < children {a}, {b}");
            assert!(p >= values[id as usize].max(0.0));
        }
        // The deepest value climbs to the roots; deepest entries stay as given.
        assert_eq!(w.get(&tri(3)), 1000.0);
        assert_eq!(w.get(&tri(len as u64 - 2)), values[len - 2]);
        assert!(w.get(&tri(40)) >= 0.0 && w.get(&tri(41)) >= 0.0);
        assert_eq!(w.get(&tri(len as u64)), 0.0, "below max_level: nothing");
    }
}
