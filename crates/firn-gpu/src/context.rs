//! Finding a graphics adapter and opening a device on it.
//!
//! `--backend auto` takes a hardware GPU (discrete, integrated or virtual)
//! when one is present; a software adapter such as Mesa's lavapipe is used
//! only when the GPU backend is asked for explicitly, because on it the CPU
//! backend is faster. [`adapters`] lists everything wgpu finds, for
//! `firn info`.

use std::sync::Arc;

use crate::error::GpuError;

/// One adapter as wgpu reports it, with the limits that decide which scenes fit.
#[derive(Clone, Debug, PartialEq)]
pub struct AdapterReport {
    /// Adapter name, e.g. "NVIDIA GeForce RTX 4070" or "llvmpipe (LLVM 15.0.6, 256 bits)".
    pub name: String,
    /// Graphics API it is reached through (Vulkan, Metal, Dx12, Gl).
    pub backend: String,
    /// Discrete, integrated, virtual, CPU (software) or other.
    pub device_type: String,
    /// Driver name and version, where the driver tells.
    pub driver: String,
    /// Whether it renders in software on the CPU.
    pub is_software: bool,
    /// Largest storage buffer firn can bind, in bytes: the lesser of the
    /// adapter's binding and buffer size limits.
    pub max_storage_binding: u64,
    /// Storage buffers one compute shader may bind.
    pub max_storage_buffers_per_stage: u32,
    /// Workgroups per dispatch dimension.
    pub max_workgroups_per_dimension: u32,
    /// Whether 32-bit float atomics are offered (an optional fast path; firn
    /// scatters with integer atomics everywhere).
    pub float_atomics: bool,
}

impl AdapterReport {
    fn of(adapter: &wgpu::Adapter) -> AdapterReport {
        let info = adapter.get_info();
        let limits = adapter.limits();
        AdapterReport {
            name: info.name,
            backend: format!("{:?}", info.backend),
            device_type: format!("{:?}", info.device_type),
            driver: format!("{} {}", info.driver, info.driver_info)
                .trim()
                .to_string(),
            is_software: info.device_type == wgpu::DeviceType::Cpu,
            max_storage_binding: largest_binding(&limits),
            max_storage_buffers_per_stage: limits.max_storage_buffers_per_shader_stage,
            max_workgroups_per_dimension: limits.max_compute_workgroups_per_dimension,
            float_atomics: adapter
                .features()
                .contains(wgpu::Features::SHADER_FLOAT32_ATOMIC),
        }
    }
}

/// The largest storage buffer `limits` let firn bind, in bytes.
pub fn largest_binding(limits: &wgpu::Limits) -> u64 {
    limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
}

/// Which adapters a device may be opened on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdapterPolicy {
    /// Hardware GPUs only (`--backend auto`).
    HardwareOnly,
    /// Hardware first, else a software adapter (`--backend gpu`).
    AllowSoftware,
}

fn instance(backends: wgpu::Backends) -> wgpu::Instance {
    let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    descriptor.backends &= backends;
    wgpu::Instance::new(descriptor)
}

/// The adapters of the native APIs (Vulkan, Metal, DX12), or of GL where
/// there are none (GL is asked only then: probing it prints EGL warnings);
/// those that can run firn's kernels, best first.
fn enumerate() -> Vec<wgpu::Adapter> {
    let found = |backends| {
        rank_adapters(pollster::block_on(
            instance(backends).enumerate_adapters(backends),
        ))
    };
    let native = found(wgpu::Backends::PRIMARY);
    if native.is_empty() {
        found(wgpu::Backends::GL)
    } else {
        native
    }
}

/// The adapters that can run firn's kernels, best first (discrete,
/// integrated, virtual, then software; native APIs before GL). For a caller
/// with adapters of its own `wgpu::Instance`, such as a viewer that needs
/// one that presents to its window, before [`GpuContext::open`].
pub fn rank_adapters(adapters: Vec<wgpu::Adapter>) -> Vec<wgpu::Adapter> {
    let mut usable = usable(adapters);
    usable.sort_by_cached_key(|adapter| rank(&AdapterReport::of(adapter)));
    usable
}

/// The adapters that can run firn's kernels.
fn usable(adapters: Vec<wgpu::Adapter>) -> Vec<wgpu::Adapter> {
    adapters
        .into_iter()
        .filter(|adapter| {
            let limits = adapter.limits();
            // Compute shaders with storage buffers are all firn needs.
            limits.max_storage_buffers_per_shader_stage >= MIN_STORAGE_BUFFERS
                && limits.max_buffers_and_acceleration_structures_per_shader_stage >= MIN_BUFFERS
                && limits.max_compute_invocations_per_workgroup >= 64
        })
        .collect()
}

/// The features that time a substep's stages: timestamps written between
/// the commands of an encoder.
pub const TIMESTAMPS: wgpu::Features =
    wgpu::Features::TIMESTAMP_QUERY.union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS);

/// The most storage buffers one kernel binds (the binned APIC scatter; each
/// snow kernel binds only the buffers it uses, `snow/program.rs`).
pub const MIN_STORAGE_BUFFERS: u32 = 23;

/// The most buffers, storage and uniform together, one kernel binds (the
/// grid update of a scene with rigid bodies and wind: 22 storage and 4
/// uniform buffers; Metal offers 29 per shader stage, Vulkan, DX12 and GL
/// no limit of their own).
pub const MIN_BUFFERS: u32 = 26;

/// Every adapter wgpu finds that can run firn's kernels, best first.
pub fn adapters() -> Vec<AdapterReport> {
    enumerate().iter().map(AdapterReport::of).collect()
}

/// Orders adapters: discrete, integrated, virtual, then software; native
/// APIs before GL.
fn rank(report: &AdapterReport) -> (u8, u8) {
    let kind = match report.device_type.as_str() {
        "DiscreteGpu" => 0,
        "IntegratedGpu" => 1,
        "VirtualGpu" => 2,
        "Cpu" => 4,
        _ => 3,
    };
    (kind, u8::from(report.backend == "Gl"))
}

/// The adapter `policy` would choose, if any.
pub fn choose(policy: AdapterPolicy) -> Option<AdapterReport> {
    adapters()
        .into_iter()
        .find(|report| policy == AdapterPolicy::AllowSoftware || !report.is_software)
}

/// An open device and its queue, shared by the simulations that run on it.
pub struct GpuContext {
    /// The device the buffers and pipelines live on.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// What the device runs on.
    pub adapter: AdapterReport,
    /// The limits the device was opened with (the adapter's own).
    pub limits: wgpu::Limits,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.adapter)
            .finish()
    }
}

impl GpuContext {
    /// Opens a device on the best adapter `policy` allows, with that
    /// adapter's full limits (large scenes need more than WebGPU's defaults).
    pub fn new(policy: AdapterPolicy) -> Result<Arc<GpuContext>, GpuError> {
        GpuContext::new_nth(policy, 0)
    }

    /// Opens a device on the adapter `policy` allows at place `index` among
    /// them, counting round (`index` modulo their number, best first): one
    /// MPI rank's GPU among its node's, by its local rank, several ranks
    /// sharing one where there are more ranks than GPUs.
    pub fn new_nth(policy: AdapterPolicy, index: usize) -> Result<Arc<GpuContext>, GpuError> {
        let allowed: Vec<wgpu::Adapter> = enumerate()
            .into_iter()
            .filter(|adapter| {
                policy == AdapterPolicy::AllowSoftware || !AdapterReport::of(adapter).is_software
            })
            .collect();
        if allowed.is_empty() {
            return Err(GpuError::NoAdapter { policy });
        }
        GpuContext::open(&allowed[index % allowed.len()])
    }

    /// Opens a device on `adapter`, which may come from the caller's own
    /// `wgpu::Instance` (a viewer draws the simulation's buffers on the
    /// device that presents to its window; see [`rank_adapters`]), with the
    /// adapter's full limits, as [`GpuContext::new`] does.
    pub fn open(adapter: &wgpu::Adapter) -> Result<Arc<GpuContext>, GpuError> {
        GpuContext::open_with_limits(adapter, adapter.limits())
    }

    /// Opens a device on `adapter` with `limits`, at most the adapter's own:
    /// how the tests hold firn to adapters smaller than the one at hand.
    pub fn open_with_limits(
        adapter: &wgpu::Adapter,
        limits: wgpu::Limits,
    ) -> Result<Arc<GpuContext>, GpuError> {
        let descriptor = wgpu::DeviceDescriptor {
            label: Some("firn"),
            // Only to time the stages (`snow::stage_times`), where the
            // adapter has them.
            required_features: adapter.features() & TIMESTAMPS,
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&descriptor))
            .map_err(|error| GpuError::Device(error.to_string()))?;
        Ok(Arc::new(GpuContext {
            device,
            queue,
            adapter: AdapterReport::of(adapter),
            limits,
        }))
    }

    /// Blocks until every submitted command has finished.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|error| GpuError::Device(error.to_string()))
    }
}

/// The environment variable that makes GPU tests fail instead of skip when
/// no adapter is found (CI sets it; it has Mesa's lavapipe).
pub const REQUIRE_GPU_VARIABLE: &str = "FIRN_REQUIRE_GPU";

/// A device for tests, software adapters allowed. `None` (after printing how
/// to get a software adapter) when there is none, unless
/// `FIRN_REQUIRE_GPU=1`, which turns that into a panic.
pub fn context_for_tests() -> Option<Arc<GpuContext>> {
    context_for_tests_with_limits(|_| {})
}

/// [`context_for_tests`] with the adapter's limits changed by `adjust`
/// first (lowered, to stand in for a smaller adapter).
pub fn context_for_tests_with_limits(
    adjust: impl FnOnce(&mut wgpu::Limits),
) -> Option<Arc<GpuContext>> {
    let opened = enumerate()
        .into_iter()
        .next()
        .ok_or(GpuError::NoAdapter {
            policy: AdapterPolicy::AllowSoftware,
        })
        .and_then(|adapter| {
            let mut limits = adapter.limits();
            adjust(&mut limits);
            GpuContext::open_with_limits(&adapter, limits)
        });
    match opened {
        Ok(context) => Some(context),
        Err(error) => {
            let required = std::env::var(REQUIRE_GPU_VARIABLE).is_ok_and(|value| value == "1");
            assert!(
                !required,
                "{REQUIRE_GPU_VARIABLE}=1 but no GPU adapter was found: {error}"
            );
            eprintln!(
                "skipping a GPU test: {error}. Install Mesa's software Vulkan driver \
                 (Debian/Ubuntu: apt install mesa-vulkan-drivers libvulkan1) to run it, \
                 and set {REQUIRE_GPU_VARIABLE}=1 to make a missing adapter an error"
            );
            None
        }
    }
}
