//! Playing back a finished (or interrupted) run from its PLY caches, read
//! as `firn render` reads them (`firn_run::RunDirectory`): the scene from
//! the run's manifest, one cloud per recorded frame, loaded when the
//! timeline reaches it.

use std::path::Path;

use firn_core::Scene;
use firn_core::scene::ColorBy;
use firn_io::{BodyPose, FrameRecord};
use firn_run::RunDirectory;
use firn_run::run_dir::RecordedRun;
use glam::Vec3;

use crate::draw::ParticleSource;

/// A run directory opened for playback.
pub struct Playback {
    run: RunDirectory,
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
    drift: Option<Vec<Vec3>>,
}

impl Playback {
    /// Opens the run in `directory`: its manifest, scene and frame list.
    pub fn open(directory: &Path) -> Result<Playback, String> {
        let run = RunDirectory::new(directory);
        let RecordedRun { manifest, scene } = run.read().map_err(|error| error.to_string())?;
        if manifest.frames.is_empty() {
            return Err(format!(
                "{}: the run has no frames yet\n  fix: let `firn run` write at least one frame (firn run --resume continues it)",
                run.manifest_path().display()
            ));
        }
        Ok(Playback {
            run,
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
        let cached = self
            .run
            .read_frame(&self.frames[index])
            .map_err(|error| error.to_string())?;
        let positions = cached
            .positions()
            .ok_or_else(|| format!("{} has no x, y, z columns", cached.path().display()))?;
        let values = cached.color_values(color_by).map_err(|column| {
            format!(
                "{} has no `{column}` column to colour by\n  fix: colour by another quantity, or add it to [output] attributes and run again",
                cached.path().display()
            )
        })?;
        let drift = self
            .run
            .read_drift(&self.frames[index])
            .map_err(|error| error.to_string())?;
        self.loaded = Some(LoadedFrame {
            index,
            color_by,
            positions,
            values,
            drift,
        });
        Ok(())
    }

    /// Particles in the loaded frame.
    pub fn particle_count(&self) -> usize {
        self.loaded
            .as_ref()
            .map_or(0, |frame| frame.positions.len())
    }

    /// Where the rigid bodies are in the loaded frame (none before one is
    /// loaded, or without bodies).
    pub fn rigid_bodies(&self) -> &[BodyPose] {
        self.loaded
            .as_ref()
            .map_or(&[], |frame| &self.frames[frame.index].rigid_bodies)
    }

    /// The loaded frame's drift particles (`[wind.spindrift]`), if it has
    /// any.
    pub fn drift(&self) -> Option<&[Vec3]> {
        self.loaded.as_ref()?.drift.as_deref()
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
