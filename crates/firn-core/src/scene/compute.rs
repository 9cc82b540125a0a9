//! Where a scene is computed: the `[compute]` table of a scene file.

use serde::{Deserialize, Serialize};

/// Which compute backend runs the simulation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Backend {
    /// A hardware GPU when one is present and runs the scene, else the CPU.
    #[default]
    Auto,
    /// The CPU solver, on every core.
    Cpu,
    /// The GPU backend, on a hardware GPU or else a software adapter; an
    /// error when there is neither or the scene needs what it lacks.
    Gpu,
}

impl Backend {
    /// The name the scene format and the command line use.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Auto => "auto",
            Backend::Cpu => "cpu",
            Backend::Gpu => "gpu",
        }
    }
}

/// The `[compute]` table: how the scene is computed. It never changes the
/// physics, so runs on either backend resume each other's checkpoints.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ComputeSettings {
    /// The backend asked for (`auto` by default).
    pub backend: Backend,
}
