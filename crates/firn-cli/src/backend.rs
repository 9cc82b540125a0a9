//! `--backend` and the command line's view of choosing a backend: the
//! choice itself (`firn_run::backend`) with its errors as exit code 2.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use firn_core::Scene;
use firn_core::scene::Backend;
use firn_gpu::GpuError;
use firn_run::Chosen;

use crate::Failure;

/// `--backend`'s values: the scene format's backend names, each with its
/// summary in `--help`.
pub fn backend_values() -> impl TypedValueParser<Value = Backend> {
    let values =
        Backend::ALL.map(|backend| PossibleValue::new(backend.name()).help(backend.summary()));
    PossibleValuesParser::new(values).map(|name| name.parse().unwrap_or_default())
}

/// Chooses where `scene` runs, by its `[compute] backend` (which
/// `--backend` overrides); a scene the GPU cannot run, or no GPU to open,
/// when `gpu` is asked for is the user's to fix.
pub fn choose_backend(scene: &Scene) -> Result<Chosen, Failure> {
    firn_run::choose_backend(scene).map_err(|error| gpu_failure(&error))
}

/// A GPU error that the user must act on (exit code 2), with a fix.
pub fn gpu_failure(error: &GpuError) -> Failure {
    let message = error.to_string();
    if message.contains("\n  fix: ") {
        Failure::BadInput(format!("error: {message}"))
    } else {
        Failure::BadInput(format!(
            "error: {message}\n  fix: run on the CPU with --backend cpu"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unsupported_scene_keeps_its_fix() {
        let error = GpuError::Unsupported {
            what: "the semi-implicit integrator".into(),
            fix: "use --backend cpu".into(),
        };
        let Failure::BadInput(message) = gpu_failure(&error) else {
            panic!("an unsupported scene is bad input");
        };
        assert_eq!(
            message,
            "error: the GPU backend cannot run this scene: the semi-implicit integrator\n  fix: use --backend cpu"
        );
    }

    #[test]
    fn errors_without_a_fix_get_one() {
        let Failure::BadInput(message) = gpu_failure(&GpuError::Device("lost".into())) else {
            panic!("a device error is reported as bad input");
        };
        assert!(
            message.ends_with("fix: run on the CPU with --backend cpu"),
            "{message}"
        );
    }
}
