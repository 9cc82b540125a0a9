//! The image folders of `firn run` and `firn render`; the pictures
//! themselves are drawn by [`firn_run::pictures`].

use firn_core::Scene;
use firn_run::RunDirectory;

use crate::Failure;

/// Creates the image folders of the scene's styles.
pub fn prepare_image_dirs(scene: &Scene, run: &RunDirectory) -> Result<(), Failure> {
    run.create_image_folders(scene).map_err(|error| {
        Failure::BadInput(format!(
            "error: {error}\n  fix: choose a writable output directory with --out DIR"
        ))
    })
}
