//! Playing back a finished (or interrupted) run from its PLY caches, read
//! as `firn render` reads them (`firn_render::run_dir`): the scene from the run's manifest, one cloud
//! per recorded frame, loaded when the timeline reaches it.

use std::path::{Path, PathBuf};

use firn_core::Scene;
use firn_core::scene::ColorBy;
use firn_io::{FrameRecord, MANIFEST_FILE};
use firn_render::run_dir::{frame_cache_name, open_run, read_frame_cache};
use firn_render::scene_view::cached_color_values;
use glam::Vec3;

use crate::draw::ParticleSource;

/// A run directory opened for playback.
pub struct Playback {
    directory: PathBuf,
    scene: Scene,
    frames: Vec<FrameRecord>,
    /// The frame loaded last, and its particles.
    loaded: Option<LoadedFrame>,
}

/// One cached frame's particles.
struct LoadedFrame {
    index: usize,
    color_by: ColorBy,
    positions: Vec<Vec3>,
    values: Option<Vec<f32>>,
}

impl Playback {
    /// Whether `path` is a run directory (it holds a manifest).
    pub fn is_run_directory(path: &Path) -> bool {
        path.is_dir() && path.join(MANIFEST_FILE).is_file()
    }

    /// Opens the run in `directory`: its manifest, scene and frame list.
    pub fn open(directory: &Path) -> Result<Playback, String> {
        let (manifest, scene) = open_run(directory)?;
        if manifest.frames.is_empty() {
            return Err(format!(
                "{}: the run has no frames yet\n  fix: let `firn run` write at least one frame (firn run --resume continues it)",
                directory.join(MANIFEST_FILE).display()
            ));
        }
        Ok(Playback {
            directory: directory.to_path_buf(),
            scene,
            frames: manifest.frames,
            loaded: None,
        })
    }

    /// The scene the run simulated.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Recorded frames.
    pub fn frame_count(&self) -> usize {
        self.frames.len()
    }

    /// Simulated time of recorded frame `index`.
    pub fn frame_time(&self, index: usize) -> f64 {
        self.frames[index].time
    }

    /// The last recorded frame at or before simulated time `t` (the first
    /// frame before it).
    pub fn frame_at(&self, t: f64) -> usize {
        self.frames
            .partition_point(|record| record.time <= t + 1e-9)
            .saturating_sub(1)
    }

    /// Loads frame `index` coloured by `color_by` (unless it is loaded).
    pub fn load(&mut self, index: usize, color_by: ColorBy) -> Result<(), String> {
        let current = self.loaded.as_ref();
        if current.is_some_and(|frame| frame.index == index && frame.color_by == color_by) {
            return Ok(());
        }
        let record = &self.frames[index];
        let cloud = read_frame_cache(&self.directory, record)?;
        let path = || {
            self.directory
                .join(frame_cache_name(record).unwrap_or_default())
        };
        let positions = cloud
            .positions()
            .ok_or_else(|| format!("{} has no x, y, z columns", path().display()))?;
        let values = cached_color_values(&cloud, color_by).map_err(|column| {
            format!(
                "{} has no `{column}` column to colour by\n  fix: colour by another quantity, or add it to [output] attributes and run again",
                path().display()
            )
        })?;
        self.loaded = Some(LoadedFrame {
            index,
            color_by,
            positions,
            values,
        });
        Ok(())
    }

    /// Particles in the loaded frame.
    pub fn particle_count(&self) -> usize {
        self.loaded
            .as_ref()
            .map_or(0, |frame| frame.positions.len())
    }

    /// The loaded frame's particles for the renderer.
    pub fn source(&self) -> Option<ParticleSource<'_>> {
        self.loaded.as_ref().map(|frame| ParticleSource::Host {
            positions: &frame.positions,
            values: frame.values.as_deref(),
            trails: None,
        })
    }
}
