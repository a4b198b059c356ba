//! Saturation (seed 001, "Saturation technique"): bottom-up over the diamond DAG,
//! chain(D) = own(D) + max over split children C of chain(C) (0 below the leaves) when the
//! own errors are bounds (`SimplifySettings::bounded_errors`), and for the diamonds above the
//! model's cube (`LatticeFrame::is_above_model`, whose own errors are always bounds), else
//! chain(D) = max(own(D), chain(C)) (meshoptimizer's estimates, the seed's rule),
//! err(D) = max(chain(D) + quantisation, floor, max over C of err(C)·(1 + ERROR_MARGIN)), and
//! sphere(D) ⊇ D's patches and every child's sphere grown by `radius_margin`, so that
//! ρ(parent) ≥ ρ(child) holds for every eye even after f32 rounding (DESIGN.md, "Float
//! robustness"): far eyes are covered by the relative error margin, near eyes by the absolute
//! radius margin.
//!
//! Why the chain sum makes err a bound: own(D) then bounds
//! the two-sided Hausdorff distance between the patches D gathers (its children's) and the
//! ones it keeps (`simplify.rs`). Coarsening the leaves to any conforming cut merges diamonds
//! one at a time, each replacing its children's patches by its own. A point of the cut on a
//! patch of D was moved there from the leaves through a descending chain of merged diamonds,
//! each move no longer than that diamond's own error, so it lies within chain(D) of the input
//! surface; a point of the input is carried up an ascending chain that ends at a drawn
//! diamond D', within chain(D') of the cut. The stored patches stand within `quantisation`
//! of the positions measured.

use rustc_hash::FxHashMap as HashMap;

use tessera_core::bounds::Sphere;
use tessera_core::leb::{DiamondId, SimplexKey};
use tessera_core::repository::format::{TetRecord, NO_INDEX};

use crate::hierarchy::Hierarchy;
use crate::simplify::AttributeError;

/// Relative growth of the error from child to parent (≫ f32's 6e-8 rounding).
pub const ERROR_MARGIN: f64 = 1e-5;
/// Absolute growth of the radius from child to parent, as a fraction of the model's size.
pub const RADIUS_MARGIN: f64 = 1e-5;

/// The own error of each split diamond (indexed like `Hierarchy::diamonds`, model units).
#[derive(Clone, Copy, Debug)]
pub struct OwnErrors<'a> {
    pub errors: &'a [f32],
    /// Each bounds the two-sided distance between what the diamond gathers and what it keeps
    /// (`SimplifySettings::bounded_errors`): chains sum. Otherwise they are estimates, and
    /// chains take the maximum, but above the model's cube, where they are bounds and sum
    /// (`simplify.rs`, `own_error_is_bound`).
    pub are_bounds: bool,
}

/// Saturated error and sphere per split diamond (indexed like `Hierarchy::diamonds`).
pub struct Saturated {
    pub error: Vec<f64>,
    pub sphere: Vec<Sphere>,
}

/// `own` holds each diamond's own error; `patch_sphere` gives the bounding sphere of a simplex's patch (relative to the
/// repository origin); `quantisation_error` (≥ 0) is added once to every chain: the own errors
/// are measured on the input's positions, the stored patches stand on the position lattice,
/// within that distance of them; `error_floor` (> 0) keeps every split diamond's error positive, so τ = 0
/// selects the leaves; `model_size` scales the radius margin; `origin` is the repository
/// origin.
pub fn saturate(
    hierarchy: &Hierarchy,
    origin: [f64; 3],
    own: OwnErrors,
    quantisation_error: f64,
    patch_sphere: &impl Fn(SimplexKey) -> std::io::Result<Sphere>,
    error_floor: f64,
    model_size: f64,
) -> std::io::Result<Saturated> {
    let index = diamond_positions(hierarchy);
    let n = hierarchy.diamonds.len();
    let mut error = vec![0.0f64; n];
    let mut chain = vec![0.0f64; n];
    let mut sphere = vec![Sphere::EMPTY; n];
    // Children come after their parents (a level deeper), so the reverse order visits children
    // first.
    let margin = RADIUS_MARGIN * model_size;
    for i in (0..n).rev() {
        let d = hierarchy.diamond(i);
        let below = d
            .children
            .iter()
            .filter_map(|c| index.get(c))
            .map(|&c| chain[c])
            .fold(0.0f64, f64::max);
        let own_error = own.errors[i] as f64;
        chain[i] = match own.are_bounds || hierarchy.frame.is_above_model(d.level) {
            true => own_error + below,
            false => own_error.max(below),
        };
        let mut e = (chain[i] + quantisation_error).max(error_floor);
        let mut s = Sphere::EMPTY;
        for t in &d.simplices {
            s = s.merge(&patch_sphere(t.key)?);
        }
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
    Ok(Saturated { error, sphere })
}

/// Each diamond's position in `Hierarchy::diamonds`, by id (children are named by id).
fn diamond_positions(hierarchy: &Hierarchy) -> HashMap<DiamondId, usize> {
    hierarchy
        .diamonds
        .iter()
        .enumerate()
        .map(|(i, d)| (d.id, i))
        .collect()
}

/// The saturated attribute errors (`simplify/attribute_error.rs`), indexed like
/// `Hierarchy::diamonds`: attr(D) = max(own(D), attr(C) over D's split children C), field by
/// field, bottom-up as `saturate`. So a parent's errors are at least each child's (monotone
/// like the geometric error: a cut whose diamonds' attribute errors are all ≤ x has every
/// coarser diamond on the way down ≤ x too), and attr(D) bounds the own errors of every
/// diamond merged to make D's patches from the leaves. The maximum, not a sum: an attribute
/// error is a sampled maximum over wedges, not a distance that chains add up.
pub fn saturate_attribute_errors(
    hierarchy: &Hierarchy,
    own: &[AttributeError],
) -> Vec<AttributeError> {
    assert_eq!(
        own.len(),
        hierarchy.diamonds.len(),
        "one own error a diamond"
    );
    let index = diamond_positions(hierarchy);
    let mut saturated = own.to_vec();
    // Children come after their parents, so the reverse order visits children first.
    for i in (0..own.len()).rev() {
        for &c in hierarchy
            .diamond(i)
            .children
            .iter()
            .filter_map(|c| index.get(c))
        {
            debug_assert!(c > i, "child diamond split before its parent");
            saturated[i] = saturated[i].max(saturated[c]);
        }
    }
    saturated
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

    /// A four-level hierarchy over 64 scattered points.
    fn four_levels() -> Hierarchy {
        let frame = LatticeFrame::around_box([0.0; 3], [1.0; 3], 10, 3);
        let barycenters: Vec<[f64; 3]> = (0..64)
            .map(|i| [0, 1, 2].map(|k| ((i * (7 + 5 * k) + 3) % 64) as f64 / 64.0 + 0.004))
            .collect();
        build_hierarchy(frame, &barycenters, Construction::Levels(4))
    }

    /// Diamond `i`'s split children, as positions (found by search: independent of
    /// `diamond_positions`).
    fn children_of(hierarchy: &Hierarchy, i: usize) -> Vec<usize> {
        hierarchy
            .diamond(i)
            .children
            .iter()
            .filter_map(|c| hierarchy.diamonds.iter().position(|x| x.id == *c))
            .collect()
    }

    #[test]
    fn own_errors_add_up_along_chains_and_the_quantisation_error_is_added_once() {
        let hierarchy = four_levels();
        let n = hierarchy.diamonds.len();
        assert!(n > 4);
        let own = vec![1.0f32; n];
        let sphere = |_: SimplexKey| -> std::io::Result<Sphere> {
            Ok(Sphere {
                center: [0.5; 3],
                radius: 0.5,
            })
        };
        let floor = 0.1;
        let bounds = |errors| OwnErrors {
            errors,
            are_bounds: true,
        };
        let without =
            saturate(&hierarchy, [0.0; 3], bounds(&own), 0.0, &sphere, floor, 1.0).unwrap();
        let with = saturate(
            &hierarchy,
            [0.0; 3],
            bounds(&own),
            0.25,
            &sphere,
            floor,
            1.0,
        )
        .unwrap();
        for (a, b) in without.error.iter().zip(&with.error) {
            // err = the own errors summed down the deepest chain, + q once: at least own + q.
            assert!(*b >= 1.25 && (*b - (a + 0.25)).abs() < 1e-9, "{a} {b}");
        }
        // Own errors add up along chains: a diamond k levels above the deepest split ones
        // has err = k + 1 (own 1 each).
        for i in 0..n {
            let children = children_of(&hierarchy, i);
            let below = children
                .iter()
                .map(|&c| without.error[c])
                .fold(0.0, f64::max);
            assert!(
                (without.error[i] - (1.0 + below)).abs() < 1e-9,
                "diamond {i}: {} with children at {below}",
                without.error[i]
            );
        }
        // A floor above own + q still wins: it is a floor, not a term.
        let floored =
            saturate(&hierarchy, [0.0; 3], bounds(&own), 0.25, &sphere, 5.0, 1.0).unwrap();
        assert!(floored.error.iter().all(|&e| e >= 5.0));
    }

    #[test]
    fn attribute_errors_are_the_maximum_down_the_dag() {
        let hierarchy = four_levels();
        let n = hierarchy.diamonds.len();
        // Own errors that vary against the level, so maxima come from below as well.
        let own: Vec<AttributeError> = (0..n)
            .map(|i| AttributeError {
                colour: ((i * 37) % 11) as f32,
                normal_degrees: ((i * 13) % 7) as f32,
                uv: ((i * 5) % 3) as f32 * 0.01,
            })
            .collect();
        let saturated = saturate_attribute_errors(&hierarchy, &own);
        let mut raised = 0;
        for i in 0..n {
            let children = children_of(&hierarchy, i);
            let expected = children.iter().fold(own[i], |m, &c| m.max(saturated[c]));
            assert_eq!(saturated[i], expected, "diamond {i}");
            raised += (saturated[i] != own[i]) as usize;
        }
        assert!(
            raised > 0,
            "no diamond took a child's error: the case tests nothing"
        );
    }
}
