//! The attribute errors a cut draws: for each tolerance, the largest stored attribute errors
//! (colour, normal, UV: the repository's table, saturated by the maximum) over the diamonds
//! whose simplices the stateless cut draws from any of some eyes. A drawn simplex's patch is
//! what its diamond's simplification kept (a leaf's is the input: no error). `check` reports
//! it at its views, `bench` at its dense pass's, so both read the same thing.

use serde_json::json;
use tessera_core::cut::{diamond_rhos, select_stateless};
use tessera_core::metric::{eye_local, ScreenSpaceMetric};
use tessera_core::repository::format::{AttributeErrorRecord, NO_INDEX};
use tessera_core::repository::reader::Repository;

/// Per tolerance (in `tolerances`' order), the largest attribute errors of the diamonds drawn
/// from any of `eyes` (model coordinates); `None` where the repository has no attribute error
/// table (an input without colours or texture coordinates).
pub fn cut_attribute_errors(
    repo: &Repository,
    metric: &ScreenSpaceMetric,
    eyes: &[[f64; 3]],
    tolerances: &[f32],
) -> Option<Vec<(f32, AttributeErrorRecord)>> {
    let table = repo.attribute_errors()?;
    let header = repo.header();
    let (tets, diamonds) = (repo.tets(), repo.diamonds());
    let mut worst = vec![AttributeErrorRecord::default(); tolerances.len()];
    for &eye in eyes {
        let rhos = diamond_rhos(diamonds, eye_local(eye, header.origin), metric);
        for (w, &tau) in worst.iter_mut().zip(tolerances) {
            let drawn = select_stateless(tets, &rhos, tau)
                .into_iter()
                .map(|t| tets[t as usize].diamond)
                .filter(|&d| d != NO_INDEX)
                .map(|d| &table[d as usize]);
            *w = AttributeErrorRecord::max_of(drawn.chain([&*w]));
        }
    }
    Some(tolerances.iter().copied().zip(worst).collect())
}

/// The largest side of the repository's textures, in texels (`None` without textures): the
/// stored UV error times it bounds the error in texels of every texture (a wedge's texture is
/// not in the table).
pub fn largest_texture_side(repo: &Repository) -> Option<u32> {
    let table = repo.textures()?;
    table.shapes().iter().map(|s| s.width.max(s.height)).max()
}

/// One record as `info`, `check` and `bench` print it in `--json`.
pub fn record_json(r: &AttributeErrorRecord, largest_side: Option<u32>) -> serde_json::Value {
    json!({"colour": r.colour, "normal_degrees": r.normal_degrees, "uv": r.uv,
           "uv_texels": largest_side.map(|side| r.uv * side as f32)})
}

/// `cut_attribute_errors`' result in `--json`: one object a tolerance, or null.
pub fn per_tolerance_json(
    per_tau: Option<&[(f32, AttributeErrorRecord)]>,
    largest_side: Option<u32>,
) -> serde_json::Value {
    per_tau.map_or(serde_json::Value::Null, |per_tau| {
        per_tau
            .iter()
            .map(|(tau, r)| {
                let mut v = record_json(r, largest_side);
                v["tolerance"] = json!(tau);
                v
            })
            .collect()
    })
}

/// One line a tolerance, for the text reports.
pub fn print_per_tolerance(per_tau: &[(f32, AttributeErrorRecord)], largest_side: Option<u32>) {
    for (tau, r) in per_tau {
        let texels = largest_side.map_or(String::new(), |side| {
            format!(" ({:.2} texels)", r.uv * side as f32)
        });
        println!(
            "attribute errors at τ = {tau} px (largest over the cuts' diamonds): colour {:.2} \
             (8-bit RGB), normal {:.2} degrees, uv {:.3e}{texels}",
            r.colour, r.normal_degrees, r.uv
        );
    }
}
