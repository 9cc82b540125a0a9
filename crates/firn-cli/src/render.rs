//! `firn render`: re-render a finished (or interrupted) run from its PLY
//! caches, in other styles, from another camera or at another size, without
//! simulating again.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use firn_core::Scene;
use firn_core::scene::{ColorBy, Orbit, RenderStyle};
use firn_io::FrameRecord;
use firn_render::scene_view::FrameParticles;
use firn_run::RunDirectory;
use firn_run::run_dir::{CachedFrame, RecordedRun};
use glam::Vec3;

use crate::Failure;
use crate::pictures::prepare_image_dirs;
use crate::run::progress_bar;
use firn_run::pictures::{render_frame, write_animations};

/// Arguments of `firn render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Run directory written by `firn run` (holds manifest.json and ply/).
    pub run_dir: PathBuf,
    /// Styles to render, comma separated (default: the scene's).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub style: Option<Vec<StyleArg>>,
    /// Camera: `auto` (frame the domain), `X,Y,Z` (eye; looks at the scene's
    /// target) or `X,Y,Z@X,Y,Z` (eye and target).
    #[arg(long)]
    pub camera: Option<String>,
    /// Turntable: circle the target at this many degrees per simulated second.
    #[arg(long)]
    pub orbit: Option<f32>,
    /// Image size as WIDTHxHEIGHT, e.g. 1920x1080.
    #[arg(long)]
    pub size: Option<String>,
    /// Quantity on the colour ramp (default: the scene's).
    #[arg(long, value_enum)]
    pub color_by: Option<ColorByArg>,
    /// Draw a legend of the colour ramp.
    #[arg(long)]
    pub legend: bool,
    /// Print nothing but errors and the final line.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Render styles on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum StyleArg {
    /// Sphere-shaded sprites with the bluish ramp.
    Points,
    /// Ray-marched density with single scattering.
    Volume,
    /// Soft additive sprites (flow scenes).
    Billboards,
    /// Fading ribbons through recent positions (flow scenes).
    Trails,
    /// The snow's reconstructed surface, shaded like the colliders.
    Surface,
}

/// Colour quantities on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ColorByArg {
    /// Density (needs the `density` attribute in the caches).
    Density,
    /// Plastic J (needs `plastic-j`).
    PlasticJ,
    /// Speed (needs `velocity`).
    Speed,
    /// Position in the domain.
    Position,
    /// One colour.
    Uniform,
}

impl ColorByArg {
    /// The scene model's colour quantity.
    pub fn color_by(self) -> ColorBy {
        match self {
            ColorByArg::Density => ColorBy::Density,
            ColorByArg::PlasticJ => ColorBy::PlasticJ,
            ColorByArg::Speed => ColorBy::Speed,
            ColorByArg::Position => ColorBy::Position,
            ColorByArg::Uniform => ColorBy::Uniform,
        }
    }
}

/// Renders every frame of the run in `args.run_dir`.
pub fn render(args: RenderArgs) -> Result<(), Failure> {
    let run = RunDirectory::new(args.run_dir.clone());
    let bad_input =
        |error: firn_run::error::ReadRunError| Failure::BadInput(format!("error: {error}"));
    let RecordedRun {
        mut manifest,
        mut scene,
    } = run.read().map_err(bad_input)?;
    apply_overrides(&mut scene, &args)?;
    prepare_image_dirs(&scene, &run)?;
    let progress = progress_bar(manifest.frames.len() as u32, 0, args.quiet);
    let mut rendered = Vec::with_capacity(manifest.frames.len());
    for record in &manifest.frames {
        let cached = run.read_frame(record).map_err(bad_input)?;
        let images = render_cached_frame(&scene, &run, record, &cached)?;
        rendered.push(images);
        progress.inc(1);
    }
    progress.finish_and_clear();
    let frames: Vec<u32> = manifest.frames.iter().map(|record| record.index).collect();
    let animations = write_animations(&scene, run.path(), &frames, args.quiet)
        .map_err(|error| Failure::Failed(format!("error: {error}")))?;
    for (record, images) in manifest.frames.iter_mut().zip(rendered) {
        record.images = images;
    }
    manifest.animations = animations;
    manifest
        .write(&run.manifest_path())
        .map_err(|error| Failure::Failed(format!("error: {error}")))?;
    outln!(
        "firn: rendered {} frames in {} style(s); pictures in {}",
        frames.len(),
        scene.render.styles.len(),
        run.path().join("images").display()
    );
    Ok(())
}

/// Applies the command-line overrides to the scene's camera and render settings.
fn apply_overrides(scene: &mut Scene, args: &RenderArgs) -> Result<(), Failure> {
    scene.render.enabled = true;
    if let Some(styles) = &args.style {
        scene.render.styles = styles.iter().map(|&style| render_style(style)).collect();
        scene.render.styles.dedup();
    }
    if let Some(camera) = &args.camera {
        set_camera(scene, camera)?;
    }
    if let Some(degrees_per_second) = args.orbit {
        scene.camera.orbit = Some(Orbit { degrees_per_second });
    }
    if let Some(size) = &args.size {
        scene.render.size = parse_size(size)?;
    }
    if let Some(color_by) = args.color_by {
        scene.render.color_by = color_by.color_by();
    }
    scene.render.legend |= args.legend;
    Ok(())
}

fn render_style(style: StyleArg) -> RenderStyle {
    match style {
        StyleArg::Points => RenderStyle::Points,
        StyleArg::Volume => RenderStyle::Volume,
        StyleArg::Billboards => RenderStyle::Billboards,
        StyleArg::Trails => RenderStyle::Trails,
        StyleArg::Surface => RenderStyle::Surface,
    }
}

/// Parses `--camera`.
fn set_camera(scene: &mut Scene, text: &str) -> Result<(), Failure> {
    let camera = &mut scene.camera;
    camera.path.clear();
    if text.trim() == "auto" {
        camera.position = None;
        camera.look_at = None;
        return Ok(());
    }
    let bad = || {
        Failure::BadInput(format!(
            "error: --camera {text:?} is not a camera\n  fix: pass auto, X,Y,Z (eye) or X,Y,Z@X,Y,Z (eye@target), e.g. --camera 2.5,1.2,3.0@1.0,0.3,1.0"
        ))
    };
    let mut parts = text.split('@');
    let eye = parts.next().and_then(parse_vec3).ok_or_else(bad)?;
    let target = match parts.next() {
        Some(part) => Some(parse_vec3(part).ok_or_else(bad)?),
        None => None,
    };
    if parts.next().is_some() {
        return Err(bad());
    }
    camera.position = Some(eye);
    if target.is_some() {
        camera.look_at = target;
    }
    Ok(())
}

fn parse_vec3(text: &str) -> Option<Vec3> {
    let values: Vec<f32> = text
        .split(',')
        .map(|part| part.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .ok()?;
    let vector = <[f32; 3]>::try_from(values).ok().map(Vec3::from_array)?;
    vector.is_finite().then_some(vector)
}

/// Parses `--size WIDTHxHEIGHT` (shared by `firn run` and `firn render`).
pub(crate) fn parse_size(text: &str) -> Result<[u32; 2], Failure> {
    let parsed = text
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some([w.trim().parse().ok()?, h.trim().parse().ok()?]));
    match parsed {
        Some([width, height]) if (16..=8192).contains(&width) && (16..=8192).contains(&height) => {
            Ok([width, height])
        }
        _ => Err(Failure::BadInput(format!(
            "error: --size {text:?} is not an image size between 16 and 8192 pixels a side\n  fix: pass WIDTHxHEIGHT, e.g. --size 1920x1080"
        ))),
    }
}

/// Renders one frame from its cache; returns the written image paths.
fn render_cached_frame(
    scene: &Scene,
    run: &RunDirectory,
    record: &FrameRecord,
    cached: &CachedFrame,
) -> Result<Vec<String>, Failure> {
    let positions = cached.positions().ok_or_else(|| {
        Failure::BadInput(format!(
            "error: {} has no x, y, z columns\n  fix: re-run the scene to rewrite its caches",
            cached.path().display()
        ))
    })?;
    let values = cached.color_values(scene.render.color_by).map_err(|column| {
        Failure::BadInput(format!(
            "error: {} has no `{column}` column to colour by\n  fix: pass --color-by with a cached quantity, or add it to [output] attributes and run again",
            cached.path().display()
        ))
    })?;
    let drift = run
        .read_drift(record)
        .map_err(|error| Failure::Failed(format!("error: {error}")))?;
    let frame = FrameParticles {
        positions: &positions,
        masses: cached.masses(),
        values: values.as_deref(),
        trails: None,
        surface: None,
        drift: drift.as_deref(),
        rigid_bodies: &record.rigid_bodies,
    };
    render_frame(scene, run.path(), record.index, record.time, frame)
        .map_err(|error| Failure::Failed(format!("error: {error}")))
}

#[cfg(test)]
mod tests {
    use super::parse_size;

    #[test]
    fn sizes_are_width_by_height_within_limits() {
        assert!(matches!(parse_size("64x48"), Ok([64, 48])));
        assert!(matches!(parse_size("1920X1080"), Ok([1920, 1080])));
        assert!(parse_size("wide").is_err());
        assert!(parse_size("8x8").is_err());
    }
}
