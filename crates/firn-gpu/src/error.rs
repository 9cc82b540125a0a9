//! Why the GPU backend could not start or continue.

use crate::context::AdapterPolicy;

/// A failure of the GPU backend, phrased for the user with a fix.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter that `policy` allows was found.
    #[error("{}", no_adapter_message(*policy))]
    NoAdapter {
        /// What was asked for.
        policy: AdapterPolicy,
    },
    /// The device could not be opened or was lost.
    #[error("the GPU device failed: {0}")]
    Device(String),
    /// The scene uses something the GPU backend does not run.
    #[error("the GPU backend cannot run this scene: {what}\n  fix: {fix}")]
    Unsupported {
        /// What the scene uses.
        what: String,
        /// What to change.
        fix: String,
    },
    /// A buffer would exceed what the adapter allows.
    #[error(
        "the scene does not fit the GPU: {what} needs {needed} bytes, but the adapter \
         ({adapter}) allows {limit} bytes per storage buffer\n  fix: {fix}"
    )]
    TooLarge {
        /// Which buffer.
        what: String,
        /// Bytes it needs.
        needed: u64,
        /// Bytes the adapter allows.
        limit: u64,
        /// The adapter's name.
        adapter: String,
        /// What to change.
        fix: String,
    },
    /// A software adapter's buffers, which live in host memory, would pass
    /// what the machine allows beside the host's copy of the state.
    #[error(
        "the scene does not fit the GPU: its buffers need {needed} and the host {host} (its \
         copy of the state and the cache writers), but the software adapter ({adapter}) keeps its buffers in this \
         machine's memory, which allows {available} ({limited_by})\n  fix: {fix}"
    )]
    HostMemory {
        /// The GPU buffers.
        needed: firn_core::scene::Bytes,
        /// The host's copy of the state and the cache writers.
        host: firn_core::scene::Bytes,
        /// What the machine allows.
        available: firn_core::scene::Bytes,
        /// Where that figure comes from ("physical memory", ...).
        limited_by: &'static str,
        /// The adapter's name.
        adapter: String,
        /// What to change.
        fix: String,
    },
    /// The snow simulation blew up; the message says why and what to change.
    #[error("{0}")]
    Snow(#[from] firn_mpm::SimulationError),
    /// A fixed-point grid sum left its 64-bit range.
    #[error(
        "at t = {time:.4} s a grid sum overflowed the 64-bit fixed-point range of the GPU \
         scatter ({quantity}); the state is no longer meaningful\n  fix: this happens only \
         when snow moves faster than about {speed_limit:.0} m/s or is compressed far beyond \
         its density; lower the speeds or cfl in [time], or run with --backend cpu"
    )]
    Overflow {
        /// Simulated time of the failed substep.
        time: f64,
        /// The grid quantity that overflowed.
        quantity: &'static str,
        /// The speed at which momentum sums overflow, m/s.
        speed_limit: f64,
    },
    /// The flow could not start: the scene or a snapshot was rejected, as
    /// `firn_flow::FlowSimulation` rejects it.
    #[error("{0}")]
    Flow(#[from] firn_flow::FlowError),
}

fn no_adapter_message(policy: AdapterPolicy) -> String {
    match policy {
        AdapterPolicy::HardwareOnly => "no hardware GPU adapter was found".into(),
        AdapterPolicy::AllowSoftware => "no GPU adapter was found, not even a software one; \
             install Mesa's software Vulkan driver (Debian/Ubuntu: apt install \
             mesa-vulkan-drivers libvulkan1) or use --backend cpu"
            .into(),
    }
}
