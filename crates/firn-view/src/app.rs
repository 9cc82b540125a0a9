//! The window and its loop (winit): each display frame the session runs the
//! physics ticks owed, the panel is laid out, and the scene and the panel
//! are drawn; screenshots and recordings read the same picture back.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use firn_core::scene::Backend;
use firn_gpu::GpuContext;
use firn_render::scene_view::{ramp_range, scene_stage, sprite_radius, stage_bodies};
use firn_render::stage::Stage;
use firn_render::trails::Trails;
use firn_run::backend::{auto_takes, gpu_supports};
use firn_run::simulation::HostParticles;
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::ActiveEventLoop;
use winit::window::{Window, WindowId};

use crate::camera::OrbitCamera;
use crate::draw::{DrawFrame, ParticleSource, SceneRenderer, capture};
use crate::error::ViewError;
use crate::graphics::Graphics;
use crate::input::{Input, KeyCommand};
use crate::panel::{self, PanelOutput, ViewToggles};
use crate::playback::Playback;
use crate::session::{Action, Content, Session};
use crate::{ViewInput, ViewOptions, ViewReport};

/// The viewer between window events.
pub struct App {
    options: ViewOptions,
    /// What to show, until the window opens.
    input: Option<ViewInput>,
    running: Option<Running>,
    /// Set when the loop must end with an error.
    error: Option<ViewError>,
    report: Option<ViewReport>,
}

/// Everything that exists while the window is open.
struct Running {
    window: Arc<Window>,
    graphics: Graphics,
    renderer: SceneRenderer,
    egui: EguiLayer,
    session: Session,
    camera: OrbitCamera,
    toggles: ViewToggles,
    /// Window pixels on the left covered by the panel.
    covered: u32,
    input: Input,
    started: Instant,
    last_frame: Instant,
    frames: u32,
    substeps: u64,
    screenshots: u32,
    /// The last note for the user (a written screenshot).
    note: Option<String>,
}

/// egui's context, its winit input state and its wgpu renderer.
struct EguiLayer {
    context: egui::Context,
    state: egui_winit::State,
    renderer: egui_wgpu::Renderer,
}

/// A laid-out panel, ready to draw.
struct PanelFrame {
    jobs: Vec<egui::ClippedPrimitive>,
    screen: egui_wgpu::ScreenDescriptor,
    textures: egui::TexturesDelta,
}

impl App {
    /// A viewer that will open a window showing `options.input`.
    pub fn new(mut options: ViewOptions) -> App {
        let input = options.input.take();
        App {
            options,
            input,
            running: None,
            error: None,
            report: None,
        }
    }

    /// The outcome once the loop has ended.
    pub fn finish(self) -> Result<ViewReport, ViewError> {
        match (self.error, self.report) {
            (Some(error), _) => Err(error),
            (None, Some(report)) => Ok(report),
            (None, None) => Err(ViewError::Failed(
                "the viewer closed before it opened".into(),
            )),
        }
    }

    /// Opens the window, the device and the session.
    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<Running, ViewError> {
        let [width, height] = self.options.size;
        let attributes = Window::default_attributes()
            .with_title("firn view")
            .with_inner_size(winit::dpi::PhysicalSize::new(width, height));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|error| {
            ViewError::NoDisplay {
                reason: error.to_string(),
            }
        })?);
        let graphics = Graphics::new(Arc::clone(&window))?;
        let input = self
            .input
            .take()
            .ok_or_else(|| ViewError::Failed("nothing to show".into()))?;
        let session = start_session(input, self.options.backend, &graphics.context)?;
        let renderer = SceneRenderer::new(
            &graphics.context.device,
            graphics.config.format,
            session.scene(),
        );
        let egui = EguiLayer::new(&window, &graphics);
        let size = window.inner_size();
        let covered = (panel::PANEL_WIDTH * window.scale_factor() as f32).ceil() as u32;
        let visible = size.width.saturating_sub(covered).max(1);
        let aspect = visible as f32 / size.height.max(1) as f32;
        let camera = OrbitCamera::of_scene(session.scene(), 0.0, aspect);
        let mut session = session;
        session.apply(Action::SetTimeScale(self.options.time_scale));
        if self.options.paused {
            session.apply(Action::Pause);
        }
        if self.options.display_fps.is_some() {
            session.run_every_tick_owed();
        }
        if let Some(style) = self.options.style {
            session.apply(Action::SetStyle(style));
        }
        if let Some(color_by) = self.options.color_by {
            session.apply(Action::SetColorBy(color_by));
        }
        let now = Instant::now();
        Ok(Running {
            window,
            graphics,
            renderer,
            egui,
            session,
            camera,
            toggles: ViewToggles {
                scene_camera: self.options.scene_camera,
                ..ViewToggles::default()
            },
            covered,
            input: Input::default(),
            started: now,
            last_frame: now,
            frames: 0,
            substeps: 0,
            screenshots: 0,
            note: None,
        })
    }

    /// Ends the loop with `error`.
    fn stop_with(&mut self, event_loop: &ActiveEventLoop, error: ViewError) {
        self.error = Some(error);
        event_loop.exit();
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match self.open(event_loop) {
            Ok(running) => {
                running.window.request_redraw();
                self.running = Some(running);
            }
            Err(error) => self.stop_with(event_loop, error),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(running) = self.running.as_mut() else {
            return;
        };
        let consumed = running
            .egui
            .state
            .on_window_event(&running.window, &event)
            .consumed;
        match event {
            WindowEvent::CloseRequested => {
                self.report = Some(running.report());
                event_loop.exit();
            }
            WindowEvent::Resized(size) => running.graphics.resize(size.width, size.height),
            WindowEvent::RedrawRequested => match running.frame(&self.options) {
                Ok(true) => {
                    self.report = Some(running.report());
                    event_loop.exit();
                }
                Ok(false) => running.window.request_redraw(),
                Err(error) => self.stop_with(event_loop, error),
            },
            other if !consumed => {
                let wants_pointer = running.egui.context.egui_wants_pointer_input();
                let height = running.graphics.config.height as f32;
                if let Some(command) =
                    running
                        .input
                        .handle(&other, &mut running.camera, height, wants_pointer)
                {
                    running.command(command);
                }
            }
            _ => {}
        }
    }
}

impl Running {
    /// One display frame; true when the viewer should close (after
    /// `--frames`).
    fn frame(&mut self, options: &ViewOptions) -> Result<bool, ViewError> {
        let now = Instant::now();
        let real = options
            .display_fps
            .map_or((now - self.last_frame).as_secs_f64(), |fps| 1.0 / fps);
        self.last_frame = now;
        self.substeps += self.session.advance_frame(real);
        self.input.hold_keys(&mut self.camera, real as f32);
        let panel = self.lay_out_panel();
        self.follow_camera();
        self.frames += 1;
        let last = options.frames.is_some_and(|frames| self.frames >= frames);
        let capture_to = self.capture_paths(options, last);
        self.draw(panel, &capture_to)?;
        Ok(last)
    }

    /// Runs the panel for this frame and carries out what it asks for.
    fn lay_out_panel(&mut self) -> PanelFrame {
        let egui = &mut self.egui;
        let raw = egui.state.take_egui_input(&self.window);
        let mut panel = PanelOutput::default();
        let session = &self.session;
        let toggles = &mut self.toggles;
        let note = self.note.as_deref();
        let output = egui.context.run_ui(raw, |ui| {
            panel = panel::show(ui, session, toggles, note);
        });
        egui.state
            .handle_platform_output(&self.window, output.platform_output);
        self.covered = (panel.width * output.pixels_per_point).ceil() as u32;
        for action in panel.actions {
            self.session.apply(action);
        }
        let size = self.window.inner_size();
        PanelFrame {
            jobs: egui
                .context
                .tessellate(output.shapes, output.pixels_per_point),
            screen: egui_wgpu::ScreenDescriptor {
                size_in_pixels: [size.width, size.height],
                pixels_per_point: output.pixels_per_point,
            },
            textures: output.textures_delta,
        }
    }

    /// Applies the camera toggles: frame-all, or following the scene's camera.
    fn follow_camera(&mut self) {
        let aspect = self.aspect();
        let scene = self.session.scene();
        if std::mem::take(&mut self.toggles.frame_all) {
            self.toggles.scene_camera = false;
            self.camera
                .frame_all(scene.domain.min, scene.domain.max, aspect);
        }
        if self.toggles.scene_camera {
            self.camera = OrbitCamera::of_scene(scene, self.session.time(), aspect);
        }
    }

    /// Width over height of the part of the window beside the panel.
    fn aspect(&self) -> f32 {
        let config = &self.graphics.config;
        let visible = config.width.saturating_sub(self.covered).max(1);
        visible as f32 / config.height.max(1) as f32
    }

    /// Where this frame's picture is written: the recording's next frame,
    /// the `--screenshot` after the last frame, and a screenshot asked for
    /// with P or the panel (any of them, or none).
    fn capture_paths(&mut self, options: &ViewOptions, last: bool) -> Vec<PathBuf> {
        let mut paths = Vec::new();
        if let Some(directory) = &options.record {
            paths.push(directory.join(format!("frame-{:05}.png", self.frames - 1)));
        }
        if last && let Some(path) = &options.screenshot {
            paths.push(path.clone());
        }
        if std::mem::take(&mut self.toggles.screenshot) {
            self.screenshots += 1;
            paths.push(PathBuf::from(format!(
                "firn-screenshot-{:03}.png",
                self.screenshots
            )));
        }
        paths
    }

    /// Draws the scene and the panel into the window (and into each of
    /// `capture_to`).
    fn draw(&mut self, mut panel: PanelFrame, capture_to: &[PathBuf]) -> Result<(), ViewError> {
        let context = Arc::clone(&self.graphics.context);
        let (device, queue) = (&context.device, &context.queue);
        for (id, deltas) in panel.textures.set.drain() {
            for delta in deltas {
                self.egui.renderer.update_texture(device, queue, id, &delta);
            }
        }
        let drawn = self.graphics.next_texture().map(|surface_texture| {
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
            self.egui.renderer.update_buffers(
                device,
                queue,
                &mut encoder,
                &panel.jobs,
                &panel.screen,
            );
            let view = surface_texture.texture.create_view(&Default::default());
            self.draw_into(&mut encoder, &view, &panel);
            let target = (!capture_to.is_empty()).then(|| self.graphics.capture_target());
            if let Some(target) = &target {
                let view = target.create_view(&Default::default());
                self.draw_into(&mut encoder, &view, &panel);
            }
            queue.submit([encoder.finish()]);
            queue.present(surface_texture);
            target
        });
        for id in panel.textures.free.drain() {
            self.egui.renderer.free_texture(&id);
        }
        if let Some(Some(target)) = drawn {
            let image = capture(device, queue, &target);
            for path in capture_to {
                self.save(&image, path)?;
            }
        }
        Ok(())
    }

    /// Records the scene, then the panel over it, into `view`.
    fn draw_into(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        panel: &PanelFrame,
    ) {
        let context = &self.graphics.context;
        let scene = self.session.scene();
        let time = self.session.time();
        let color_by = self.session.color_by();
        let read_back = self.session.draws_read_back();
        let host: Option<HostParticles<'_>> = match self.session.content() {
            Content::Live(live) if !live.on_gpu() || read_back => live.host_particles(color_by),
            Content::Live(_) | Content::Playback(_) => None,
        };
        let particles = match (self.session.content(), &host) {
            (_, Some(host)) => host_source(host),
            (Content::Live(live), None) => live
                .device_particles()
                .map_or(EMPTY, ParticleSource::Device),
            (Content::Playback(playback), None) => playback.source().unwrap_or(EMPTY),
        };
        let drift = match (self.session.content(), &host) {
            (_, Some(host)) => host.drift,
            (Content::Playback(playback), None) => playback.drift(),
            (Content::Live(_), None) => None,
        };
        let device_bodies = match (self.session.content(), &host) {
            (Content::Live(live), None) => live.device_body_poses().unwrap_or_default(),
            _ => Vec::new(),
        };
        let bodies = match (self.session.content(), &host) {
            (_, Some(host)) => host.rigid_bodies.as_slice(),
            (Content::Playback(playback), None) => playback.rigid_bodies(),
            (Content::Live(_), None) => device_bodies.as_slice(),
        };
        let stage = Stage {
            bodies: stage_bodies(scene, bodies),
            ..scene_stage(scene, time)
        };
        let frame = DrawFrame {
            view: self.camera.view_setup(
                [self.graphics.config.width, self.graphics.config.height],
                self.covered,
            ),
            style: self.session.style(),
            color_by,
            range: ramp_range(scene, color_by),
            particles,
            stage: &stage,
            point_radius: sprite_radius(scene),
            drift,
        };
        self.renderer
            .draw(&context.device, &context.queue, encoder, view, &frame);
        let mut pass = encoder
            .begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("panel"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            })
            .forget_lifetime();
        self.egui
            .renderer
            .render(&mut pass, &panel.jobs, &panel.screen);
    }

    /// Writes a captured picture as a PNG, atomically.
    fn save(&mut self, image: &image::RgbaImage, path: &Path) -> Result<(), ViewError> {
        let rgb = image::DynamicImage::ImageRgba8(image.clone()).to_rgb8();
        firn_render::output::write_png(path, &rgb).map_err(|error| {
            ViewError::Failed(format!("cannot write {}: {error}", path.display()))
        })?;
        self.note = Some(format!("wrote {}", path.display()));
        Ok(())
    }

    /// Carries out a key command.
    fn command(&mut self, command: KeyCommand) {
        match command {
            KeyCommand::Session(action) => self.session.apply(action),
            KeyCommand::TogglePlay => {
                let action = if self.session.is_playing() {
                    Action::Pause
                } else {
                    Action::Play
                };
                self.session.apply(action);
            }
            KeyCommand::FrameAll => self.toggles.frame_all = true,
            KeyCommand::ToggleSceneCamera => self.toggles.scene_camera ^= true,
            KeyCommand::Screenshot => self.toggles.screenshot = true,
            KeyCommand::ManualCamera => self.toggles.scene_camera = false,
            KeyCommand::Throw => self.session.apply(Action::Throw {
                eye: self.camera.eye(),
                target: self.camera.target,
            }),
        }
    }

    /// What the viewer did, for the closing line.
    fn report(&self) -> ViewReport {
        let seconds = self.started.elapsed().as_secs_f64();
        ViewReport {
            frames: self.frames,
            seconds,
            substeps: self.substeps,
            simulated: self.session.time(),
            adapter: self.graphics.adapter().name.clone(),
            on_gpu: self.session.on_gpu(),
            dropped: self.session.clock().dropped(),
        }
    }
}

/// No particles (a run whose frame could not be read).
const EMPTY: ParticleSource<'static> = ParticleSource::Host {
    positions: &[],
    values: None,
    trails: None,
};

impl EguiLayer {
    fn new(window: &Window, graphics: &Graphics) -> EguiLayer {
        let context = egui::Context::default();
        let state = egui_winit::State::new(
            context.clone(),
            egui::ViewportId::ROOT,
            window,
            Some(window.scale_factor() as f32),
            None,
            Some(graphics.context.limits.max_texture_dimension_2d as usize),
        );
        let renderer = egui_wgpu::Renderer::new(
            &graphics.context.device,
            graphics.config.format,
            egui_wgpu::RendererOptions::default(),
        );
        EguiLayer {
            context,
            state,
            renderer,
        }
    }
}

/// The session for `input`, live on the backend `backend` picks.
fn start_session(
    input: ViewInput,
    backend: Backend,
    context: &Arc<GpuContext>,
) -> Result<Session, ViewError> {
    match input {
        ViewInput::RunDirectory(directory) => {
            let playback = Playback::open(&directory).map_err(ViewError::BadInput)?;
            Ok(Session::new(Content::Playback(Box::new(playback)), None))
        }
        ViewInput::Scene(scene) => {
            let gpu = simulation_device(&scene, backend, context)?;
            Session::live(*scene, gpu).map_err(ViewError::Failed)
        }
    }
}

/// Where a live scene runs: the window's device with `--backend gpu`, or
/// with `auto` when it is a hardware GPU that runs the scene; else the CPU.
fn simulation_device(
    scene: &firn_core::Scene,
    backend: Backend,
    context: &Arc<GpuContext>,
) -> Result<Option<Arc<GpuContext>>, ViewError> {
    match backend {
        Backend::Cpu => Ok(None),
        Backend::Gpu => gpu_supports(scene)
            .map(|()| Some(Arc::clone(context)))
            .map_err(|error| ViewError::BadInput(format!("--backend gpu: {error}"))),
        Backend::Auto => Ok(auto_takes(scene, Some(&context.adapter))
            .is_ok()
            .then(|| Arc::clone(context))),
    }
}

/// The renderer's view of a simulation's particles on the host.
fn host_source<'a>(particles: &'a HostParticles<'a>) -> ParticleSource<'a> {
    ParticleSource::Host {
        positions: particles.positions,
        values: particles.values.as_deref(),
        trails: particles.trails.as_ref().map(|rings| Trails {
            points: &rings.points,
            capacity: rings.capacity,
            lengths: &rings.lengths,
        }),
    }
}
