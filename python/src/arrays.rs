//! Particle arrays between firn and numpy: out as fresh float32 arrays in
//! the solver's layout ((N, 3) vectors, (N, 3, 3) row-major matrices), in
//! from any array of numbers of the right shape (numpy converts it to
//! float64), refused unless every number is finite; points in space in from
//! (M, 3) arrays in double precision.

use glam::{DVec3, Mat3, Vec3};
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArray3, PyArrayLike2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// `vectors` as an (N, 3) array.
pub fn vectors_array<'py>(py: Python<'py>, vectors: &[Vec3]) -> Bound<'py, PyArray2<f32>> {
    let flat: Vec<f32> = vectors.iter().flat_map(|v| v.to_array()).collect();
    PyArray1::from_vec(py, flat)
        .reshape([vectors.len(), 3])
        .expect("3 numbers per vector")
}

/// `matrices` as an (N, 3, 3) array, row-major.
pub fn matrices_array<'py>(py: Python<'py>, matrices: &[Mat3]) -> Bound<'py, PyArray3<f32>> {
    let flat: Vec<f32> = matrices
        .iter()
        .flat_map(|m| m.transpose().to_cols_array())
        .collect();
    PyArray1::from_vec(py, flat)
        .reshape([matrices.len(), 3, 3])
        .expect("9 numbers per matrix")
}

/// `values` as an (N,) array.
pub fn scalars_array(py: Python<'_>, values: Vec<f32>) -> Bound<'_, PyArray1<f32>> {
    PyArray1::from_vec(py, values)
}

/// The vectors of an (N, 3) array of `count` particles, named `name` in
/// errors; every number must be finite.
pub fn positions_from_numpy(
    values: PyArrayLike2<'_, f64, AllowTypeChange>,
    count: usize,
    name: &str,
) -> PyResult<Vec<Vec3>> {
    let view = values.as_array();
    if view.shape() != [count, 3] {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape ({count}, 3), one row per particle, not {:?}",
            view.shape()
        )));
    }
    if let Some((index, _)) = view.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{name} must be finite: row {}, column {} is not",
            index / 3,
            index % 3
        )));
    }
    Ok(view
        .rows()
        .into_iter()
        .map(|row| Vec3::new(row[0] as f32, row[1] as f32, row[2] as f32))
        .collect())
}

/// The points of an (M, 3) array, in double precision.
pub fn points_from_numpy(points: &PyArrayLike2<'_, f64, AllowTypeChange>) -> PyResult<Vec<DVec3>> {
    let view = points.as_array();
    if view.ncols() != 3 {
        return Err(PyValueError::new_err(format!(
            "points must have shape (M, 3), not {:?}",
            view.shape()
        )));
    }
    Ok(view
        .rows()
        .into_iter()
        .map(|row| DVec3::new(row[0], row[1], row[2]))
        .collect())
}
