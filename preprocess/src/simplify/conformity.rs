//! The conformity assertion: a diamond's new patch keeps the border of the region it replaces.
//!
//! The crack-free argument (module comment of `simplify`) holds only if simplifying a diamond
//! leaves the border between its gathered triangles and the rest of the mesh exactly as it
//! was. That is checked here for every diamond, while building, so that a simplifier that
//! breaks it (a lock ignored, a collapse across the border, a flap dropped from a border edge)
//! fails the build naming the diamond instead of travelling into the repository as cracks that
//! only some cuts show.
//!
//! The border of a triangle set, as a chain modulo 2, is the set of its edges used an odd
//! number of times (a border edge of a manifold patch is used once, an inner edge twice, a
//! non-manifold edge of three sheets three times). Replacing the gathered set G by the output
//! P leaves every other triangle of the mesh as it is, so each edge's total use count changes
//! by uses_P − uses_G; the mesh keeps its borders where it has them exactly when those two
//! have the same parity on every edge that the rest of the mesh can see:
//!
//! - where the build keeps input borders (`SimplifySettings::keep_borders`, meshes), every
//!   edge keeps its parity: inner edges stay inner, border edges (the region's border with the
//!   rest of the mesh, and holes inside the diamond) stay borders;
//! - where input borders are free (height fields shorten their outline chains: an outline
//!   vertex inside the diamond goes, its two border edges become one), an odd edge of G that
//!   the rest of the mesh also uses stays odd — the border with the rest of the mesh —, and
//!   an edge that becomes odd joins two vertices that were on G's border — a chain shortened,
//!   never a hole opened inside. Odd edges only G uses may go (the shortened chain's: an input
//!   border, even where both its endpoints are shared, as where a hole's outline crosses the
//!   region's border).

use super::local_edges::LocalEdges;

/// An edge whose parity the simplification changed, in the diamond's local vertex numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct BorderBreak {
    pub a: u32,
    pub b: u32,
    /// Triangles using the edge in the gathered set and in the output.
    pub gathered_uses: u32,
    pub output_uses: u32,
}

/// What `border_break` found.
#[derive(Debug, Default, PartialEq, Eq)]
pub(super) struct BorderCheck {
    /// The first edge (in `gathered`'s, then `output`'s order) on which the output does not
    /// keep the border whatever the rest of the mesh does.
    pub broken: Option<BorderBreak>,
    /// Odd edges between two shared vertices that went even with borders free: a shortened
    /// input border if nothing else uses the edge, a broken border with the rest of the mesh
    /// otherwise. Only the rest's counts tell (`edge_census.rs`).
    pub broken_if_used_outside: Vec<BorderBreak>,
}

/// Checks that `output` keeps `gathered`'s border. `interior[v]`: every triangle of the
/// current mesh using local vertex `v` is in the gathered set.
pub(super) fn border_break(
    gathered: &LocalEdges,
    output: &LocalEdges,
    interior: &[bool],
    keep_borders: bool,
) -> BorderCheck {
    let mut on_border = vec![false; interior.len()];
    for (_, a, b, n) in gathered.iter() {
        if n % 2 == 1 {
            on_border[a as usize] = true;
            on_border[b as usize] = true;
        }
    }
    let shared = |a: u32, b: u32| !interior[a as usize] && !interior[b as usize];
    let mut check = BorderCheck::default();
    let mut judge = |a: u32, b: u32, gathered_uses: u32, output_uses: u32| {
        let edge = BorderBreak {
            a,
            b,
            gathered_uses,
            output_uses,
        };
        let broken = if gathered_uses % 2 == output_uses % 2 {
            false
        } else if keep_borders {
            true
        } else if gathered_uses % 2 == 1 {
            // A shortened chain's edge, never the border with the rest.
            if shared(a, b) {
                check.broken_if_used_outside.push(edge);
            }
            false
        } else {
            // A shortened chain's new edge joins two vertices of the old border.
            !(on_border[a as usize] && on_border[b as usize])
        };
        if broken && check.broken.is_none() {
            check.broken = Some(edge);
        }
    };
    let uses_in =
        |edges: &LocalEdges, a: u32, b: u32| edges.find(a, b).map_or(0, |i| edges.uses(i));
    for (_, a, b, n) in gathered.iter() {
        judge(a, b, n, uses_in(output, a, b));
    }
    for (_, a, b, n) in output.iter() {
        if gathered.find(a, b).is_none() {
            judge(a, b, 0, n);
        }
    }
    check
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles sharing edge (1, 2): a square 0-1-3-2 with border 0-1, 1-3, 3-2, 2-0.
    const SQUARE: [u32; 6] = [0, 1, 2, 2, 1, 3];

    fn check(
        gathered: &[u32],
        output: &[u32],
        interior: &[bool],
        keep: bool,
    ) -> Option<BorderBreak> {
        let g = LocalEdges::count(interior.len(), gathered);
        let o = LocalEdges::count(interior.len(), output);
        // With every odd edge between shared vertices also used by the rest of the mesh.
        let check = border_break(&g, &o, interior, keep);
        check
            .broken
            .or_else(|| check.broken_if_used_outside.first().copied())
    }

    #[test]
    fn the_same_border_passes() {
        let shared = [false; 4];
        assert_eq!(check(&SQUARE, &SQUARE, &shared, true), None);
        // The other diagonal: a new inner edge (used twice), the old one gone (was twice).
        assert_eq!(check(&SQUARE, &[0, 1, 3, 0, 3, 2], &shared, true), None);
    }

    #[test]
    fn a_dropped_triangle_opens_the_border() {
        let shared = [false; 4];
        let broken = check(&SQUARE, &[0, 1, 2], &shared, true).expect("a border opened");
        // Edge (1, 2) was inner (2 uses) and is now a border (1 use).
        assert_eq!((broken.a, broken.b), (1, 2));
        assert_eq!((broken.gathered_uses, broken.output_uses), (2, 1));
    }

    #[test]
    fn a_collapsed_border_vertex_is_caught() {
        // A fan around interior vertex 4 inside the square 0-1-3-2, collapsed onto corner 0:
        // the border 0-1-3-2 keeps, but collapsing corner 1 onto 0 loses border edge 1-3.
        let fan = [0, 1, 4, 1, 3, 4, 3, 2, 4, 2, 0, 4];
        let interior = [false, false, false, false, true];
        assert_eq!(check(&fan, &SQUARE, &interior, true), None);
        let collapsed = [0, 3, 2];
        let broken = check(&fan, &collapsed, &interior, true).expect("border edge lost");
        assert_eq!((broken.a, broken.b), (0, 1));
    }

    #[test]
    fn free_borders_only_check_shared_edges() {
        // Vertex 1 is an interior outline vertex of a height field: its border edges may
        // shorten when borders are free, never when they are kept.
        let interior = [false, true, false, false];
        let shortened = [0, 3, 2];
        assert_eq!(check(&SQUARE, &shortened, &interior, false), None);
        assert!(check(&SQUARE, &shortened, &interior, true).is_some());
        // The border with the rest of the mesh (both endpoints shared) stays, either way.
        let shared = [false; 4];
        let broken = check(&SQUARE, &shortened, &shared, false).expect("shared border lost");
        assert_eq!((broken.a, broken.b), (0, 1));
        // A hole opened inside is never a shortened chain: (0, 4) and (2, 4) were inner.
        let fan = [0, 1, 4, 1, 3, 4, 3, 2, 4, 2, 0, 4];
        let interior = [false, false, false, false, true];
        let holed = [0, 1, 4, 1, 3, 4, 3, 2, 4];
        assert!(check(&fan, &holed, &interior, false).is_some());
        // An input border (a hole's outline) between two shared vertices, used by nothing
        // else, may shorten.
        let g = LocalEdges::count(4, &SQUARE);
        let o = LocalEdges::count(4, &shortened);
        let check = border_break(&g, &o, &shared, false);
        assert_eq!(check.broken, None);
        assert_eq!(check.broken_if_used_outside.len(), 2, "{check:?}");
    }
}
