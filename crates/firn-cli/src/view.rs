//! `firn view`: the interactive viewer on a scene (simulated live) or on a
//! run directory (played back from its caches).

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use firn_core::scene::Backend;
use firn_run::RunDirectory;
use firn_view::draw::DrawStyle;
use firn_view::{ViewError, ViewInput, ViewOptions};

use crate::Failure;
use crate::backend::backend_values;
use crate::render::{ColorByArg, parse_size};
use crate::scene_source::load_scene;

/// Arguments of `firn view`.
#[derive(Args, Debug)]
pub struct ViewArgs {
    /// A scene file to simulate live, or a run directory (holding
    /// manifest.json) to play back; the bundled default scene if omitted.
    pub input: Option<PathBuf>,
    /// Where a live scene is simulated (default: the scene's [compute]
    /// backend, else auto: the window's GPU if it is a hardware GPU that runs
    /// the scene, else the CPU).
    #[arg(long, value_parser = backend_values())]
    pub backend: Option<Backend>,
    /// Window size as WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720")]
    pub size: String,
    /// Close after this many displayed frames.
    #[arg(long)]
    pub frames: Option<u32>,
    /// Write the last displayed frame to this PNG (with --frames).
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
    /// Write every displayed frame as a PNG into this directory.
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// Count each display frame as 1/FPS seconds instead of the measured
    /// time, and run all the physics each frame owes however long it takes:
    /// the same frames every time, and recordings at a steady rate.
    #[arg(long)]
    pub display_fps: Option<f64>,
    /// Follow the scene's camera (its path, orbit or fixed eye) from the start.
    #[arg(long)]
    pub scene_camera: bool,
    /// Simulated seconds per wall-clock second.
    #[arg(long, default_value_t = 1.0)]
    pub time_scale: f64,
    /// Start paused.
    #[arg(long)]
    pub paused: bool,
    /// How particles are drawn at the start (default: the scene's first style).
    #[arg(long, value_enum)]
    pub style: Option<ViewStyleArg>,
    /// What colours particles at the start (default: the scene's).
    #[arg(long, value_enum)]
    pub color_by: Option<ColorByArg>,
}

/// Render modes of the viewer on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ViewStyleArg {
    /// Sphere-shaded points on the colour ramp.
    Points,
    /// Soft additive sprites.
    Billboards,
    /// Fading lines through recent positions (flows that keep trails).
    Trails,
}

/// Opens the viewer; prints what it did when it closes.
pub fn view(args: ViewArgs) -> Result<(), Failure> {
    let options = options(args)?;
    let report = firn_view::run(options).map_err(|error| match error {
        ViewError::Failed(_) => Failure::Failed(format!("error: {error}")),
        _ => Failure::BadInput(format!("error: {error}")),
    })?;
    outln!(
        "firn view: {} frames in {:.1} s ({:.1} FPS) on {}; {} substeps ({:.0}/s) on the {}; simulated {:.3} s{}",
        report.frames,
        report.seconds,
        report.fps(),
        report.adapter,
        report.substeps,
        report.substeps_per_second(),
        if report.on_gpu { "GPU" } else { "CPU" },
        report.simulated,
        if report.dropped > 0.0 {
            format!(
                " ({:.3} s dropped: the simulation could not keep up with the time scale)",
                report.dropped
            )
        } else {
            String::new()
        }
    );
    Ok(())
}

/// Checks the arguments and loads the input.
fn options(args: ViewArgs) -> Result<ViewOptions, Failure> {
    let size = parse_size(&args.size)?;
    if let Some(fps) = args
        .display_fps
        .filter(|fps| !(fps.is_finite() && *fps > 0.0))
    {
        return Err(Failure::BadInput(format!(
            "error: --display-fps {fps} is not a frame rate\n  fix: pass a positive number, e.g. --display-fps 60"
        )));
    }
    if !(args.time_scale.is_finite() && args.time_scale > 0.0) {
        return Err(Failure::BadInput(format!(
            "error: --time-scale {} is not a speed\n  fix: pass a positive number, e.g. --time-scale 0.25 for slow motion",
            args.time_scale
        )));
    }
    if args.screenshot.is_some() && args.frames.is_none() {
        return Err(Failure::BadInput(
            "error: --screenshot needs --frames N (the screenshot is of the last frame)\n  fix: add --frames, or press P in the window for a screenshot".into(),
        ));
    }
    if let Some(directory) = &args.record {
        firn_io::ensure_writable_dir(directory)
            .map_err(|error| Failure::BadInput(format!("error: --record: {error}")))?;
    }
    let (input, scene_backend) = match &args.input {
        Some(path) if RunDirectory::holds_run(path) => {
            (ViewInput::RunDirectory(path.clone()), Backend::Auto)
        }
        path => {
            let (scene, _) = load_scene(path.as_deref())?;
            let backend = scene.compute.backend;
            (ViewInput::Scene(Box::new(scene)), backend)
        }
    };
    let backend = args.backend.unwrap_or(scene_backend);
    Ok(ViewOptions {
        input: Some(input),
        backend,
        size,
        frames: args.frames,
        screenshot: args.screenshot,
        record: args.record,
        display_fps: args.display_fps,
        scene_camera: args.scene_camera,
        time_scale: args.time_scale,
        paused: args.paused,
        style: args.style.map(|style| match style {
            ViewStyleArg::Points => DrawStyle::Points,
            ViewStyleArg::Billboards => DrawStyle::Billboards,
            ViewStyleArg::Trails => DrawStyle::Trails,
        }),
        color_by: args.color_by.map(ColorByArg::color_by),
    })
}
