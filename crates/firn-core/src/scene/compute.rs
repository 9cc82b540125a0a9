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
    /// Every backend, in the order the command line lists them.
    pub const ALL: [Backend; 3] = [Backend::Auto, Backend::Cpu, Backend::Gpu];

    /// The name the scene format, the command line and Python use.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Auto => "auto",
            Backend::Cpu => "cpu",
            Backend::Gpu => "gpu",
        }
    }

    /// What the backend does, in a line (for `--help`).
    pub fn summary(self) -> &'static str {
        match self {
            Backend::Auto => "a hardware GPU when there is one and it runs the scene, else the CPU",
            Backend::Cpu => "the CPU solver, on every core",
            Backend::Gpu => "the GPU backend, a software adapter if there is no hardware GPU",
        }
    }
}

impl std::str::FromStr for Backend {
    type Err = String;

    /// The backend named `name` ("auto", "cpu" or "gpu").
    fn from_str(name: &str) -> Result<Backend, String> {
        Backend::ALL
            .into_iter()
            .find(|backend| backend.name() == name)
            .ok_or_else(|| format!("backend must be \"auto\", \"cpu\" or \"gpu\", not {name:?}"))
    }
}

/// The `[compute]` table: how the scene is computed. It never changes the
/// physics, so runs on either backend resume each other's checkpoints.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ComputeSettings {
    /// The backend asked for (`auto` by default).
    pub backend: Backend,
}
