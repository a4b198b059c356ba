//! Stored errors that are bounds (`build --bounded-errors`, issue 13) on real scans: for
//! object-space cuts at several thresholds, the two-sided distance between the drawn patches
//! and the input surface (the leaf patches), sampled independently of the build's bound, is
//! never above the largest error of the drawn diamonds. Sampling can only show a bound false:
//! a sampled distance above the stored error fails the test.

use tessera_core::repository::surface::{leaf_surface, measure_object_cut};
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::BuildConfig;
use tessera_tests::{build, testdata};

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
        let leaves = leaf_surface(repo).unwrap();
        for epsilon in [
            errors[errors.len() / 2],
            errors[errors.len() * 9 / 10],
            root * 0.5,
        ] {
            let m = measure_object_cut(repo, &leaves, epsilon, 4, 2).unwrap();
            let (distance, largest, drawn) = (m.distance, m.largest_error, m.triangles);
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
