//! `firn.run`: a whole run as `firn run` makes it (caches, manifest,
//! checkpoints, pictures and animations, resumable), through firn-run's
//! `Recording` and `RunDirectory`.

use std::ops::ControlFlow;
use std::path::PathBuf;

use firn_core::Scene;
use firn_run::pictures::{frame_pictures, write_animations};
use firn_run::recording::{FrameToPicture, Observer, Progress};
use firn_run::{Recording, RunDirectory, choose_backend};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::simulation_error;
use crate::scene::PyScene;
use crate::simulation::backend_named;

/// Runs `scene` to its last frame (or `frames`), writing what `firn run`
/// writes into `out` (default: the scene's `[output] directory`); `render`
/// off writes caches only. `resume` continues from the run's checkpoint.
/// `progress` is called after each frame with a dict (frame, last_frame,
/// time, substeps_per_second, eta_seconds). Returns the run directory.
/// An exception from `progress`, or Ctrl-C (KeyboardInterrupt), stops the
/// run after the frame being simulated and is raised: the run directory
/// then ends at that frame with a checkpoint of it, and `resume=True`
/// continues it to the same bytes as a run never stopped.
#[pyfunction]
#[pyo3(signature = (scene, out = None, frames = None, render = true, resume = false, backend = None, progress = None))]
#[allow(clippy::too_many_arguments)]
pub fn run(
    py: Python<'_>,
    scene: &PyScene,
    out: Option<PathBuf>,
    frames: Option<u32>,
    render: bool,
    resume: bool,
    backend: Option<&str>,
    progress: Option<Py<PyAny>>,
) -> PyResult<PathBuf> {
    let mut scene: Scene = scene.scene.clone();
    if let Some(out) = out {
        scene.output.directory = out;
    }
    scene.render.enabled &= render;
    if let Some(backend) = backend {
        scene.compute.backend = backend_named(backend)?;
    }
    let placement = choose_backend(&scene).map_err(simulation_error)?.placement;
    let directory = RunDirectory::new(scene.output.directory.clone());
    directory.create(&scene).map_err(simulation_error)?;
    if scene.render.enabled {
        directory
            .create_image_folders(&scene)
            .map_err(simulation_error)?;
    }
    let last_frame = scene.time.frame_count().min(frames.unwrap_or(u32::MAX));
    let path = directory.path().to_path_buf();
    let mut observer = Pictures {
        directory: path.clone(),
        progress,
        failure: None,
    };
    let mut recording = if resume {
        Recording::resume(scene, directory, &placement).map_err(simulation_error)?
    } else {
        let solver = firn_run::Solver::new(scene, &placement).map_err(simulation_error)?;
        Recording::start(solver, directory, None, &mut observer).map_err(simulation_error)?
    };
    let outcome = py.detach(|| recording.run_to(last_frame, &mut observer));
    if let Some(failure) = observer.failure.take() {
        return Err(failure);
    }
    outcome.map_err(simulation_error)?;
    Ok(path)
}

/// Pictures like `firn run`'s, and progress to a Python callback.
struct Pictures {
    directory: PathBuf,
    progress: Option<Py<PyAny>>,
    /// The callback's exception (or Ctrl-C), which stopped the run and is
    /// raised once it returns.
    failure: Option<PyErr>,
}

impl Observer for Pictures {
    fn pictures(&mut self, frame: &FrameToPicture<'_>) -> Result<Vec<String>, String> {
        frame_pictures(frame, &self.directory)
    }

    fn frame_recorded(&mut self, progress: &Progress) -> ControlFlow<()> {
        Python::attach(|py| {
            let outcome = py.check_signals().and_then(|()| {
                let Some(callback) = &self.progress else {
                    return Ok(());
                };
                let info = PyDict::new(py);
                info.set_item("frame", progress.frame)?;
                info.set_item("last_frame", progress.last_frame)?;
                info.set_item("time", progress.time)?;
                info.set_item("substeps_per_second", progress.substeps_per_second())?;
                info.set_item("eta_seconds", progress.seconds_left())?;
                callback.call1(py, (info,)).map(|_| ())
            });
            self.failure = outcome.err();
        });
        match self.failure {
            Some(_) => ControlFlow::Break(()),
            None => ControlFlow::Continue(()),
        }
    }

    fn animations(&mut self, scene: &Scene, frames: &[u32]) -> Result<Vec<String>, String> {
        write_animations(scene, &self.directory, frames, true)
    }
}
