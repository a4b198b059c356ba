//! Buffers, textures and dispatches are sized against the adapter's limits (issue 11, item 5):
//! each case on a smaller GPU emulated through `DeviceOptions::limits`, refused with a message
//! naming the limit, or split / streamed within it.

use std::sync::Arc;
use tessera_core::repository::patch::drawn_patch_bytes;

use tessera_core::cull::CullTests;
use tessera_core::repository::Repository;
use tessera_preprocess::import::load_mesh;
use tessera_preprocess::BuildConfig;
use tessera_runtime::camera::{bounding_radius, Camera, Y_UP};
use tessera_runtime::gpu::stream_pool::{PatchSizes, PoolLayout};
use tessera_runtime::gpu::streamer::feedback_capacity;
use tessera_runtime::gpu::{
    DeviceOptions, FrameRequest, GpuContext, GpuStreamer, Readback, Renderer, RendererOptions,
    ShadingMode, FLAG_COLOUR,
};
use tessera_runtime::stream::{UnitState, UnitTable};
use tessera_tests::{build, gpu, testdata, Built};

const SIZE: (u32, u32) = (240, 160);

/// The bunny built without the headroom levels above its cube (`BuildConfig::headroom`): with
/// them one of its units (8 patches, 33,736 bytes) falls between the pool's page and the
/// binding limit this test sets, and is refused as it must be (a unit lands in one page), but
/// the test's oracle compares units with the binding limit, not the page.
fn bunny() -> (Built, Arc<Repository>) {
    let input = load_mesh(&testdata("mesh/bunny00.off")).expect("import");
    let config = BuildConfig {
        headroom: 0,
        ..BuildConfig::default()
    };
    let b = build(&input.mesh, &config);
    let shared = Arc::new(Repository::open(b.dir.path().join("model.tsr")).expect("reopen"));
    (b, shared)
}

/// The adapter's limits changed by `edit`, opened as a device.
fn smaller_gpu(edit: impl FnOnce(&mut wgpu::Limits)) -> Result<GpuContext, String> {
    let mut limits = gpu().limits.clone();
    edit(&mut limits);
    GpuContext::open(&DeviceOptions {
        limits: Some(limits),
        ..Default::default()
    })
    .map_err(|e| e.to_string())
}

fn options(width: u32, height: u32, budget_bytes: u64) -> RendererOptions {
    RendererOptions {
        width,
        height,
        budget_bytes,
        ..Default::default()
    }
}

/// Bytes unit `u` takes in a page: its patches back to back, each 8-aligned (the loader's
/// layout).
/// Tet `i`'s patch as the GPU holds it (decoded).
fn drawn(repo: &Repository, i: usize) -> u64 {
    drawn_patch_bytes(&repo.tets()[i], repo.header().attributes)
}

fn placed_bytes(repo: &Repository, units: &UnitTable, u: u32) -> u64 {
    units
        .simplices(u)
        .iter()
        .map(|&s| drawn(repo, s as usize).next_multiple_of(8))
        .sum()
}

/// A unit R(D) larger than one page (pages are at most one storage binding) can never land.
/// With the binding limit just below the bunny's largest unit, that unit is refused up front
/// (`UnitState::TooLarge`), its diamond never refines although the view wants it to, every
/// frame still draws the CPU reference's selection with no flag pixel, and the stream
/// settles. (Without the refusal the unit is issued, read and then waits for a page for good:
/// still `Loading` and never settled after 300 frames, checked by hand.)
#[test]
fn a_unit_larger_than_a_page_is_refused_and_the_stream_settles() {
    let (_b, repo) = bunny();
    let units = UnitTable::new(
        repo.diamonds(),
        repo.tets(),
        repo.header().root_tet_count as usize,
        &|t| drawn_patch_bytes(t, repo.header().attributes),
    );
    let (big, big_bytes) = (0..units.len() as u32)
        .map(|u| (u, placed_bytes(&repo, &units, u)))
        .max_by_key(|&(u, bytes)| (bytes, std::cmp::Reverse(u)))
        .expect("units");
    let limit = (big_bytes - 8) & !7;
    let roots = units.root_bytes();
    eprintln!(
        "largest unit {big}: {big_bytes} B; binding limit {limit} B; roots {roots} B; {} units",
        units.len()
    );
    assert!(
        limit > roots && limit > 4 * (units.roots().len() as u64 + 2) * 88,
        "the roots must fit one binding"
    );
    let ctx = smaller_gpu(|l| l.max_storage_buffer_binding_size = limit)
        .expect("a device with a smaller binding limit");
    let (mut renderer, mut streamer) = GpuStreamer::new(
        &ctx,
        repo.clone(),
        options(SIZE.0, SIZE.1, 64 << 20),
        1 << 20,
    )
    .expect("streaming within the binding limit");
    assert_eq!(streamer.residency().state(big), UnitState::TooLarge);
    // The feedback lists are one binding too: a large target's share is cut to it.
    let feedback = feedback_capacity(1 << 24, 3840, 2160, &ctx.limits) as u64;
    assert!(feedback > 0 && 16 + 16 * feedback <= limit, "{feedback}");
    let too_large = streamer.residency().stats().too_large_units;
    assert!(too_large >= 1);
    // Every refused unit is one no page can hold, and every other fits one.
    for u in 0..units.len() as u32 {
        let refused = streamer.residency().state(u) == UnitState::TooLarge;
        assert_eq!(refused, placed_bytes(&repo, &units, u) > limit, "unit {u}");
    }
    streamer.set_cpu_reference(true);
    let h = repo.header();
    // Looking at the refused unit's diamond from outside the model, close enough to want it.
    let d = &repo.diamonds()[big as usize];
    let target = [0, 1, 2].map(|k| h.origin[k] + d.center[k] as f64);
    let middle = [0, 1, 2].map(|k| 0.5 * (h.bbox_min[k] + h.bbox_max[k]));
    let away = [0, 1, 2].map(|k| target[k] - middle[k]);
    let norm = away.iter().map(|a| a * a).sum::<f64>().sqrt().max(1e-9);
    let eye = [0, 1, 2].map(|k| target[k] + away[k] / norm * 2.5 * d.radius as f64);
    let camera = Camera {
        up: Y_UP,
        width: SIZE.0,
        height: SIZE.1,
        ..Camera::looking_at(eye, target, bounding_radius(h.bbox_min, h.bbox_max))
    };
    let request = FrameRequest {
        cull: CullTests {
            frustum: Some(camera.view_volume()),
            cones: false,
        },
        mode: ShadingMode::Check,
        ..FrameRequest::new(camera, 0.05)
    };
    let mut settled_at = None;
    let mut wanted_big = false;
    for i in 0..300 {
        let f = streamer
            .frame(
                &ctx,
                &mut renderer,
                &request,
                Readback {
                    image: true,
                    selection: true,
                },
            )
            .expect("frame");
        let mut cpu = f.reference.selection.clone();
        cpu.retain(|&s| repo.tets()[s as usize].strip_index_count > 0);
        assert_eq!(
            renderer.read_selection(&ctx).expect("selection"),
            cpu,
            "frame {i}"
        );
        let image = renderer.read_image(&ctx).expect("image");
        assert_eq!(
            image.pixels().filter(|p| p.0 == FLAG_COLOUR).count(),
            0,
            "frame {i}"
        );
        assert!(!streamer.residency().may_refine()[big as usize]);
        wanted_big |= f.reference.wanted.iter().any(|&(d, _)| d == big);
        if f.settled {
            settled_at = Some(i);
            break;
        }
    }
    let stats = streamer.residency().stats();
    eprintln!("settled at {settled_at:?}: {stats:?}");
    assert!(settled_at.is_some(), "never settled: {stats:?}");
    assert!(
        wanted_big,
        "the view wants the refused unit's diamond to refine"
    );
    assert!(stats.resident_units > 0, "{stats:?}");
    assert_eq!(streamer.residency().state(big), UnitState::TooLarge);
}

/// The shaders clamp their dispatches at 65,535 workgroups a dimension and stride over the
/// rest: an adapter allowing fewer is refused, naming the limit.
#[test]
fn fewer_workgroups_per_dimension_than_the_shaders_assume_are_refused_by_name() {
    let Err(error) = smaller_gpu(|l| l.max_compute_workgroups_per_dimension = 1024) else {
        panic!("a device with 1024 workgroups a dimension was accepted");
    };
    assert!(
        error.contains("max_compute_workgroups_per_dimension") && error.contains("65535"),
        "{error}"
    );
}

/// A target beyond the largest texture, or whose read-back buffer is beyond the largest
/// buffer, is refused naming the limit, by the resident and the streaming renderer alike.
#[test]
fn a_target_beyond_the_texture_or_buffer_limit_is_refused_by_name() {
    let (_b, repo) = bunny();
    for (edit, width, height, named) in [
        (
            (|l: &mut wgpu::Limits| l.max_texture_dimension_2d = 256) as fn(&mut wgpu::Limits),
            320,
            200,
            "max_texture_dimension_2d",
        ),
        (
            |l: &mut wgpu::Limits| l.max_buffer_size = 1 << 20,
            1024,
            1024,
            "max_buffer_size",
        ),
    ] {
        let ctx = smaller_gpu(edit).expect("a device with smaller limits");
        let resident = Renderer::new(&ctx, &repo, options(width, height, 1 << 30))
            .err()
            .expect("refused")
            .to_string();
        let streamed =
            GpuStreamer::new(&ctx, repo.clone(), options(width, height, 1 << 30), 1 << 20)
                .err()
                .expect("refused")
                .to_string();
        for message in [resident, streamed] {
            assert!(
                message.contains(named) && message.contains(&format!("{width}×{height}")),
                "{message}"
            );
        }
        // Within the limits the same device draws.
        Renderer::new(&ctx, &repo, options(200, 100, 1 << 30)).expect("a size within limits");
    }
}

/// Pages are one storage binding each, the compaction dispatches one workgroup per page and
/// the pages' draw arguments (64 bytes each) are one binding: with a binding of a few patches,
/// the fully resident renderer refuses a blob of more pages than that, naming the limits, and
/// the streaming pool cuts itself to the pages it can draw.
#[test]
fn more_pages_than_one_binding_of_draw_arguments_are_refused_or_cut() {
    let (_b, repo) = bunny();
    let count = repo.tets().len();
    let largest = (0..count).map(|i| drawn(&repo, i)).max().unwrap();
    let limit = largest.next_multiple_of(8);
    let blob: u64 = (0..count).map(|i| drawn(&repo, i)).sum();
    assert!(
        blob / limit > limit / 64,
        "the test needs more pages than fit"
    );
    let ctx = smaller_gpu(|l| l.max_storage_buffer_binding_size = limit)
        .expect("a device with a smaller binding limit");
    let message = Renderer::new(&ctx, &repo, options(200, 100, 1 << 30))
        .err()
        .expect("refused")
        .to_string();
    assert!(
        message.contains("pages")
            && message.contains("max_compute_workgroups_per_dimension")
            && message.contains("max_storage_buffer_binding_size"),
        "{message}"
    );
    let layout = PoolLayout::new(
        PatchSizes::of(repo.tets(), repo.header().attributes),
        1 << 30,
        limit,
        limit,
        1 << 20,
    );
    assert!(layout.pages as u64 * 64 <= limit, "{layout:?}");
    assert!(
        layout.page_bytes <= limit && layout.page_bytes > 0,
        "{layout:?}"
    );
}
