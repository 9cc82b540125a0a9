//! What the viewer shows and how it moves on, without a window: a live
//! simulation in the fixed-timestep loop, or a run played back along its
//! timeline; the panel's settings; and the live figures. The panel changes
//! it only through [`Action`]s, so tests drive the very code path the panel
//! uses.

use std::sync::Arc;
use std::time::{Duration, Instant};

use firn_core::Scene;
use firn_core::scene::{ColorBy, FlowSettings, Material, RigidBody, SceneKind, Wind};
use firn_gpu::GpuContext;
use firn_run::{Placement, Solver};
use glam::Vec3;

use crate::clock::FixedStepClock;
use crate::draw::DrawStyle;
use crate::playback::Playback;

/// Wall-clock time one display frame may spend on physics before the rest
/// of what is owed waits for the next frame (the clock reports falling behind).
const PHYSICS_BUDGET: Duration = Duration::from_millis(40);

/// Wall-clock seconds over which the live figures are averaged.
const FIGURE_WINDOW_SECONDS: f64 = 0.5;

/// What is shown.
pub enum Content {
    /// A scene simulated as it is shown.
    Live(Box<Solver>),
    /// A finished run read from its caches.
    Playback(Box<Playback>),
}

/// Something the panel (or a key) asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Run the loop.
    Play,
    /// Stop the loop.
    Pause,
    /// Advance by exactly one tick (live) or one recorded frame (playback).
    Step,
    /// Start the scene again at time 0 with the current parameters.
    Restart,
    /// Replace the snow materials (E, ν, ξ, θc, θs) from the next substep on.
    SetMaterials(Vec<Material>),
    /// Replace the flow's field parameters (γ, M, L, background, obstacles).
    SetFlow(Box<FlowSettings>),
    /// Replace the wind over the snow (its field, drag and packed density).
    SetWind(Box<Wind>),
    /// Draw particles this way.
    SetStyle(DrawStyle),
    /// Colour particles by this quantity.
    SetColorBy(ColorBy),
    /// Simulated seconds per wall-clock second.
    SetTimeScale(f64),
    /// Jump to this simulated time (playback only).
    Seek(f64),
    /// Throw a rigid ball from where the view from `eye` towards `target`
    /// enters the domain, along it (live, on the CPU).
    Throw {
        /// The camera's eye.
        eye: Vec3,
        /// The point it looks at.
        target: Vec3,
    },
}

/// The figures the panel shows, updated twice a second.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Figures {
    /// Display frames per wall-clock second.
    pub fps: f64,
    /// Solver substeps per wall-clock second.
    pub substeps_per_second: f64,
}

/// Frames and substeps counted towards the next [`Figures`].
#[derive(Clone, Copy, Debug)]
struct FigureWindow {
    started: Instant,
    frames: u32,
    substeps: u64,
}

/// The viewer's state apart from the window.
pub struct Session {
    content: Content,
    /// The scene as loaded, for restarts (with the live parameters applied).
    scene: Scene,
    /// Where live simulations run (and restart).
    placement: Placement,
    clock: FixedStepClock,
    /// Playback position in simulated seconds.
    playback_time: f64,
    playing: bool,
    style: DrawStyle,
    color_by: ColorBy,
    /// Why the simulation stopped, if it failed.
    failure: Option<String>,
    /// The last rejected parameter change, and why.
    rejected: Option<String>,
    figures: Figures,
    window: FigureWindow,
    /// Wall-clock time a display frame may spend on physics.
    physics_budget: Duration,
}

impl Session {
    /// A session showing `content`; `gpu` is where live simulations run
    /// (and restart), `None` for the CPU.
    pub fn new(content: Content, gpu: Option<Arc<GpuContext>>) -> Session {
        let scene = match &content {
            Content::Live(live) => live.scene().clone(),
            Content::Playback(playback) => playback.scene().clone(),
        };
        let style = default_style(&scene);
        let color_by = scene.render.color_by;
        let tick = tick_for(&scene);
        Session {
            content,
            placement: gpu.map_or(Placement::Cpu, Placement::Gpu),
            clock: FixedStepClock::new(tick, 1.0),
            playback_time: 0.0,
            playing: true,
            style,
            color_by,
            failure: None,
            rejected: None,
            figures: Figures::default(),
            window: FigureWindow {
                started: Instant::now(),
                frames: 0,
                substeps: 0,
            },
            physics_budget: PHYSICS_BUDGET,
            scene,
        }
    }

    /// Starts `scene` live on `gpu` (or the CPU).
    pub fn live(scene: Scene, gpu: Option<Arc<GpuContext>>) -> Result<Session, String> {
        let placement = gpu.clone().map_or(Placement::Cpu, Placement::Gpu);
        let live = Solver::new(scene, &placement).map_err(|error| error.to_string())?;
        Ok(Session::new(Content::Live(Box::new(live)), gpu))
    }

    /// Lets every display frame run all the ticks it owes, however long
    /// they take: with display frames of a fixed length (`--display-fps`),
    /// the same frames then always show the same simulated times.
    pub fn run_every_tick_owed(&mut self) {
        self.physics_budget = Duration::MAX;
    }

    /// What is shown.
    pub fn content(&self) -> &Content {
        &self.content
    }

    /// The scene shown, with the parameters changed live.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The fixed-timestep clock (live content).
    pub fn clock(&self) -> &FixedStepClock {
        &self.clock
    }

    /// Simulated time shown.
    pub fn time(&self) -> f64 {
        match &self.content {
            Content::Live(live) => live.time(),
            Content::Playback(playback) => {
                playback.frame_time(playback.frame_at(self.playback_time))
            }
        }
    }

    /// The time the timeline ends at (playback), or `None` (live).
    pub fn timeline_end(&self) -> Option<f64> {
        match &self.content {
            Content::Live(_) => None,
            Content::Playback(playback) => Some(playback.frame_time(playback.frame_count() - 1)),
        }
    }

    /// Particles shown.
    pub fn particle_count(&self) -> usize {
        match &self.content {
            Content::Live(live) => live.particle_count(),
            Content::Playback(playback) => playback.particle_count(),
        }
    }

    /// Whether the loop runs.
    pub fn is_playing(&self) -> bool {
        self.playing
    }

    /// How particles are drawn.
    pub fn style(&self) -> DrawStyle {
        self.style
    }

    /// The quantity particles are coloured by.
    pub fn color_by(&self) -> ColorBy {
        self.color_by
    }

    /// Why the simulation stopped, if it failed.
    pub fn failure(&self) -> Option<&str> {
        self.failure.as_deref()
    }

    /// Why the last parameter change was refused, if it was.
    pub fn rejected(&self) -> Option<&str> {
        self.rejected.as_deref()
    }

    /// The live figures of the last half second.
    pub fn figures(&self) -> Figures {
        self.figures
    }

    /// Whether the live simulation runs on the GPU.
    pub fn on_gpu(&self) -> bool {
        matches!(&self.content, Content::Live(live) if live.on_gpu())
    }

    /// Carries out `action`. A refused parameter change leaves the
    /// simulation as it was and is kept for [`Session::rejected`].
    pub fn apply(&mut self, action: Action) {
        self.rejected = None;
        match action {
            Action::Play => self.playing = self.failure.is_none(),
            Action::Pause => self.playing = false,
            Action::Step => {
                self.playing = false;
                self.step_once();
            }
            Action::Restart => self.restart(),
            Action::SetMaterials(materials) => self.set_materials(materials),
            Action::SetFlow(settings) => self.set_flow(*settings),
            Action::SetWind(wind) => self.set_wind(*wind),
            Action::SetStyle(style) => self.style = style,
            Action::SetColorBy(color_by) => self.color_by = color_by,
            Action::SetTimeScale(scale) => self.clock.set_time_scale(scale),
            Action::Seek(t) => self.playback_time = t.max(0.0),
            Action::Throw { eye, target } => self.throw(eye, target),
        }
    }

    /// One display frame: `real` wall-clock seconds have passed since the
    /// last. Live content runs the ticks owed; playback moves along the
    /// timeline and loads the frame it reaches. Returns the solver substeps run.
    pub fn advance_frame(&mut self, real: f64) -> u64 {
        let mut substeps = 0u64;
        if self.playing {
            match &mut self.content {
                Content::Live(live) => {
                    let result = self.clock.run_frame(real, self.physics_budget, |end| {
                        substeps += u64::from(live.advance_to(end)?);
                        Ok::<(), firn_run::RunError>(())
                    });
                    if let Err(error) = result {
                        self.fail(error.to_string());
                    }
                }
                Content::Playback(_) => self.play_along(real),
            }
        }
        self.read_back_drift();
        self.load_playback_frame();
        self.count_figures(substeps);
        substeps
    }

    /// Advances playback by `real` seconds at the time scale, looping at the end.
    fn play_along(&mut self, real: f64) {
        let end = self.timeline_end().unwrap_or(0.0);
        self.playback_time += real * self.clock.time_scale();
        if self.playback_time > end + 1e-9 {
            self.playback_time = 0.0;
        }
    }

    /// Loads the recorded frame at the playback time.
    fn load_playback_frame(&mut self) {
        if let Content::Playback(playback) = &mut self.content {
            let index = playback.frame_at(self.playback_time);
            if let Err(reason) = playback.load(index, self.color_by) {
                self.rejected = Some(reason);
                self.color_by = ColorBy::Uniform;
            }
        }
    }

    /// Runs one tick (live) or moves to the next recorded frame (playback).
    fn step_once(&mut self) {
        match &mut self.content {
            Content::Live(live) => {
                let end = self.clock.next_tick_end();
                match live.advance_to(end) {
                    Ok(_) => self.clock.count_single_tick(),
                    Err(error) => self.fail(error.to_string()),
                }
            }
            Content::Playback(playback) => {
                let next = (playback.frame_at(self.playback_time) + 1) % playback.frame_count();
                self.playback_time = playback.frame_time(next);
            }
        }
        self.read_back_drift();
        self.load_playback_frame();
    }

    /// Whether the live snow is drawn from a host copy read back from the
    /// GPU: with spindrift, whose drift and escaped drift share the snow's
    /// buffers on the device (`firn_gpu::GpuSnow::particle_arrays`).
    pub fn draws_read_back(&self) -> bool {
        self.on_gpu() && self.scene().spindrift().is_some()
    }

    /// Reads a live GPU run with spindrift back, so that its snow and its
    /// drift are drawn apart ([`Session::draws_read_back`]).
    fn read_back_drift(&mut self) {
        if !self.draws_read_back() {
            return;
        }
        if let Content::Live(live) = &mut self.content
            && let Err(error) = live.host()
        {
            self.fail(error.to_string());
        }
    }

    /// Starts the scene again (with the live parameters), or rewinds playback.
    fn restart(&mut self) {
        self.failure = None;
        self.clock.reset();
        self.playback_time = 0.0;
        if let Content::Live(live) = &mut self.content {
            match Solver::new(self.scene.clone(), &self.placement) {
                Ok(fresh) => **live = fresh,
                Err(error) => self.fail(error.to_string()),
            }
        }
        self.load_playback_frame();
    }

    fn set_materials(&mut self, materials: Vec<Material>) {
        let Content::Live(live) = &mut self.content else {
            self.rejected = Some("a played-back run cannot change its materials".into());
            return;
        };
        match live.set_materials(&materials) {
            Ok(()) => self.scene.materials = materials,
            Err(error) => self.rejected = Some(error.to_string()),
        }
    }

    fn set_flow(&mut self, settings: FlowSettings) {
        let Content::Live(live) = &mut self.content else {
            self.rejected = Some("a played-back run cannot change its flow".into());
            return;
        };
        match live.set_flow(&settings) {
            Ok(()) => self.scene.kind = SceneKind::Flow(Box::new(settings)),
            Err(error) => self.rejected = Some(error.to_string()),
        }
    }

    fn set_wind(&mut self, wind: Wind) {
        let Content::Live(live) = &mut self.content else {
            self.rejected = Some("a played-back run cannot change its wind".into());
            return;
        };
        match live.set_wind(&wind) {
            Ok(()) => self.scene.wind = Some(wind),
            Err(error) => self.rejected = Some(error.to_string()),
        }
    }

    /// Throws a stone ball of four cells' radius at [`THROW_SPEED`] along
    /// the view, from where the view enters the domain (clear of its walls).
    fn throw(&mut self, eye: Vec3, target: Vec3) {
        let Content::Live(live) = &mut self.content else {
            self.rejected = Some("a played-back run cannot take a thrown body".into());
            return;
        };
        let domain = &self.scene.domain;
        let radius = 4.0 * domain.cell_size;
        let margin = Vec3::splat(radius + domain.cell_size);
        let direction = (target - eye).normalize_or_zero();
        let Some(start) = ray_entry(eye, direction, domain.min + margin, domain.max - margin)
        else {
            self.rejected = Some("look at the domain to throw into it".into());
            return;
        };
        let ball = RigidBody::sphere(start, radius)
            .density(THROWN_DENSITY)
            .moving(direction * THROW_SPEED, Vec3::ZERO);
        match live.add_rigid_body(ball.clone()) {
            Ok(()) => self.scene.rigid_bodies.push(ball),
            Err(error) => self.rejected = Some(error.to_string()),
        }
    }

    /// Stops the loop with the solver's explanation.
    fn fail(&mut self, reason: String) {
        self.playing = false;
        self.failure = Some(reason);
    }

    /// Counts a frame and its substeps; closes the figures' window twice a second.
    fn count_figures(&mut self, substeps: u64) {
        let window = &mut self.window;
        window.frames += 1;
        window.substeps += substeps;
        let seconds = window.started.elapsed().as_secs_f64();
        if seconds >= FIGURE_WINDOW_SECONDS {
            self.figures = Figures {
                fps: f64::from(window.frames) / seconds,
                substeps_per_second: window.substeps as f64 / seconds,
            };
            *window = FigureWindow {
                started: Instant::now(),
                frames: 0,
                substeps: 0,
            };
        }
    }
}

/// The physics tick of a scene: one flow substep (flows advance in whole
/// substeps), or for snow the frame divided into ticks of at most 1/120 s.
pub fn tick_for(scene: &Scene) -> f64 {
    match &scene.kind {
        SceneKind::Flow(flow) => 1.0 / (scene.time.fps * f64::from(flow.substeps.max(1))),
        SceneKind::Snow => FixedStepClock::tick_for_frame_rate(scene.time.fps),
    }
}

/// The scene's first render style as a draw style (snow: points; flows
/// with trails: trails).
fn default_style(scene: &Scene) -> DrawStyle {
    use firn_core::scene::RenderStyle;
    match scene.render.styles.first() {
        Some(RenderStyle::Billboards) => DrawStyle::Billboards,
        Some(RenderStyle::Trails) => DrawStyle::Trails,
        _ => DrawStyle::Points,
    }
}

/// The speed of a thrown ball, m/s.
const THROW_SPEED: f32 = 4.0;

/// The density of a thrown ball, kg/m³ (stone).
const THROWN_DENSITY: f32 = 2500.0;

/// The first point at or after `origin` along the unit `direction` that lies
/// in the box from `low` to `high`, if the ray meets the box.
fn ray_entry(origin: Vec3, direction: Vec3, low: Vec3, high: Vec3) -> Option<Vec3> {
    let (mut near, mut far) = (0.0f32, f32::INFINITY);
    for axis in 0..3 {
        if direction[axis] == 0.0 {
            if origin[axis] < low[axis] || origin[axis] > high[axis] {
                return None;
            }
            continue;
        }
        let a = (low[axis] - origin[axis]) / direction[axis];
        let b = (high[axis] - origin[axis]) / direction[axis];
        near = near.max(a.min(b));
        far = far.min(a.max(b));
    }
    (near <= far).then(|| origin + direction * near)
}
