//! Pictures of a run, shared by every front door (`firn run` after each
//! frame, `firn render` from the caches, the Python module): a PNG per frame
//! and style under `images/STYLE/`, and per style an animated GIF and, when
//! ffmpeg is on PATH, an MP4 of the whole run.

use std::io::Write;
use std::path::{Path, PathBuf};

use firn_core::Scene;
use firn_core::scene::RenderStyle;
use firn_mesh::TriangleMesh;
use firn_render::output::{find_ffmpeg, write_gif, write_mp4, write_png};
use firn_render::scene_view::{FrameParticles, particle_spacing, scene_picture, uniform_mass};
use firn_render::trails::Trails;

use crate::RunDirectory;
use crate::recording::FrameToPicture;
use crate::simulation::HostParticles;
use crate::surface::scene_surface;

/// The renderer's view of a simulation's particles.
pub fn frame_particles<'a>(particles: &'a HostParticles<'a>) -> FrameParticles<'a> {
    FrameParticles {
        positions: particles.positions,
        masses: particles.masses,
        values: particles.values.as_deref(),
        trails: particles.trails.as_ref().map(|rings| Trails {
            points: &rings.points,
            capacity: rings.capacity,
            lengths: &rings.lengths,
        }),
        surface: None,
        drift: particles.drift,
        rigid_bodies: &particles.rigid_bodies,
    }
}

/// Renders frame `index` at `time` in every style of the scene and writes the
/// PNGs; returns their paths relative to `directory`. The `surface` style
/// draws `particles.surface`, or the surface reconstructed from the
/// particles as the `mesh` format would.
pub fn render_frame(
    scene: &Scene,
    directory: &Path,
    index: u32,
    time: f64,
    particles: FrameParticles<'_>,
) -> Result<Vec<String>, String> {
    let reconstructed = (particles.surface.is_none()
        && scene.render.styles.contains(&RenderStyle::Surface))
    .then(|| particles_surface(scene, &particles));
    let particles = FrameParticles {
        surface: particles.surface.or(reconstructed.as_ref()),
        ..particles
    };
    let mut written = Vec::new();
    for &style in &scene.render.styles {
        let picture = scene_picture(scene, time, style, particles, None);
        let image = firn_render::render(&picture);
        let name = RunDirectory::image_name(style, index);
        write_png(&directory.join(&name), &image).map_err(|error| error.to_string())?;
        written.push(name);
    }
    Ok(written)
}

/// The snow's surface from `particles` (uniform masses where they carry
/// none), with the scene's `[output.mesh]` settings.
fn particles_surface(scene: &Scene, particles: &FrameParticles<'_>) -> TriangleMesh {
    match particles.masses {
        Some(masses) => scene_surface(scene, particles.positions, masses),
        None => {
            let mass = uniform_mass(scene, particle_spacing(scene));
            let masses = vec![mass; particles.positions.len()];
            scene_surface(scene, particles.positions, &masses)
        }
    }
}

/// Writes each style's animation over `frames` (frame indices in order, all
/// rendered); returns the written paths relative to `directory`. Says
/// plainly on stderr when ffmpeg is missing and only GIFs are written.
pub fn write_animations(
    scene: &Scene,
    directory: &Path,
    frames: &[u32],
    quiet: bool,
) -> Result<Vec<String>, String> {
    let (Some(&first), false) = (frames.first(), scene.render.styles.is_empty()) else {
        return Ok(Vec::new());
    };
    let ffmpeg = find_ffmpeg();
    let mut written = Vec::new();
    for &style in &scene.render.styles {
        let images: Vec<PathBuf> = frames
            .iter()
            .map(|&index| directory.join(RunDirectory::image_name(style, index)))
            .collect();
        let gif = RunDirectory::animation_name(style, "gif");
        write_gif(&directory.join(&gif), &images, scene.time.fps)
            .map_err(|error| error.to_string())?;
        written.push(gif);
        if let Some(ffmpeg) = &ffmpeg {
            let mp4 = RunDirectory::animation_name(style, "mp4");
            let pattern = directory.join(RunDirectory::image_pattern(style));
            write_mp4(
                ffmpeg,
                &pattern,
                first,
                scene.time.fps,
                &directory.join(&mp4),
            )
            .map_err(|error| error.to_string())?;
            written.push(mp4);
        }
    }
    if ffmpeg.is_none() && !quiet {
        // A closed standard error (`2>&1 | head`) loses the note, not the run.
        let _ = writeln!(
            std::io::stderr(),
            "note: ffmpeg is not on PATH, so no MP4 was written (the GIF preview was); \
             install ffmpeg to get MP4 videos"
        );
    }
    Ok(written)
}

/// The pictures of a frame a [`crate::Recording`] hands its observer, in
/// every style of its scene, under `directory`; returns their paths
/// relative to it.
pub fn frame_pictures(frame: &FrameToPicture<'_>, directory: &Path) -> Result<Vec<String>, String> {
    let particles = FrameParticles {
        surface: frame.surface,
        ..frame_particles(&frame.particles)
    };
    render_frame(frame.scene, directory, frame.index, frame.time, particles)
}
