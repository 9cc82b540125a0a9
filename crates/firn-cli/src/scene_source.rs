//! Where a scene comes from: a file, or the bundled default.

use std::path::{Path, PathBuf};

use firn_core::Scene;

use crate::Failure;

/// The bundled default scene: a snowball thrown against a wall (thesis §6.3).
pub const DEFAULT_SCENE: &str = include_str!("../../../scenes/snowball-wall.toml");
/// Name shown for the bundled scene in messages.
pub const DEFAULT_SCENE_NAME: &str = "<bundled snowball-wall.toml>";

/// Loads `path`, or the bundled default scene when no path is given, and
/// prints what the inspection of its meshes found as warnings.
pub fn load_scene(path: Option<&Path>) -> Result<(Scene, Option<PathBuf>), Failure> {
    let loaded = read_scene(path)?;
    for warning in loaded.0.mesh_warnings() {
        errln!("warning: {warning}");
    }
    Ok(loaded)
}

fn read_scene(path: Option<&Path>) -> Result<(Scene, Option<PathBuf>), Failure> {
    match path {
        Some(path) => Scene::load(path)
            .map(|scene| (scene, Some(path.to_path_buf())))
            .map_err(|error| Failure::BadInput(error.to_string())),
        None => Scene::from_toml_str(DEFAULT_SCENE, DEFAULT_SCENE_NAME)
            .map(|scene| (scene, None))
            .map_err(|error| Failure::BadInput(error.to_string())),
    }
}
