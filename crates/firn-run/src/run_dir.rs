//! [`RunDirectory`]: the folder a run writes and every front door reads
//! back (`firn render`, the viewer's playback):
//!
//! ```text
//! manifest.json             the scene, the backend, a record per frame
//! checkpoint.firnckpt       the state after the last checkpointed frame
//! ply/frame_00001.ply       caches, one per frame and format
//! vtk/frame_00001.vtp
//! particles.pvd             the VTK frames by time (ParaView)
//! vtk/frame_00001_part_0002.vtp          a split run's frames, one piece per rank
//! checkpoint-pieces.json                 a split run's checkpoint: its pieces
//! checkpoint/frame_00004_rank_0002.firnckpt
//! images/points/frame_00001.png, images/points.gif, images/points.mp4
//! ```

use std::path::{Path, PathBuf};

use firn_core::Scene;
use firn_core::scene::{CacheFormat, ColorBy, RenderStyle};
use firn_io::{FrameRecord, MANIFEST_FILE, Manifest, PlyCloud, ensure_writable_dir, read_ply};
use glam::Vec3;

use crate::error::ReadRunError;

/// File name of the checkpoint inside a run directory.
pub const CHECKPOINT_FILE: &str = "checkpoint.firnckpt";

/// File name of the manifest of a split run's checkpoint pieces.
pub const PIECE_MANIFEST_FILE: &str = "checkpoint-pieces.json";

/// File name of the ParaView collection of VTK frames.
const COLLECTION_FILE: &str = "particles.pvd";

/// A run's folder.
#[derive(Clone, Debug)]
pub struct RunDirectory {
    path: PathBuf,
}

/// A run read back: its manifest and the scene it ran.
pub struct RecordedRun {
    /// The manifest, with a record per frame written.
    pub manifest: Manifest,
    /// The scene from the manifest, its meshes loaded again.
    pub scene: Scene,
}

/// A frame's PLY cache read back.
pub struct CachedFrame {
    path: PathBuf,
    cloud: PlyCloud,
}

impl RunDirectory {
    /// The run directory at `path` (nothing is read or written yet).
    pub fn new(path: impl Into<PathBuf>) -> RunDirectory {
        RunDirectory { path: path.into() }
    }

    /// Whether `path` holds a run (a folder with a manifest).
    pub fn holds_run(path: &Path) -> bool {
        path.is_dir() && path.join(MANIFEST_FILE).is_file()
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The run's manifest.
    pub fn manifest_path(&self) -> PathBuf {
        self.path.join(MANIFEST_FILE)
    }

    /// The run's checkpoint.
    pub fn checkpoint_path(&self) -> PathBuf {
        self.path.join(CHECKPOINT_FILE)
    }

    /// The manifest of a split run's checkpoint pieces (one per rank).
    pub fn piece_manifest_path(&self) -> PathBuf {
        self.path.join(PIECE_MANIFEST_FILE)
    }

    /// Path of rank `rank`'s checkpoint piece after frame `frame`,
    /// relative to the folder.
    pub fn checkpoint_piece_name(frame: u32, rank: usize) -> String {
        format!("checkpoint/frame_{frame:05}_rank_{rank:04}.firnckpt")
    }

    /// Path of part `part` of frame `index`'s VTK cache (a run split
    /// between MPI ranks writes one part per rank), relative to the folder.
    pub fn vtk_piece_name(index: u32, part: usize) -> String {
        format!(
            "{}/frame_{index:05}_part_{part:04}.vtp",
            cache_folder(CacheFormat::Vtk)
        )
    }

    /// The ParaView collection of the VTK frames.
    pub fn collection_path(&self) -> PathBuf {
        self.path.join(COLLECTION_FILE)
    }

    /// Creates the folder and the cache folders of the scene's formats,
    /// and checks that they can be written.
    pub fn create(&self, scene: &Scene) -> Result<(), firn_io::IoError> {
        ensure_writable_dir(&self.path)?;
        for &format in &scene.output.formats {
            ensure_writable_dir(&self.path.join(cache_folder(format)))?;
        }
        Ok(())
    }

    /// Creates the image folders of the scene's render styles.
    pub fn create_image_folders(&self, scene: &Scene) -> Result<(), firn_io::IoError> {
        for &style in &scene.render.styles {
            ensure_writable_dir(&self.path.join(image_folder(style)))?;
        }
        Ok(())
    }

    /// Path of frame `index`'s cache in `format`, relative to the folder.
    pub fn cache_name(format: CacheFormat, index: u32) -> String {
        let extension = match format {
            CacheFormat::Ply => "ply",
            CacheFormat::Vtk => "vtp",
            CacheFormat::Vdb => "vdb",
            CacheFormat::Mesh => "ply",
            CacheFormat::Usd => return firn_io::usd::clip_name(index),
        };
        format!("{}/frame_{index:05}.{extension}", cache_folder(format))
    }

    /// Path of frame `index`'s surface mesh as OBJ (the `mesh` format also
    /// writes [`RunDirectory::cache_name`], the PLY), relative to the folder.
    pub fn mesh_obj_name(index: u32) -> String {
        format!("{}/frame_{index:05}.obj", cache_folder(CacheFormat::Mesh))
    }

    /// Path of frame `index`'s rigid bodies as one OBJ mesh (written with
    /// the `mesh` format where the scene has bodies), relative to the
    /// folder.
    pub fn bodies_obj_name(index: u32) -> String {
        format!("{}/bodies_{index:05}.obj", cache_folder(CacheFormat::Mesh))
    }

    /// Path of frame `index`'s drift particles (`[wind.spindrift]`) in
    /// `format` (`ply` or `vtk`), relative to the folder:
    /// `drift/frame_NNNNN.ply` or `.vtp`.
    pub fn drift_cache_name(format: CacheFormat, index: u32) -> String {
        let extension = match format {
            CacheFormat::Vtk => "vtp",
            _ => "ply",
        };
        format!("drift/frame_{index:05}.{extension}")
    }

    /// Path of frame `index`'s picture in `style`, relative to the folder.
    pub fn image_name(style: RenderStyle, index: u32) -> String {
        format!("{}/frame_{index:05}.png", image_folder(style))
    }

    /// The pictures of `style` as a printf pattern of the frame index
    /// (ffmpeg's input), relative to the folder.
    pub fn image_pattern(style: RenderStyle) -> String {
        format!("{}/frame_%05d.png", image_folder(style))
    }

    /// Path of the animation of `style` in the container `extension`
    /// ("gif", "mp4"), relative to the folder.
    pub fn animation_name(style: RenderStyle, extension: &str) -> String {
        format!("images/{}.{extension}", style_name(style))
    }

    /// Reads the manifest and the scene it records, its meshes loaded again.
    pub fn read(&self) -> Result<RecordedRun, ReadRunError> {
        let manifest_path = self.manifest_path();
        let manifest =
            Manifest::read(&manifest_path).map_err(|source| ReadRunError::Manifest { source })?;
        let mut scene: Scene =
            serde_json::from_value(manifest.scene.clone()).map_err(|source| {
                ReadRunError::Scene {
                    path: manifest_path.clone(),
                    source,
                }
            })?;
        scene.load_meshes().map_err(|error| ReadRunError::Mesh {
            path: manifest_path.clone(),
            reason: error.to_string(),
        })?;
        scene
            .validate()
            .map_err(|error| ReadRunError::InvalidScene {
                path: manifest_path,
                source: Box::new(error),
            })?;
        Ok(RecordedRun { manifest, scene })
    }

    /// Reads the drift particles' positions (`[wind.spindrift]`) of the
    /// frame `record` describes from its PLY cache; `None` where the frame
    /// has none.
    pub fn read_drift(&self, record: &FrameRecord) -> Result<Option<Vec<Vec3>>, ReadRunError> {
        let Some(name) = record
            .files
            .iter()
            .find(|file| file.starts_with("drift/") && file.ends_with(".ply"))
        else {
            return Ok(None);
        };
        let cloud = read_ply(&self.path.join(name))
            .map_err(|source| ReadRunError::FrameCache { source })?;
        Ok(cloud.positions())
    }

    /// Reads the PLY cache of the frame `record` describes.
    pub fn read_frame(&self, record: &FrameRecord) -> Result<CachedFrame, ReadRunError> {
        let name = record
            .files
            .iter()
            .find(|file| file.ends_with(".ply") && !file.starts_with("drift/"))
            .ok_or_else(|| ReadRunError::NoPlyCache {
                index: record.index,
                directory: self.path.clone(),
            })?;
        let path = self.path.join(name);
        let cloud = read_ply(&path).map_err(|source| ReadRunError::FrameCache { source })?;
        Ok(CachedFrame { path, cloud })
    }
}

impl CachedFrame {
    /// The cache file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Positions, if the cache has x, y and z columns.
    pub fn positions(&self) -> Option<Vec<Vec3>> {
        self.cloud.positions()
    }

    /// Masses, if cached.
    pub fn masses(&self) -> Option<&[f32]> {
        self.cloud.floats("mass")
    }

    /// Values of `color_by` from the cached columns (none for colourings
    /// that need no values); `Err(column)` names the missing column.
    pub fn color_values(&self, color_by: ColorBy) -> Result<Option<Vec<f32>>, &'static str> {
        let cloud = &self.cloud;
        let column = |name: &'static str| cloud.floats(name).map(<[f32]>::to_vec).ok_or(name);
        match color_by {
            ColorBy::Density => column("density").map(Some),
            ColorBy::PlasticJ => column("plastic_j").map(Some),
            ColorBy::Speed => cloud
                .vector("velocity")
                .map(|velocity| Some(velocity.iter().map(|v| v.length()).collect()))
                .ok_or("velocity"),
            ColorBy::Position | ColorBy::Uniform => Ok(None),
        }
    }
}

/// The style's name as written in scene files, which names its folder.
pub fn style_name(style: RenderStyle) -> &'static str {
    match style {
        RenderStyle::Points => "points",
        RenderStyle::Volume => "volume",
        RenderStyle::Billboards => "billboards",
        RenderStyle::Trails => "trails",
        RenderStyle::Surface => "surface",
    }
}

/// Folder of a cache format's frames.
fn cache_folder(format: CacheFormat) -> &'static str {
    match format {
        CacheFormat::Ply => "ply",
        CacheFormat::Vtk => "vtk",
        CacheFormat::Vdb => "vdb",
        CacheFormat::Mesh => "mesh",
        CacheFormat::Usd => firn_io::usd::CLIP_FOLDER,
    }
}

/// Folder of a style's pictures.
fn image_folder(style: RenderStyle) -> String {
    format!("images/{}", style_name(style))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_the_layout() {
        assert_eq!(
            RunDirectory::cache_name(CacheFormat::Ply, 7),
            "ply/frame_00007.ply"
        );
        assert_eq!(
            RunDirectory::cache_name(CacheFormat::Vtk, 12),
            "vtk/frame_00012.vtp"
        );
        assert_eq!(
            RunDirectory::cache_name(CacheFormat::Vdb, 4),
            "vdb/frame_00004.vdb"
        );
        assert_eq!(
            RunDirectory::cache_name(CacheFormat::Mesh, 4),
            "mesh/frame_00004.ply"
        );
        assert_eq!(RunDirectory::mesh_obj_name(4), "mesh/frame_00004.obj");
        assert_eq!(
            RunDirectory::cache_name(CacheFormat::Usd, 7),
            "usd/frame.00007.usda"
        );
        assert_eq!(
            RunDirectory::image_name(RenderStyle::Volume, 3),
            "images/volume/frame_00003.png"
        );
        assert_eq!(
            RunDirectory::image_pattern(RenderStyle::Trails),
            "images/trails/frame_%05d.png"
        );
        assert_eq!(
            RunDirectory::animation_name(RenderStyle::Points, "gif"),
            "images/points.gif"
        );
    }
}
