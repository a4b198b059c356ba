//! The wgpu device: adapter choice (by name, or the best one present), the features the
//! renderer needs and those it uses when present, and a clear error when nothing fits.
//!
//! Works on lavapipe (Mesa's CPU Vulkan driver, `mesa-vulkan-drivers`), our GPU in CI, and on
//! real GPUs. `TESSERA_ADAPTER` (or `--adapter`) picks an adapter by a case-insensitive
//! substring of its name, e.g. `llvmpipe`; wgpu's own `WGPU_BACKEND` limits the backends.

use std::fmt::Write as _;

/// Environment variable naming the adapter to use (a substring of its name).
pub const ADAPTER_ENV: &str = "TESSERA_ADAPTER";

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
    #[error("adapter {adapter:?} lacks what tessera needs: {missing}")]
    Unsupported { adapter: String, missing: String },
    #[error("adapter {adapter:?} refused to create a device: {source}")]
    RequestDevice {
        adapter: String,
        #[source]
        source: wgpu::RequestDeviceError,
    },
}

/// What the renderer may use beyond the required minimum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capabilities {
    /// `multi_draw_indexed_indirect_count`, where the adapter has it and it honours primitive
    /// restart (`probe.rs`): the GPU reads the draw count. Without it, every slot of the draw
    /// list is issued and unused slots draw nothing.
    pub draw_indirect_count: bool,
    /// GPU timestamps around each frame (`gpu_ms`).
    pub timestamps: bool,
    /// Line polygon mode (wireframe overlay).
    pub wireframe: bool,
}

/// A device and queue, with what they can do.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    pub capabilities: Capabilities,
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

/// Features the renderer cannot work without: the traversal writes each draw's simplex index
/// as its first instance, which the vertex shader reads back.
const REQUIRED: wgpu::Features = wgpu::Features::INDIRECT_FIRST_INSTANCE;

impl GpuContext {
    /// Opens the adapter whose name contains `wanted` (case-insensitive), else the one named by
    /// `TESSERA_ADAPTER`, else the best present (discrete, integrated, virtual, then CPU).
    pub fn new(wanted: Option<&str>) -> Result<GpuContext, DeviceError> {
        pollster::block_on(Self::new_async(wanted))
    }

    async fn new_async(wanted: Option<&str>) -> Result<GpuContext, DeviceError> {
        let instance = wgpu::Instance::new(instance_descriptor(false));
        let adapters = instance.enumerate_adapters(wgpu::Backends::all()).await;
        if adapters.is_empty() {
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
        let mut info = adapter.get_info();
        // On DX12, wgpu's indirect validation also supplies base_vertex and first_instance to
        // the shader builtins, which the vertex shader needs: keep it there.
        let mut adapter = adapter.clone();
        if info.backend == wgpu::Backend::Dx12 {
            let dx12 = wgpu::Instance::new(instance_descriptor(true))
                .enumerate_adapters(wgpu::Backends::DX12)
                .await;
            if let Some(same) = dx12.into_iter().find(|a| a.get_info() == info) {
                adapter = same;
                info = adapter.get_info();
            }
        }
        usable(&adapter).map_err(|missing| DeviceError::Unsupported {
            adapter: info.name.clone(),
            missing,
        })?;
        let features = adapter.features();
        let optional = wgpu::Features::MULTI_DRAW_INDIRECT_COUNT
            | wgpu::Features::TIMESTAMP_QUERY
            | wgpu::Features::POLYGON_MODE_LINE;
        let limits = adapter.limits();
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("tessera"),
                required_features: REQUIRED | (features & optional),
                required_limits: limits.clone(),
                ..Default::default()
            })
            .await
            .map_err(|source| DeviceError::RequestDevice {
                adapter: info.name.clone(),
                source,
            })?;
        let mut ctx = GpuContext {
            device,
            queue,
            capabilities: Capabilities {
                draw_indirect_count: false,
                timestamps: features.contains(wgpu::Features::TIMESTAMP_QUERY),
                wireframe: features.contains(wgpu::Features::POLYGON_MODE_LINE),
            },
            info,
            limits,
        };
        // The feature bit is not enough: the count path must honour primitive restart.
        ctx.capabilities.draw_indirect_count = features
            .contains(wgpu::Features::MULTI_DRAW_INDIRECT_COUNT)
            && super::probe::count_draws_restart_strips(&ctx);
        Ok(ctx)
    }

    /// "name (backend, device type)", for reports.
    pub fn adapter_description(&self) -> String {
        format!(
            "{} ({:?}, {:?})",
            self.info.name, self.info.backend, self.info.device_type
        )
    }

    /// Blocks until the GPU has finished everything submitted.
    pub fn wait_idle(&self) {
        // An error here means the device was lost; the next call reports it.
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }
}

/// Ok, or what the adapter lacks.
fn usable(adapter: &wgpu::Adapter) -> Result<(), String> {
    let mut missing = Vec::new();
    if !adapter.features().contains(REQUIRED) {
        missing.push(format!("features {:?}", REQUIRED - adapter.features()));
    }
    let downlevel = adapter.get_downlevel_capabilities();
    for (flag, name) in [
        (wgpu::DownlevelFlags::COMPUTE_SHADERS, "compute shaders"),
        (wgpu::DownlevelFlags::INDIRECT_EXECUTION, "indirect draws"),
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

/// The instance: backends and flags from wgpu's environment variables, except that wgpu's
/// CPU-side validation of indirect draws is off unless `indirect_validation` (or
/// `WGPU_VALIDATION_INDIRECT_CALL=1`) asks for it. It costs ~0.3 ms a frame on a 15 K-simplex
/// model (most of the frame's CPU time) and protects against indirect arguments that address
/// outside the bound buffers; ours come from the traversal over tables and patches the reader
/// validated at load (strip ranges inside their page, zero-filled unused slots).
fn instance_descriptor(indirect_validation: bool) -> wgpu::InstanceDescriptor {
    let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle();
    descriptor.flags = wgpu::InstanceFlags::from_build_config();
    descriptor.flags.set(
        wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL,
        indirect_validation,
    );
    descriptor.with_env()
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
