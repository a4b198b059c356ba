//! The wgpu device: backend and adapter choice (by name, or the best one present), the
//! capabilities the renderer needs and those it uses when present, and a clear error when
//! nothing fits.
//!
//! Works on lavapipe (Mesa's CPU Vulkan driver, `mesa-vulkan-drivers`), our GPU in CI, on
//! wgpu's GL backend (llvmpipe through EGL here) and on real GPUs. `TESSERA_ADAPTER` (or
//! `--adapter`) picks an adapter by a case-insensitive substring of its name, e.g. `llvmpipe`;
//! `--backend` (else wgpu's own `WGPU_BACKEND`) limits the backends.
//!
//! What the renderer relies on, checked before a device is made (`usable`): compute shaders,
//! indirect draws and dispatches, storage buffers read by vertex shaders, 10 storage buffers in
//! one compute stage (the traversal), 256-thread workgroups (the compaction). It needs no
//! optional feature: no primitive restart, multi-draw, count draw or `first_instance`.

use std::fmt::Write as _;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// Environment variable naming the adapter to use (a substring of its name).
pub const ADAPTER_ENV: &str = "TESSERA_ADAPTER";

/// Environment variable injecting a device fault, for the tests of what every GPU command
/// does then (exit 3 with a message, never a panic or a hang): `lost@N` destroys the device
/// (`Device::destroy`) right after the Nth frame is submitted; `oom@N` hands the device's
/// error handler the out-of-memory error wgpu reports for a failed allocation, at the Nth
/// submit; `readback@N` destroys the buffer of the first read-back after the Nth submit, so
/// its `map_async` fails. `N` defaults to 1.
pub const FAULT_ENV: &str = "TESSERA_GPU_FAULT";

/// The device failed: lost, out of memory, a read-back that could not be mapped, or an error
/// wgpu reported outside any error scope. Nothing more can be drawn; the CLI exits with 3.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("the GPU device failed: {0}")]
pub struct GpuFailure(pub String);

/// A fault `FAULT_ENV` asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FaultKind {
    Lost,
    OutOfMemory,
    Readback,
}

/// What the device's callbacks saw, and the injected fault.
#[derive(Debug, Default)]
struct FaultState {
    /// The first failure reported (device lost, an uncaptured error).
    first: Mutex<Option<String>>,
    /// Frames submitted (`GpuContext::submitted`).
    submits: AtomicU64,
    /// `readback@N` has failed its read-back.
    readback_failed: AtomicBool,
    inject: Option<(FaultKind, u64)>,
}

impl FaultState {
    /// Keeps the first failure, on one line (wgpu's messages span several).
    fn record(&self, message: String) {
        if let Ok(mut first) = self.first.lock() {
            first.get_or_insert_with(|| message.split_whitespace().collect::<Vec<_>>().join(" "));
        }
    }
}

/// Parses `FAULT_ENV`'s value (`kind[@N]`).
fn parse_fault(text: &str) -> Option<(FaultKind, u64)> {
    let (kind, at) = text.split_once('@').unwrap_or((text, "1"));
    let kind = match kind.trim() {
        "lost" => FaultKind::Lost,
        "oom" => FaultKind::OutOfMemory,
        "readback" => FaultKind::Readback,
        _ => return None,
    };
    Some((kind, at.trim().parse().ok()?))
}

/// Why no device could be made.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    #[error(
        "no GPU adapter found (wgpu saw none on any backend). On Debian/Ubuntu, \
         `apt-get install mesa-vulkan-drivers` provides lavapipe, a CPU Vulkan driver"
    )]
    NoAdapter,
    #[error("no adapter's name contains {wanted:?}; adapters present:\n{present}")]
    NoMatchingAdapter { wanted: String, present: String },
    #[error("no adapter on the {backend} backend; adapters present on any backend:\n{present}")]
    NoAdapterOnBackend { backend: Backend, present: String },
    #[error(
        "adapter {adapter:?} ({backend}) lacks what tessera needs to draw correctly: {missing}"
    )]
    Unsupported {
        adapter: String,
        backend: Backend,
        missing: String,
    },
    #[error("adapter {adapter:?} refused to create a device: {source}")]
    RequestDevice {
        adapter: String,
        #[source]
        source: wgpu::RequestDeviceError,
    },
}

/// A wgpu backend, as `--backend` names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    Vulkan,
    Gl,
    Metal,
    Dx12,
}

impl Backend {
    pub const ALL: [Backend; 4] = [Backend::Vulkan, Backend::Gl, Backend::Metal, Backend::Dx12];

    /// The name `--backend` takes and reports print ("vulkan", "gl", "metal", "dx12").
    pub fn name(self) -> &'static str {
        match self {
            Backend::Vulkan => "vulkan",
            Backend::Gl => "gl",
            Backend::Metal => "metal",
            Backend::Dx12 => "dx12",
        }
    }

    fn backends(self) -> wgpu::Backends {
        match self {
            Backend::Vulkan => wgpu::Backends::VULKAN,
            Backend::Gl => wgpu::Backends::GL,
            Backend::Metal => wgpu::Backends::METAL,
            Backend::Dx12 => wgpu::Backends::DX12,
        }
    }

    /// The backend of an adapter (`None` for wgpu's no-op and browser backends).
    pub fn of(backend: wgpu::Backend) -> Option<Backend> {
        match backend {
            wgpu::Backend::Vulkan => Some(Backend::Vulkan),
            wgpu::Backend::Gl => Some(Backend::Gl),
            wgpu::Backend::Metal => Some(Backend::Metal),
            wgpu::Backend::Dx12 => Some(Backend::Dx12),
            _ => None,
        }
    }
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Backend {
    type Err = String;
    fn from_str(s: &str) -> Result<Backend, String> {
        Backend::ALL
            .into_iter()
            .find(|b| {
                b.name().eq_ignore_ascii_case(s)
                    || (s.eq_ignore_ascii_case("opengl") && *b == Backend::Gl)
            })
            .ok_or_else(|| format!("unknown backend {s:?}: expected vulkan, gl, metal or dx12"))
    }
}

/// Which device to open.
#[derive(Clone, Debug, Default)]
pub struct DeviceOptions {
    /// A substring of the adapter's name (default: `TESSERA_ADAPTER`, else the best present).
    pub adapter: Option<String>,
    /// Only this backend (default: `WGPU_BACKEND`, else every backend).
    pub backend: Option<Backend>,
    /// Limits to request instead of the adapter's (each at most the adapter's): a smaller
    /// GPU emulated, for tests of what the renderer does at the limits.
    pub limits: Option<wgpu::Limits>,
}

/// What the renderer may use beyond the required minimum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capabilities {
    /// GPU timestamps around each frame (`gpu_ms`).
    pub timestamps: bool,
    /// Line polygon mode (wireframe overlay).
    pub wireframe: bool,
    /// `@early_depth_test(force)` in fragment shaders: the textured fill's page requests
    /// then come from visible fragments only (a fragment with side effects otherwise runs
    /// before the depth test).
    pub early_depth_test: bool,
    /// BC1-7 textures: BC1 texture pages stay compressed on the GPU (`texture_pages::PoolFormat`;
    /// a test may clear it to exercise the decoding path).
    pub bc_textures: bool,
}

/// A device and queue, with what they can do.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// The backend in use (reports print it: `"backend": "vulkan"`).
    pub backend: Backend,
    pub limits: wgpu::Limits,
    pub capabilities: Capabilities,
    /// The instance and adapter the device was made from: a window's surface (`tessera
    /// view`) is created on this instance and must be supported by this adapter.
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    faults: Arc<FaultState>,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.info.name)
            .field("backend", &self.info.backend)
            .field("capabilities", &self.capabilities)
            .finish_non_exhaustive()
    }
}

/// Storage buffers the traversal binds in its compute stage.
const TRAVERSAL_STORAGE_BUFFERS: u32 = 11;

impl GpuContext {
    /// Opens the adapter whose name contains `wanted` (case-insensitive), else the one named by
    /// `TESSERA_ADAPTER`, else the best present (discrete, integrated, virtual, then CPU), on
    /// the backends `WGPU_BACKEND` allows.
    pub fn new(wanted: Option<&str>) -> Result<GpuContext, DeviceError> {
        Self::open(&DeviceOptions {
            adapter: wanted.map(str::to_string),
            ..Default::default()
        })
    }

    /// Opens the device `options` describe (`new`, with a backend that overrides
    /// `WGPU_BACKEND`).
    pub fn open(options: &DeviceOptions) -> Result<GpuContext, DeviceError> {
        pollster::block_on(Self::new_async(options, None))
    }

    /// `open`, on an instance that knows the display a window's surface will be made on
    /// (`tessera view`): wgpu's GL backend needs it to present; Vulkan, Metal and DX12 ignore
    /// it.
    pub fn open_with_display(
        options: &DeviceOptions,
        display: Box<dyn wgpu::wgt::WgpuHasDisplayHandle>,
    ) -> Result<GpuContext, DeviceError> {
        pollster::block_on(Self::new_async(options, Some(display)))
    }

    async fn new_async(
        options: &DeviceOptions,
        display: Option<Box<dyn wgpu::wgt::WgpuHasDisplayHandle>>,
    ) -> Result<GpuContext, DeviceError> {
        let wanted = options.adapter.as_deref();
        let instance = wgpu::Instance::new(instance_descriptor(options.backend, display));
        let backends = options
            .backend
            .map_or(wgpu::Backends::all(), Backend::backends);
        let adapters = instance.enumerate_adapters(backends).await;
        if adapters.is_empty() {
            if let Some(backend) = options.backend {
                let everywhere = wgpu::Instance::new(instance_descriptor(None, None))
                    .enumerate_adapters(wgpu::Backends::all())
                    .await;
                return Err(DeviceError::NoAdapterOnBackend {
                    backend,
                    present: if everywhere.is_empty() {
                        "  (none)\n".to_string()
                    } else {
                        describe(&everywhere)
                    },
                });
            }
            return Err(DeviceError::NoAdapter);
        }
        let from_env = std::env::var(ADAPTER_ENV).ok().filter(|s| !s.is_empty());
        let wanted = wanted.map(str::to_string).or(from_env);
        let adapter = match &wanted {
            Some(name) => {
                let needle = name.to_lowercase();
                adapters
                    .iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&needle))
                    .ok_or_else(|| DeviceError::NoMatchingAdapter {
                        wanted: name.clone(),
                        present: describe(&adapters),
                    })?
            }
            None => adapters
                .iter()
                .filter(|a| usable(a).is_ok())
                .min_by_key(|a| preference(&a.get_info()))
                .unwrap_or(&adapters[0]),
        };
        let info = adapter.get_info();
        let backend = Backend::of(info.backend);
        usable(adapter).map_err(|missing| DeviceError::Unsupported {
            adapter: info.name.clone(),
            backend: backend.unwrap_or(Backend::Vulkan),
            missing,
        })?;
        let backend = backend.expect("usable() accepts the four native backends only");
        let features = adapter.features();
        let optional = wgpu::Features::TIMESTAMP_QUERY
            | wgpu::Features::POLYGON_MODE_LINE
            | wgpu::Features::SHADER_EARLY_DEPTH_TEST
            | wgpu::Features::TEXTURE_COMPRESSION_BC;
        let limits = options.limits.clone().unwrap_or_else(|| adapter.limits());
        required_limits(&limits).map_err(|missing| DeviceError::Unsupported {
            adapter: info.name.clone(),
            backend,
            missing,
        })?;
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("tessera"),
                required_features: features & optional,
                required_limits: limits.clone(),
                ..Default::default()
            })
            .await
            .map_err(|source| DeviceError::RequestDevice {
                adapter: info.name.clone(),
                source,
            })?;
        // Every failure the device reports outside an error scope (wgpu's default handler
        // panics) and its loss are recorded; `check` and every wait and read-back return them.
        let inject = match std::env::var(FAULT_ENV) {
            Ok(text) if !text.is_empty() => {
                Some(parse_fault(&text).ok_or_else(|| DeviceError::Unsupported {
                    adapter: info.name.clone(),
                    backend,
                    missing: format!("{FAULT_ENV}={text:?} is not lost|oom|readback[@N]"),
                })?)
            }
            _ => None,
        };
        let faults = Arc::new(FaultState {
            inject,
            ..Default::default()
        });
        let sink = faults.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            sink.record(match &e {
                wgpu::Error::OutOfMemory { source } => format!("out of GPU memory: {source}"),
                _ => format!("wgpu reported an error: {e}"),
            })
        }));
        let sink = faults.clone();
        device.set_device_lost_callback(move |reason, message| {
            sink.record(if message.is_empty() {
                format!("device lost ({reason:?})")
            } else {
                format!("device lost ({reason:?}): {message}")
            });
        });
        Ok(GpuContext {
            faults,
            device,
            queue,
            capabilities: Capabilities {
                timestamps: features.contains(wgpu::Features::TIMESTAMP_QUERY),
                wireframe: features.contains(wgpu::Features::POLYGON_MODE_LINE),
                early_depth_test: features.contains(wgpu::Features::SHADER_EARLY_DEPTH_TEST),
                bc_textures: features.contains(wgpu::Features::TEXTURE_COMPRESSION_BC),
            },
            info,
            backend,
            limits,
            adapter: adapter.clone(),
            instance,
        })
    }

    /// "name (backend, device type)", for reports.
    pub fn adapter_description(&self) -> String {
        format!(
            "{} ({}, {:?})",
            self.info.name, self.backend, self.info.device_type
        )
    }

    /// Blocks until the GPU has finished everything submitted; the device's failure, if it
    /// failed (`check`).
    pub fn wait_idle(&self) -> Result<(), GpuFailure> {
        self.check()?;
        let polled = self.device.poll(wgpu::PollType::wait_indefinitely());
        self.check()?;
        polled
            .map(|_| ())
            .map_err(|e| GpuFailure(format!("waiting for the GPU: {e}")))
    }

    /// The first failure the device reported (lost, out of memory, an error outside any
    /// error scope), if any.
    pub fn check(&self) -> Result<(), GpuFailure> {
        match self.faults.first.lock() {
            Ok(first) => first.clone().map_or(Ok(()), |m| Err(GpuFailure(m))),
            Err(_) => Err(GpuFailure("the device's error state is poisoned".into())),
        }
    }

    /// Counts a frame just submitted (`Renderer::render`, `FullMeshRenderer::render`) and
    /// injects the fault `FAULT_ENV` asks for at that frame.
    pub fn submitted(&self) {
        let n = self.faults.submits.fetch_add(1, Ordering::AcqRel) + 1;
        match self.faults.inject {
            Some((FaultKind::Lost, at)) if n == at => self.device.destroy(),
            Some((FaultKind::OutOfMemory, at)) if n == at => {
                // What the handler installed in `new_async` records for wgpu's error.
                self.faults.record(
                    "out of GPU memory: an allocation failed (injected by TESSERA_GPU_FAULT)"
                        .into(),
                )
            }
            _ => {}
        }
    }

    /// Whether the read-back about to start should fail (`FAULT_ENV`'s `readback@N`: the
    /// first one after the Nth submit).
    pub(crate) fn fail_this_readback(&self) -> bool {
        match self.faults.inject {
            Some((FaultKind::Readback, at)) => {
                self.faults.submits.load(Ordering::Acquire) >= at
                    && !self.faults.readback_failed.swap(true, Ordering::AcqRel)
            }
            _ => false,
        }
    }
}

/// Ok, or the limits among `limits` (those the device is opened with) that are below what
/// the renderer's shaders assume: they clamp their dispatches at 65,535 workgroups a
/// dimension and stride over the rest.
fn required_limits(limits: &wgpu::Limits) -> Result<(), String> {
    let need = super::shaders::MAX_WORKGROUPS_PER_DIMENSION;
    if limits.max_compute_workgroups_per_dimension < need {
        return Err(format!(
            "limit max_compute_workgroups_per_dimension ≥ {need} (it has {})",
            limits.max_compute_workgroups_per_dimension
        ));
    }
    Ok(())
}

/// Ok, or what the adapter lacks.
fn usable(adapter: &wgpu::Adapter) -> Result<(), String> {
    let mut missing = Vec::new();
    if Backend::of(adapter.get_info().backend).is_none() {
        missing.push(format!(
            "a native backend (it is {:?})",
            adapter.get_info().backend
        ));
    }
    let limits = adapter.limits();
    for (name, have, need) in [
        (
            "max_storage_buffers_per_shader_stage",
            limits.max_storage_buffers_per_shader_stage,
            TRAVERSAL_STORAGE_BUFFERS,
        ),
        (
            "max_compute_invocations_per_workgroup",
            limits.max_compute_invocations_per_workgroup,
            super::shaders::COMPACT_WORKGROUP,
        ),
        (
            "max_compute_workgroup_size_x",
            limits.max_compute_workgroup_size_x,
            super::shaders::COMPACT_WORKGROUP,
        ),
        (
            "max_compute_workgroups_per_dimension",
            limits.max_compute_workgroups_per_dimension,
            super::shaders::MAX_WORKGROUPS_PER_DIMENSION,
        ),
        (
            "max_compute_workgroup_storage_size",
            limits.max_compute_workgroup_storage_size,
            4 * super::shaders::COMPACT_WORKGROUP + 4,
        ),
    ] {
        if have < need {
            missing.push(format!("limit {name} ≥ {need} (it has {have})"));
        }
    }
    let downlevel = adapter.get_downlevel_capabilities();
    for (flag, name) in [
        (wgpu::DownlevelFlags::COMPUTE_SHADERS, "compute shaders"),
        (
            wgpu::DownlevelFlags::INDIRECT_EXECUTION,
            "indirect draws and dispatches",
        ),
        (
            wgpu::DownlevelFlags::VERTEX_STORAGE,
            "storage buffers in vertex shaders",
        ),
    ] {
        if !downlevel.flags.contains(flag) {
            missing.push(name.to_string());
        }
    }
    if missing.is_empty() {
        Ok(())
    } else {
        Err(missing.join(", "))
    }
}

/// The instance: backends and flags from wgpu's environment variables (`backend`, when given,
/// replaces `WGPU_BACKEND`), the display windows will be on when given, except that wgpu's validation of indirect draws is off unless
/// `WGPU_VALIDATION_INDIRECT_CALL=1` asks for it: it costs CPU time every frame and protects
/// against indirect arguments that address outside the bound buffers: ours draw no vertex
/// buffers (vertices are pulled, WGSL storage reads are bounds-checked) and the compaction
/// keeps every indexed draw inside its page's index region.
fn instance_descriptor(
    backend: Option<Backend>,
    display: Option<Box<dyn wgpu::wgt::WgpuHasDisplayHandle>>,
) -> wgpu::InstanceDescriptor {
    let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle();
    descriptor.display = display;
    descriptor.flags = wgpu::InstanceFlags::from_build_config();
    descriptor
        .flags
        .remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
    let mut descriptor = descriptor.with_env();
    if let Some(backend) = backend {
        descriptor.backends = backend.backends();
    }
    descriptor
}

/// Lower is better.
fn preference(info: &wgpu::AdapterInfo) -> u8 {
    match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

fn describe(adapters: &[wgpu::Adapter]) -> String {
    let mut out = String::new();
    for a in adapters {
        let i = a.get_info();
        let _ = writeln!(out, "  {} ({:?}, {:?})", i.name, i.backend, i.device_type);
    }
    out
}
