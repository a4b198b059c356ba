//! Saturation (seed 001, "Saturation technique"): bottom-up over the diamond DAG,
//! err(D) = max(own(D) + quantisation, floor, max over split children C of err(C)·(1 + ERROR_MARGIN)) and
//! sphere(D) ⊇ D's patches and every child's sphere grown by `radius_margin`, so that
//! ρ(parent) ≥ ρ(child) holds for every eye even after f32 rounding (DESIGN.md, "Float
//! robustness"): far eyes are covered by the relative error margin, near eyes by the absolute
//! radius margin.

use rustc_hash::FxHashMap as HashMap;

use tessera_core::bounds::Sphere;
use tessera_core::leb::{DiamondId, SimplexKey};
use tessera_core::repository::format::{TetRecord, NO_INDEX};

use crate::hierarchy::Hierarchy;

/// Relative growth of the error from child to parent (≫ f32's 6e-8 rounding).
pub const ERROR_MARGIN: f64 = 1e-5;
/// Absolute growth of the radius from child to parent, as a fraction of the model's size.
pub const RADIUS_MARGIN: f64 = 1e-5;

/// Saturated error and sphere per split diamond (indexed like `Hierarchy::diamonds`).
pub struct Saturated {
    pub error: Vec<f64>,
    pub sphere: Vec<Sphere>,
}

/// `patch_sphere` gives the bounding sphere of a simplex's patch (relative to the repository
/// origin); `quantisation_error` (≥ 0) is added to every own error: the simplifier measures
/// on the input's positions, the stored patches stand on the position lattice, within that
/// distance of them; `error_floor` (> 0) keeps every split diamond's error positive, so τ = 0
/// selects the leaves; `model_size` scales the radius margin; `origin` is the repository
/// origin.
pub fn saturate(
    hierarchy: &Hierarchy,
    origin: [f64; 3],
    own_error: &[f32],
    quantisation_error: f64,
    patch_sphere: &impl Fn(SimplexKey) -> Sphere,
    error_floor: f64,
    model_size: f64,
) -> Saturated {
    let index: HashMap<DiamondId, usize> = hierarchy
        .diamonds
        .iter()
        .enumerate()
        .map(|(i, d)| (d.id, i))
        .collect();
    let n = hierarchy.diamonds.len();
    let mut error = vec![0.0f64; n];
    let mut sphere = vec![Sphere::EMPTY; n];
    // Children come after their parents (a level deeper), so the reverse order visits children
    // first.
    let margin = RADIUS_MARGIN * model_size;
    for i in (0..n).rev() {
        let d = &hierarchy.diamonds[i];
        let mut e = (own_error[i] as f64 + quantisation_error).max(error_floor);
        let mut s = d
            .simplices
            .iter()
            .fold(Sphere::EMPTY, |acc, t| acc.merge(&patch_sphere(t.key)));
        for c in d.children.iter().filter_map(|c| index.get(c)) {
            debug_assert!(*c > i, "child diamond split before its parent");
            e = e.max(error[*c] * (1.0 + ERROR_MARGIN));
            s = s.merge(&sphere[*c].inflated(margin));
        }
        if s.is_empty() {
            // A diamond with no geometry at all below it: a point sphere at its split point.
            let f = &hierarchy.frame;
            s = Sphere {
                center: [0, 1, 2].map(|k| {
                    (f.origin[k] + d.id[k] as f64 * f.unit) + (f.model_origin[k] - origin[k])
                }),
                radius: 0.0,
            };
        }
        error[i] = e;
        sphere[i] = s;
    }
    Saturated { error, sphere }
}

/// Makes every simplex's sphere contain its patch and, grown by `margin` (so containment
/// survives f32 rounding), both children's spheres: a simplex's sphere then bounds every patch
/// of its subtree, so a traversal may cull a simplex before refining it (nothing below an
/// invisible sphere is visible) and streaming requests only what a view can show. Children
/// come after their parents in the table, so one reverse pass nests them (and one forward
/// pass places empty subtrees at their parent's centre).
pub fn nest_simplex_spheres(tets: &mut [TetRecord], spheres: &mut [Sphere], margin: f64) {
    for i in (0..tets.len()).rev() {
        let c = tets[i].first_child;
        if c != NO_INDEX {
            let c = c as usize;
            spheres[i] = spheres[i]
                .merge(&spheres[c].inflated(margin))
                .merge(&spheres[c + 1].inflated(margin));
        }
        (tets[i].center, tets[i].radius) = spheres[i].to_f32();
    }
    // A subtree with no triangle gets a point at its parent's centre: inside the parent's
    // sphere like any other child, so culling stays monotone down the tree.
    for i in 0..tets.len() {
        let c = tets[i].first_child;
        if c != NO_INDEX {
            for c in [c as usize, c as usize + 1] {
                if spheres[c].is_empty() {
                    tets[c].center = tets[i].center;
                }
            }
        }
    }
    // The f32 spheres nest too (the margin dwarfs f32 rounding): checked here, where a broken
    // invariant would otherwise travel silently into the repository and cull visible patches.
    let f64s = |c: [f32; 3]| c.map(f64::from);
    for (i, t) in tets
        .iter()
        .enumerate()
        .filter(|(_, t)| t.first_child != NO_INDEX)
    {
        for c in [t.first_child as usize, t.first_child as usize + 1] {
            let child = &tets[c];
            let reach = tessera_core::bounds::distance(f64s(t.center), f64s(child.center))
                + child.radius as f64;
            assert!(
                spheres[c].is_empty() || reach <= t.radius as f64,
                "simplex {i}'s sphere does not contain its child {c}'s ({reach} > {})",
                t.radius
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::LatticeFrame;
    use crate::hierarchy::{build_hierarchy, Construction};

    #[test]
    fn the_quantisation_error_is_added_to_every_own_error() {
        let frame = LatticeFrame::around_box([0.0; 3], [1.0; 3], 10, 3);
        let barycenters: Vec<[f64; 3]> = (0..64)
            .map(|i| [0, 1, 2].map(|k| ((i * (7 + 5 * k) + 3) % 64) as f64 / 64.0 + 0.004))
            .collect();
        let hierarchy = build_hierarchy(frame, &barycenters, Construction::Levels(4));
        let n = hierarchy.diamonds.len();
        assert!(n > 4);
        let own = vec![1.0f32; n];
        let sphere = |_| Sphere {
            center: [0.5; 3],
            radius: 0.5,
        };
        let floor = 0.1;
        let without = saturate(&hierarchy, [0.0; 3], &own, 0.0, &sphere, floor, 1.0);
        let with = saturate(&hierarchy, [0.0; 3], &own, 0.25, &sphere, floor, 1.0);
        for (a, b) in without.error.iter().zip(&with.error) {
            // err = (own + q)·(1 + margin)^k along the deepest chain below: at least own + q.
            assert!(*b >= 1.25 && *b >= a + 0.25 - 1e-12, "{a} {b}");
        }
        // A floor above own + q still wins: it is a floor, not a term.
        let floored = saturate(&hierarchy, [0.0; 3], &own, 0.25, &sphere, 5.0, 1.0);
        assert!(floored.error.iter().all(|&e| e >= 5.0));
    }
}
