//! `firn._firn`, the native half of firn's Python module: scenes, snow and
//! flow simulations on any backend, whole runs, and particles as numpy
//! arrays. Everything goes through the same library as the `firn` command
//! (firn-core's scene format, firn-run's `Solver`, `Recording` and
//! `RunDirectory`), so a run from Python writes the same bytes.
//!
//! - [`errors`]: `SceneError` and `SimulationError`;
//! - [`scene`]: `Scene`, loaded from a file or built from dicts;
//! - [`simulation`]: `Solver`, `Simulation` (snow) and `FlowSimulation`;
//! - [`arrays`]: particle arrays in and out of numpy;
//! - [`pictures`]: rendered frames as numpy images;
//! - [`runs`]: `run`, a whole run as `firn run` makes it.

use pyo3::prelude::*;

mod arrays;
mod errors;
mod pictures;
mod runs;
mod scene;
mod simulation;

/// The module's contents.
#[pymodule]
fn _firn(module: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = module.py();
    module.add("SceneError", py.get_type::<errors::SceneError>())?;
    module.add("SimulationError", py.get_type::<errors::SimulationError>())?;
    module.add_class::<scene::PyScene>()?;
    module.add_class::<simulation::Solver>()?;
    module.add_class::<simulation::Simulation>()?;
    module.add_class::<simulation::FlowSimulation>()?;
    module.add_function(wrap_pyfunction!(runs::run, module)?)?;
    module.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
