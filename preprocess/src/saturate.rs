//! Saturation (seed 001, "Saturation technique"): bottom-up over the diamond DAG,
//! err(D) = max(own(D), floor, max over split children C of err(C)·(1 + ERROR_MARGIN)) and
//! sphere(D) ⊇ D's patches and every child's sphere grown by `radius_margin`, so that
//! ρ(parent) ≥ ρ(child) holds for every eye even after f32 rounding (DESIGN.md, "Float
//! robustness"): far eyes are covered by the relative error margin, near eyes by the absolute
//! radius margin.

use rustc_hash::FxHashMap as HashMap;

use tessera_core::bounds::Sphere;
use tessera_core::leb::{DiamondId, SimplexKey};

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
/// origin); `error_floor` (> 0) keeps every split diamond's error positive, so τ = 0 selects
/// the leaves; `model_size` scales the radius margin; `origin` is the repository origin.
pub fn saturate(
    hierarchy: &Hierarchy,
    origin: [f64; 3],
    own_error: &[f32],
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
    // Children are split after their parents, so the reverse split order visits children first.
    let margin = RADIUS_MARGIN * model_size;
    for i in (0..n).rev() {
        let d = &hierarchy.diamonds[i];
        let mut e = (own_error[i] as f64).max(error_floor);
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
