//! firn-view: the interactive viewer (`firn view`). A window (winit + wgpu)
//! runs a scene live on the CPU or the GPU, or plays back a finished run
//! from its caches, with an orbit camera, a parameter panel (egui) and the
//! physics in a fixed-timestep loop (thesis §5.2, Quellcode 6).
//!
//! - [`clock`]: the fixed-timestep accumulator;
//! - [`session`]: what is shown and how it moves on, without a window;
//! - [`playback`]: a run's caches along a timeline (a scene simulated live
//!   is a `firn_run::Solver`);
//! - [`panel`]: the egui panel, which only returns [`session::Action`]s;
//! - [`camera`] and [`input`]: orbit, pan, zoom, frame-all, the scene camera;
//! - [`draw`]: the wgpu drawing, straight from GPU simulation buffers;
//! - [`graphics`] and `app`: the window, its device and its loop.

mod app;
pub mod camera;
pub mod clock;
pub mod draw;
pub mod error;
pub mod graphics;
pub mod input;
pub mod panel;
pub mod playback;
pub mod session;

use std::path::PathBuf;

use firn_core::Scene;
use firn_core::scene::Backend;
use winit::event_loop::{ControlFlow, EventLoop};

pub use error::ViewError;

/// What the viewer shows.
#[derive(Debug)]
pub enum ViewInput {
    /// A scene, simulated live.
    Scene(Box<Scene>),
    /// A run directory written by `firn run`, played back from its caches.
    RunDirectory(PathBuf),
}

/// How the viewer opens and when it closes.
#[derive(Debug)]
pub struct ViewOptions {
    /// What to show (taken when the window opens).
    pub input: Option<ViewInput>,
    /// Where a live scene is simulated: `auto` takes the window's device
    /// when it is a hardware GPU that runs the scene, `gpu` takes it even
    /// when it is a software one.
    pub backend: Backend,
    /// Window size in pixels.
    pub size: [u32; 2],
    /// Close after this many displayed frames (automation).
    pub frames: Option<u32>,
    /// Write the last displayed frame here as a PNG.
    pub screenshot: Option<PathBuf>,
    /// Write every displayed frame into this directory as PNGs.
    pub record: Option<PathBuf>,
    /// Count every display frame as 1/fps wall-clock seconds instead of
    /// measuring them, and run every physics tick owed however long it
    /// takes: reproducible automation, and recordings at a steady rate.
    pub display_fps: Option<f64>,
    /// Start following the scene's camera.
    pub scene_camera: bool,
    /// Simulated seconds per wall-clock second at the start.
    pub time_scale: f64,
    /// Start paused.
    pub paused: bool,
    /// How particles are drawn at the start (default: the scene's first style).
    pub style: Option<draw::DrawStyle>,
    /// What colours particles at the start (default: the scene's `color_by`).
    pub color_by: Option<firn_core::scene::ColorBy>,
}

/// What a viewing session did, for the closing line.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewReport {
    /// Frames displayed.
    pub frames: u32,
    /// Wall-clock seconds the window was open.
    pub seconds: f64,
    /// Solver substeps run.
    pub substeps: u64,
    /// Simulated time reached.
    pub simulated: f64,
    /// The adapter that drew.
    pub adapter: String,
    /// Whether the simulation ran on that adapter.
    pub on_gpu: bool,
    /// Simulated seconds dropped because the physics could not keep up.
    pub dropped: f64,
}

impl ViewReport {
    /// Display frames per wall-clock second.
    pub fn fps(&self) -> f64 {
        f64::from(self.frames) / self.seconds.max(1e-9)
    }

    /// Solver substeps per wall-clock second.
    pub fn substeps_per_second(&self) -> f64 {
        self.substeps as f64 / self.seconds.max(1e-9)
    }
}

/// Opens the window and runs until it is closed (or `options.frames` are shown).
pub fn run(options: ViewOptions) -> Result<ViewReport, ViewError> {
    let event_loop = EventLoop::new().map_err(|error| ViewError::NoDisplay {
        reason: error.to_string(),
    })?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = app::App::new(options);
    event_loop
        .run_app(&mut app)
        .map_err(|error| ViewError::Failed(error.to_string()))?;
    app.finish()
}
