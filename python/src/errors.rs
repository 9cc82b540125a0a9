//! The module's exceptions: a scene that is not valid (`SceneError`, a
//! `ValueError` carrying the file, line, column, key and fix of the command
//! line's message) and a simulation that cannot go on (`SimulationError`).

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

create_exception!(
    firn,
    SceneError,
    PyValueError,
    "A scene that is not valid: the message names the file, line and key, what is wrong and how to fix it (attributes file, line, column, key, hint)."
);
create_exception!(
    firn,
    SimulationError,
    PyRuntimeError,
    "A simulation that cannot start or go on (no GPU, a blow-up, an unwritable run directory)."
);

/// `error` as a Python `SceneError` with its parts as attributes.
pub fn scene_error(py: Python<'_>, error: &firn_core::scene::SceneError) -> PyErr {
    let raised = SceneError::new_err(error.to_string());
    let value = raised.value(py);
    let _ = value.setattr("file", &error.file);
    let _ = value.setattr("line", error.line);
    let _ = value.setattr("column", error.column);
    let _ = value.setattr("key", &error.key);
    let _ = value.setattr("hint", &error.hint);
    raised
}

/// Anything a simulation reports, as a Python `SimulationError`.
pub fn simulation_error(error: impl std::fmt::Display) -> PyErr {
    SimulationError::new_err(error.to_string())
}
