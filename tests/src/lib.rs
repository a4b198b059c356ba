//! Shared helpers of the cross-crate integration tests (tests/tests/*.rs).

use std::path::PathBuf;

use tessera_core::repository::reader::Repository;
use tessera_preprocess::{build_repository, BuildConfig, BuildSummary, InputMesh};

/// A file of the fetched test data; panics with the fix when it is missing.
pub fn testdata(relative: &str) -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../testdata");
    let path = root.join(relative);
    assert!(
        path.exists(),
        "{} is missing: run tools/fetch-testdata.sh first (README.md, 'Tests')",
        path.display()
    );
    path
}

/// A built repository in a temporary directory (removed on drop).
pub struct Built {
    pub dir: tempfile::TempDir,
    pub repo: Repository,
    pub summary: BuildSummary,
}

/// Builds `mesh` with `config` into a temporary file and opens it with the validating reader.
pub fn build(mesh: &InputMesh, config: &BuildConfig) -> Built {
    let dir = tempfile::tempdir().expect("temporary directory");
    let path = dir.path().join("model.tsr");
    let summary = build_repository(mesh, config, &path, &|_| {}).expect("build");
    let repo = Repository::open(&path).expect("the reader accepts what the writer wrote");
    Built { dir, repo, summary }
}

/// The GPU device for tests: lavapipe in CI (`mesa-vulkan-drivers`), or whatever
/// `TESSERA_ADAPTER` names. Panics with the fix when no adapter exists.
pub fn gpu() -> tessera_runtime::gpu::GpuContext {
    tessera_runtime::gpu::GpuContext::new(None).unwrap_or_else(|e| {
        panic!("{e}\n(the GPU tests need a Vulkan adapter; .ci/run installs lavapipe)")
    })
}

/// The GPU device on `backend` (Vulkan: lavapipe, GL: llvmpipe through EGL in CI); panics
/// with what to install when the machine lacks it, so a missing backend never passes silently.
pub fn gpu_on(backend: tessera_runtime::gpu::Backend) -> tessera_runtime::gpu::GpuContext {
    let ctx = tessera_runtime::gpu::GpuContext::open(&tessera_runtime::gpu::DeviceOptions {
        adapter: None,
        backend: Some(backend),
        limits: None,
    })
    .unwrap_or_else(|e| {
        panic!(
            "{e}\n(the backend tests need both Vulkan and GL adapters: on Debian/Ubuntu \
             `apt-get install mesa-vulkan-drivers libegl1 libegl-mesa0`)"
        )
    });
    assert_eq!(ctx.backend, backend, "{}", ctx.adapter_description());
    ctx
}

/// The pixel check of `repo` from `views` views at 480 × 270 (the default tolerances).
pub fn check_pixels_small(
    ctx: &tessera_runtime::gpu::GpuContext,
    repo: &Repository,
    views: usize,
) -> tessera_runtime::pixel_check::PixelCheckReport {
    use tessera_runtime::gpu::{Renderer, RendererOptions};
    use tessera_runtime::pixel_check::{check_pixels, PixelCheckConfig};
    let options = RendererOptions {
        width: 480,
        height: 270,
        ..Default::default()
    };
    let mut renderer = Renderer::new(ctx, repo, options).expect("the model fits the GPU budget");
    let config = PixelCheckConfig {
        views,
        ..Default::default()
    };
    check_pixels(ctx, &mut renderer, repo, &config).expect("the GPU device works")
}

/// Bytes of every patch of `repo` as drawn on the GPU (decoded), summed: what a pool that
/// holds the whole model needs, before alignment.
pub fn drawn_blob_bytes(repo: &Repository) -> u64 {
    let attributes = repo.header().attributes;
    repo.tets()
        .iter()
        .map(|t| tessera_core::repository::patch::drawn_patch_bytes(t, attributes))
        .sum()
}

/// The smallest GPU budget (to 1 KiB) whose page pool holds `pool` bytes for renderers made
/// with `options(budget)`: the fixed allocations and the record slots (which take the model's
/// share of the rest) come on top.
pub fn budget_for_pool(
    ctx: &tessera_runtime::gpu::GpuContext,
    repo: &Repository,
    options: impl Fn(u64) -> tessera_runtime::gpu::RendererOptions,
    pool: u64,
) -> u64 {
    use tessera_runtime::gpu::stream_budget::{fixed_bytes, largest_unit_bytes};
    let largest = largest_unit_bytes(&tessera_runtime::stream::UnitTable::from_repository(repo));
    let pool_of = |budget| fixed_bytes(ctx, repo, &options(budget), largest).pool_bytes();
    let (mut low, mut high) = (pool, 4 * pool + (64 << 20));
    while high - low > 1024 {
        let middle = (low + high) / 2;
        if pool_of(middle) >= pool {
            high = middle;
        } else {
            low = middle;
        }
    }
    high
}

/// The demo mesh at `subdivisions` with colours and UVs on every vertex (it has normals).
pub fn attributed_demo_mesh(subdivisions: u32) -> InputMesh {
    let mut mesh = tessera_preprocess::procedural::demo_mesh(subdivisions);
    let n = mesh.positions.len();
    mesh.colors = Some(
        (0..n)
            .map(|i| [(i % 251) as u8, (i % 13) as u8, 7, 255])
            .collect(),
    );
    mesh.uvs = Some((0..n).map(|i| [i as f32 * 0.25, -(i as f32)]).collect());
    mesh
}
