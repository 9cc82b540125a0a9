//! Pictures as numpy images: the styles and sizes `Solver.render` and
//! `Solver.project` take, checked as `firn run --size` checks them, and
//! the rendered pixels handed back as an (H, W, 3) array.

use firn_core::Scene;
use firn_core::scene::RenderStyle;
use firn_run::run_dir::style_name;
use numpy::{PyArray1, PyArray3, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Every render style, in the order their names are listed in errors.
const STYLES: [RenderStyle; 4] = [
    RenderStyle::Points,
    RenderStyle::Volume,
    RenderStyle::Billboards,
    RenderStyle::Trails,
];

/// Pixels a side a picture may have (as `firn run --size` allows).
const SIDE: std::ops::RangeInclusive<u32> = 16..=8192;

/// The style named `name` as in scene files, or the scene's first style.
pub fn style_or_default(scene: &Scene, name: Option<&str>) -> PyResult<RenderStyle> {
    let Some(name) = name else {
        return Ok(scene
            .render
            .styles
            .first()
            .copied()
            .unwrap_or(RenderStyle::Points));
    };
    STYLES
        .into_iter()
        .find(|&style| style_name(style) == name)
        .ok_or_else(|| {
            let names: Vec<&str> = STYLES.into_iter().map(style_name).collect();
            PyValueError::new_err(format!("style must be one of {names:?}, not {name:?}"))
        })
}

/// `width` x `height`, each defaulting to the scene's `[render] size`.
pub fn image_size(scene: &Scene, width: Option<u32>, height: Option<u32>) -> PyResult<[u32; 2]> {
    let [scene_width, scene_height] = scene.render.size;
    let size = [width.unwrap_or(scene_width), height.unwrap_or(scene_height)];
    if !size.iter().all(|side| SIDE.contains(side)) {
        return Err(PyValueError::new_err(format!(
            "width and height must be from {} to {} pixels, not {} x {}",
            SIDE.start(),
            SIDE.end(),
            size[0],
            size[1]
        )));
    }
    Ok(size)
}

/// Row-major RGB `pixels` of a `width` x `height` picture as an
/// (height, width, 3) uint8 array.
pub fn image_array(
    py: Python<'_>,
    pixels: Vec<u8>,
    [width, height]: [u32; 2],
) -> PyResult<Bound<'_, PyArray3<u8>>> {
    PyArray1::from_vec(py, pixels).reshape([height as usize, width as usize, 3])
}
