//! The per-diamond `may_refine` flags streaming will use (DESIGN.md, "Out-of-core"): a diamond
//! whose flag is clear does not refine, ρ'(D) = 0. The GPU traversal and the CPU reference
//! apply the same flags, and the cut stays conforming.

use tessera_core::cull::CullTests;
use tessera_core::cut::{
    close_may_refine, diamond_rhos, forbid_refine, may_refine, may_refine_all, restrict_rhos,
    select_visible,
};
use tessera_core::repository::format::NO_INDEX;
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::BuildConfig;
use tessera_runtime::camera::{Camera, Y_UP};
use tessera_runtime::geometric_check::{check_cuts_restricted, decode_all_patches, CheckEye};
use tessera_runtime::gpu::{FrameRequest, Readback, RenderError, Renderer, RendererOptions};
use tessera_tests::{build, gpu, testdata};

const TAU: f32 = 1.0;

#[test]
fn a_diamond_kept_from_refining_gives_the_same_conforming_cut_on_gpu_and_cpu() {
    let mesh = load_mesh(&testdata("mesh/bunny00.off"))
        .expect("import")
        .mesh;
    let built = build(&mesh, &BuildConfig::default());
    let repo = &built.repo;
    let h = *repo.header();
    let (width, height) = (480, 270);
    let cameras: Vec<Camera> = (0..8)
        .map(|k| Camera {
            width,
            height,
            ..Camera::orbit(h.bbox_min, h.bbox_max, Y_UP, 45.0 * k as f64, 15.0, 1.8)
        })
        .collect();

    // The diamond to keep from refining: one that the first view refines, halfway down the
    // hierarchy, so that the cut changes below it and stays the same elsewhere.
    let first = &cameras[0];
    let rhos = diamond_rhos(repo.diamonds(), first.eye_local(h.origin), &first.metric());
    let deepest = repo.diamonds().iter().map(|d| d.level).max().unwrap();
    let chosen = (0..repo.diamonds().len() as u32)
        .filter(|&d| rhos[d as usize] > TAU)
        .min_by_key(|&d| repo.diamonds()[d as usize].level.abs_diff(deepest / 2))
        .expect("the view refines some diamond");
    let mut words = may_refine_all(repo.diamonds().len());
    forbid_refine(&mut words, chosen);
    close_may_refine(repo.diamonds(), &mut words);

    let ctx = gpu();
    let mut renderer = Renderer::new(
        &ctx,
        repo,
        RendererOptions {
            width,
            height,
            ..Default::default()
        },
    )
    .unwrap();
    // A wrong length is refused with the numbers, and changes nothing.
    assert!(matches!(
        renderer.set_may_refine(&ctx, &words[1..]),
        Err(RenderError::MayRefineLength { .. })
    ));
    let mut changed_views = 0;
    for camera in &cameras {
        let request = FrameRequest {
            cull: CullTests::NONE,
            ..FrameRequest::new(*camera, TAU)
        };
        let eye_local = camera.eye_local(h.origin);
        let full_rhos = diamond_rhos(repo.diamonds(), eye_local, &camera.metric());
        let mut restricted = full_rhos.clone();
        restrict_rhos(&mut restricted, &words);
        let cpu = |rhos: &[f32]| {
            let mut s = select_visible(repo.tets(), rhos, TAU, eye_local, &request.cull);
            s.retain(|&i| repo.tets()[i as usize].strip_index_count > 0);
            s
        };
        let readback = Readback {
            image: false,
            selection: true,
        };
        let mut gpu_selection = |words: &[u32]| {
            renderer.set_may_refine(&ctx, words).unwrap();
            renderer.render(&ctx, &request, readback);
            renderer.read_selection(&ctx).expect("selection read back")
        };
        let restricted_gpu = gpu_selection(&words);
        let full_gpu = gpu_selection(&may_refine_all(repo.diamonds().len()));
        assert_eq!(restricted_gpu, cpu(&restricted), "{camera:?}");
        assert_eq!(full_gpu, cpu(&full_rhos), "{camera:?}");
        if restricted_gpu != full_gpu {
            changed_views += 1;
            // Coarser: no simplex of a diamond below the chosen one is drawn.
            assert!(restricted_gpu.len() < full_gpu.len(), "{camera:?}");
        }
        // Nothing below a diamond that may not refine is drawn.
        assert!(restricted_gpu.iter().all(|&i| {
            let p = repo.tets()[i as usize].parent_diamond;
            p == NO_INDEX || may_refine(&words, p)
        }));
        if std::ptr::eq(camera, &cameras[0]) {
            // The first view refines the chosen diamond: now its own simplices are drawn.
            assert!(
                restricted_gpu
                    .iter()
                    .any(|&i| repo.tets()[i as usize].diamond == chosen),
                "no simplex of diamond {chosen} drawn"
            );
        }
    }
    assert!(
        changed_views > 0,
        "keeping diamond {chosen} from refining changed nothing"
    );

    // Conforming: the exact crack check over these eyes with the flags applied.
    let patches = decode_all_patches(repo).unwrap();
    let eyes: Vec<CheckEye> = cameras
        .iter()
        .map(|c| CheckEye {
            eye: c.eye,
            metric: c.metric(),
        })
        .collect();
    let report = check_cuts_restricted(repo, &patches, &eyes, &[0.5, TAU, 4.0], Some(&words));
    assert!(report.is_clean(), "{report:?}");
    assert_eq!(report.cuts_checked, 3 * cameras.len());
}
