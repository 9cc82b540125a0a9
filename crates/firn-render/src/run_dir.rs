//! Reading a run directory written by `firn run`: its manifest, the scene it
//! ran, and a frame's PLY cache. `firn render` and the viewer's playback
//! both read runs this way.

use std::path::Path;

use firn_core::Scene;
use firn_io::{FrameRecord, MANIFEST_FILE, Manifest, PlyCloud, read_ply};

/// The manifest in `directory` and the scene it records, its meshes loaded
/// again; the error says what is wrong and how to fix it.
pub fn open_run(directory: &Path) -> Result<(Manifest, Scene), String> {
    let manifest_path = directory.join(MANIFEST_FILE);
    let manifest = Manifest::read(&manifest_path).map_err(|error| {
        format!("{error}\n  fix: pass the directory of a run made by `firn run` (it holds {MANIFEST_FILE})")
    })?;
    let mut scene: Scene = serde_json::from_value(manifest.scene.clone()).map_err(|error| {
        format!(
            "{}: the scene in the manifest cannot be read: {error}\n  fix: re-run the scene with this version of firn",
            manifest_path.display()
        )
    })?;
    scene.load_meshes().map_err(|error| {
        format!(
            "{}: a mesh of the scene cannot be loaded again: {error}",
            manifest_path.display()
        )
    })?;
    Ok((manifest, scene))
}

/// The PLY cache named in a frame's record.
pub fn frame_cache_name(record: &FrameRecord) -> Option<&str> {
    record
        .files
        .iter()
        .find(|file| file.ends_with(".ply"))
        .map(String::as_str)
}

/// Reads the PLY cache of a frame, naming the file in any error.
pub fn read_frame_cache(directory: &Path, record: &FrameRecord) -> Result<PlyCloud, String> {
    let name = frame_cache_name(record).ok_or_else(|| {
        format!(
            "frame {} has no PLY cache in {}\n  fix: add \"ply\" to [output] formats and run the scene again",
            record.index,
            directory.display()
        )
    })?;
    read_ply(&directory.join(name)).map_err(|error| {
        format!(
            "{error}\n  fix: re-run the scene (firn run --resume continues an interrupted run), or remove the damaged frame's record"
        )
    })
}
