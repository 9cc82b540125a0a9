//! Choosing the compute backend of a scene from its `[compute] backend`
//! and the adapters this machine has.
//!
//! `auto` takes a hardware GPU when one is present and runs the scene, and
//! the CPU otherwise; a software adapter (Mesa's lavapipe) is used only when
//! `gpu` is asked for, since the CPU backend is faster than it.

use std::sync::Arc;

use firn_core::Scene;
use firn_core::scene::{Backend, SceneKind};
use firn_gpu::{AdapterPolicy, AdapterReport, GpuContext, GpuError, GpuFlow, GpuSnow};

/// Where a simulation runs, once chosen.
#[derive(Clone, Debug)]
pub enum Placement {
    /// The CPU solver on rayon's pool.
    Cpu,
    /// The GPU backend on this device.
    Gpu(Arc<GpuContext>),
}

impl Placement {
    /// The backend's name for manifests and JSON records: "cpu" or "gpu".
    pub fn name(&self) -> &'static str {
        match self {
            Placement::Cpu => "cpu",
            Placement::Gpu(_) => "gpu",
        }
    }

    /// The GPU adapter's name, if on the GPU.
    pub fn adapter(&self) -> Option<String> {
        match self {
            Placement::Cpu => None,
            Placement::Gpu(context) => Some(context.adapter.name.clone()),
        }
    }

    /// A few words for a start line: "the CPU (2 threads)" or
    /// "the GPU (NAME, Vulkan)".
    pub fn describe(&self) -> String {
        match self {
            Placement::Cpu => format!("the CPU ({} threads)", rayon::current_num_threads()),
            Placement::Gpu(context) => format!(
                "the GPU ({}, {})",
                context.adapter.name, context.adapter.backend
            ),
        }
    }
}

/// The backend chosen for a scene, and the line `auto` says when it stays
/// on the CPU although a GPU is present.
pub struct Chosen {
    /// Where the simulation runs.
    pub placement: Placement,
    /// Why `auto` did not take the GPU it found, in one line.
    pub note: Option<String>,
}

/// `Ok` when the GPU backend runs `scene`; otherwise what it lacks.
pub fn gpu_supports(scene: &Scene) -> Result<(), GpuError> {
    match scene.kind {
        SceneKind::Snow => GpuSnow::check_supported(scene),
        SceneKind::Flow(_) => GpuFlow::check_supported(scene),
    }
}

/// Chooses where `scene` runs, by its `[compute] backend`. The error (a
/// scene the GPU cannot run, or no GPU to open, when `gpu` is asked for)
/// is the user's to act on.
pub fn choose_backend(scene: &Scene) -> Result<Chosen, GpuError> {
    let chosen = |placement, note| Chosen { placement, note };
    match scene.compute.backend {
        Backend::Cpu => Ok(chosen(Placement::Cpu, None)),
        Backend::Gpu => {
            gpu_supports(scene)?;
            let context = GpuContext::new(AdapterPolicy::AllowSoftware)?;
            Ok(chosen(Placement::Gpu(context), None))
        }
        Backend::Auto => Ok(choose_auto(scene)),
    }
}

/// `auto`'s rule, the one every front door (`firn run`, the viewer, Python,
/// MPI ranks) follows: a scene runs on `adapter` when it is a hardware GPU
/// and the GPU backend runs the scene. `Err` says why not, where there was
/// a hardware GPU to take (`None` when there was none).
pub fn auto_takes(scene: &Scene, adapter: Option<&AdapterReport>) -> Result<(), Option<String>> {
    if adapter.is_none_or(|adapter| adapter.is_software) {
        return Err(None);
    }
    gpu_supports(scene).map_err(|error| Some(first_line(&error)))
}

/// `auto`: the hardware GPU if there is one that runs the scene, else the CPU.
fn choose_auto(scene: &Scene) -> Chosen {
    let on_cpu = |why: Option<String>| Chosen {
        placement: Placement::Cpu,
        note: why.map(|why| format!("firn: --backend auto stays on the CPU: {why}")),
    };
    let hardware = firn_gpu::choose(AdapterPolicy::HardwareOnly);
    if let Err(why) = auto_takes(scene, hardware.as_ref()) {
        return on_cpu(why);
    }
    match GpuContext::new(AdapterPolicy::HardwareOnly) {
        Ok(context) => Chosen {
            placement: Placement::Gpu(context),
            note: None,
        },
        Err(error) => on_cpu(Some(first_line(&error))),
    }
}

/// The first line of a GPU error, without its fix (for `auto`'s note).
pub fn first_line(error: &GpuError) -> String {
    match error {
        GpuError::Unsupported { what, .. } => {
            format!("the GPU backend cannot run this scene: {what}")
        }
        other => other
            .to_string()
            .lines()
            .next()
            .unwrap_or_default()
            .to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unsupported_scene_is_named_in_one_line() {
        let error = GpuError::Unsupported {
            what: "the semi-implicit integrator".into(),
            fix: "use --backend cpu".into(),
        };
        assert_eq!(
            first_line(&error),
            "the GPU backend cannot run this scene: the semi-implicit integrator"
        );
    }
}
