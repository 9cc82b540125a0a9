//! firn-gpu: the GPU backend. The snow MPM substep (both transfer schemes,
//! the snow model with its 3x3 SVD, moving colliders, the adaptive Δt) and
//! the curl-noise flow run as WGSL compute shaders through wgpu, on any
//! vendor's GPU (Vulkan, Metal, DX12, GL) or on a software adapter.
//!
//! - [`context`]: finding an adapter (`--backend auto|gpu`) and opening a device;
//! - [`shaders`]: the WGSL programs, put together from `shaders/*.wgsl`;
//! - [`bindings`]: each bind group named once, in a table that gives both the
//!   WGSL declarations and the layout;
//! - [`snow`]: the MPM substep on the GPU, checked against `firn-mpm`;
//! - [`flow`]: the curl-noise flow on the GPU, checked against `firn-flow`;
//! - [`dispatch`]: splitting work over the adapter's workgroup limits.
//! - [`draw`]: the particle arrays as a renderer on the same device reads them.
//!
//! Particle and grid data stay on the GPU between substeps; the host reads
//! back a few words per batch of substeps and the particles once per frame.
//! The scatter adds into the grid with 64-bit fixed-point sums built from
//! 32-bit integer atomics ([`snow::fixed_point`]): no float atomics, and the
//! sums do not depend on the order the GPU runs the particles in.

pub mod bindings;
pub mod buffers;
pub mod context;
pub mod dispatch;
pub mod draw;
pub mod error;
pub mod flow;
pub mod shaders;
pub mod snow;

pub use context::{
    AdapterPolicy, AdapterReport, GpuContext, adapters, choose, context_for_tests,
    context_for_tests_with_limits, rank_adapters,
};
pub use error::GpuError;
pub use flow::GpuFlow;
pub use snow::GpuSnow;
