//! Stored errors that are bounds (`build --bounded-errors`, issue 13) on real scans: for
//! object-space cuts at several thresholds, the two-sided distance between the drawn patches
//! and the input surface (the leaf patches), sampled independently of the build's bound, is
//! never above the largest error of the drawn diamonds. Sampling can only show a bound false:
//! a sampled distance above the stored error fails the test.

use tessera_core::cut::select_stateless;
use tessera_core::hausdorff::sampled_directed;
use tessera_core::repository::surface::patch_surface;
use tessera_core::repository::{Repository, NO_INDEX};
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::BuildConfig;
use tessera_tests::{build, testdata};

/// Largest sampled two-sided distance between the cut at object-space threshold `epsilon`
/// and the leaves, the largest error of the cut's diamonds, and the cut's triangles.
fn cut_against_input(repo: &Repository, epsilon: f32) -> (f64, f64, usize) {
    let errors: Vec<f32> = repo.diamonds().iter().map(|d| d.error).collect();
    let tets = repo.tets();
    let drawn = select_stateless(tets, &errors, epsilon);
    let largest = drawn
        .iter()
        .map(|&t| match tets[t as usize].diamond {
            NO_INDEX => 0.0,
            d => errors[d as usize] as f64,
        })
        .fold(0.0, f64::max);
    let (cut_positions, cut) = patch_surface(repo, drawn.iter().map(|&t| t as usize)).unwrap();
    let leaves = (0..tets.len()).filter(|&t| tets[t].diamond == NO_INDEX);
    let (leaf_positions, leaves) = patch_surface(repo, leaves).unwrap();
    // One position list: the cut's vertices, then the leaves'.
    let offset = cut_positions.len() as u32;
    let positions: Vec<[f64; 3]> = cut_positions.into_iter().chain(leaf_positions).collect();
    let leaves: Vec<u32> = leaves.iter().map(|i| i + offset).collect();
    let distance = sampled_directed(&positions, &cut, &leaves, 4)
        .max(sampled_directed(&positions, &leaves, &cut, 2));
    (distance, largest, cut.len() / 3)
}

fn errors_bound_the_cuts(name: &str) {
    let mesh = load_mesh(&testdata(name)).unwrap().mesh;
    let mut config = BuildConfig::default();
    config.simplify.bounded_errors = true;
    let bounded = build(&mesh, &config);
    let estimated = build(&mesh, &BuildConfig::default());
    for (label, built) in [("bounded", &bounded), ("estimated", &estimated)] {
        let repo = &built.repo;
        let h = repo.header();
        // The stored patches stand within half a lattice step of the input (the leaves too).
        let quantisation = 0.5 * h.position_step.iter().map(|s| s * s).sum::<f64>().sqrt();
        let mut errors: Vec<f32> = repo.diamonds().iter().map(|d| d.error).collect();
        errors.sort_by(f32::total_cmp);
        let root = *errors.last().unwrap();
        for epsilon in [
            errors[errors.len() / 2],
            errors[errors.len() * 9 / 10],
            root * 0.5,
        ] {
            let (distance, largest, drawn) = cut_against_input(repo, epsilon);
            eprintln!(
                "{name} {label}: cut at {epsilon:.3e}: {drawn} triangles, sampled two-sided \
                 distance {distance:.3e}, largest drawn error {largest:.3e} (ratio {:.2})",
                distance / largest.max(f64::MIN_POSITIVE)
            );
            if label == "bounded" {
                assert!(
                    distance <= largest + quantisation,
                    "{name}: the cut at {epsilon:e} is {distance:e} from the input, its largest \
                     stored error {largest:e}"
                );
            }
        }
    }
}

#[test]
fn bounded_errors_hold_on_the_bunny() {
    errors_bound_the_cuts("mesh/bunny00.off");
}

#[test]
fn bounded_errors_hold_on_the_lion() {
    errors_bound_the_cuts("mesh/lion-head.off");
}
