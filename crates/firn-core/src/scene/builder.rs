//! Scenes built in code: [`Scene::builder`] and [`SceneBuilder`].
//!
//! The builder starts from the defaults a scene file gets for the keys it
//! leaves out (the [`Default`] impls and constants of [`model`](super::model)
//! and [`flow`](super::flow), which the file format's resolver uses too), so
//! a scene built with the same required inputs as a file is the same scene.
//! [`SceneBuilder::build`] runs [`Scene::validate`]: a scene built in code gets
//! the checks and messages of a scene file, with the key path of the
//! offending value (`bodies[0].radius`) in [`SceneError::key`].
//!
//! ```
//! use firn_core::scene::{Body, Collider, Contact, Material, Scene, Transfer};
//! use glam::Vec3;
//!
//! let scene = Scene::builder("snowball")
//!     .domain(Vec3::ZERO, Vec3::ONE, 0.025)
//!     .walls(Contact::separate(0.3))
//!     .duration(0.5)
//!     .fps(20.0)
//!     .transfer(Transfer::Apic)
//!     .material(Material::preset("wet").unwrap())
//!     .body(Body::sphere(Vec3::new(0.5, 0.7, 0.5), 0.12))
//!     .collider(Collider::sphere(Vec3::new(0.4, 0.25, 0.5), 0.15).moving(Vec3::X * 0.3))
//!     .build()
//!     .unwrap();
//! assert_eq!(scene.output.directory, std::path::Path::new("out/snowball"));
//! ```

use std::path::PathBuf;

use glam::Vec3;

use super::compute::{Backend, ComputeSettings};
use super::flow::{FlowEmitter, FlowObstacle, FlowSettings, SceneKind};
use super::format::SceneError;
use super::material::Material;
use super::model::{
    Attribute, Body, CacheFormat, Collider, Contact, Domain, Integrator, OutputSettings, Scene,
    SolverSettings, TimeSettings, TimeStep, Transfer,
};
use super::render::{Camera, RenderSettings};
use super::rigid_body::RigidBody;
use super::wind::Wind;

/// Builds a [`Scene`] from its defaults; see the [module docs](self).
///
/// Every method takes and returns the builder, so calls chain; only what
/// differs from the defaults needs saying. Defaults, as in a scene file:
///
/// - domain: the unit box `[0, 1]³` with cell size 0.05 m
///   ([`Domain::default`]) and separate walls with friction 0.2;
/// - time: 1 s ([`TimeSettings::DEFAULT_DURATION`]; a file must give
///   `duration`) at 30 fps, adaptive step with CFL 0.4 and Δt at most 1 ms or
///   one frame, whichever is shorter, for the frame rate finally set;
/// - solver: PIC/FLIP with α = 0.95, gravity (0, −9.81, 0), seed 1, explicit;
/// - materials: the `snow` preset when bodies exist and none is added;
///   bodies refer to materials by index, in the order they were added;
/// - output: `out/<name>`, PLY and VTK, the kind's default attributes, a
///   checkpoint every 10 frames; default camera, render and compute settings.
#[derive(Clone, Debug)]
#[must_use = "a builder does nothing until `build` is called"]
pub struct SceneBuilder {
    name: String,
    domain: Domain,
    duration: f64,
    fps: f64,
    step: StepChoice,
    max_substeps_per_frame: u32,
    solver: SolverSettings,
    materials: Vec<Material>,
    bodies: Vec<Body>,
    colliders: Vec<Collider>,
    rigid_bodies: Vec<RigidBody>,
    output: OutputSettings,
    /// Whether the attributes are still the default (they depend on the kind).
    default_attributes: bool,
    camera: Camera,
    render: RenderSettings,
    compute: ComputeSettings,
    flow: FlowChoice,
    wind: Option<Wind>,
}

/// The time step as far as it has been chosen.
#[derive(Clone, Debug)]
enum StepChoice {
    /// [`TimeStep::default_for_fps`] of the final frame rate.
    Default,
    /// Adaptive with this CFL number and the default bound for the final frame rate.
    Cfl(f32),
    /// Exactly this step.
    Exact(TimeStep),
}

/// Snow, or a flow and what has been said about it.
#[derive(Clone, Debug)]
enum FlowChoice {
    /// A snow scene.
    Snow,
    /// A flow scene: its settings (`None`: [`FlowSettings::for_domain`] of
    /// the final domain), and the obstacles and emitters added to them.
    Flow {
        settings: Option<FlowSettings>,
        obstacles: Vec<FlowObstacle>,
        emitters: Vec<FlowEmitter>,
    },
}

impl FlowChoice {
    /// The flow's obstacles and emitters to add to, making the scene a flow.
    fn parts(&mut self) -> (&mut Vec<FlowObstacle>, &mut Vec<FlowEmitter>) {
        if let FlowChoice::Snow = self {
            *self = FlowChoice::Flow {
                settings: None,
                obstacles: Vec::new(),
                emitters: Vec::new(),
            };
        }
        match self {
            FlowChoice::Flow {
                obstacles,
                emitters,
                ..
            } => (obstacles, emitters),
            FlowChoice::Snow => unreachable!("made a flow above"),
        }
    }
}

impl Scene {
    /// A builder for a scene named `name`, starting from the defaults of the
    /// scene format; see [`SceneBuilder`].
    pub fn builder(name: impl Into<String>) -> SceneBuilder {
        SceneBuilder::new(name)
    }
}

// `SceneError` is a plain record of public fields (part of the API); it is
// returned once, on a cold path, so its size does not matter.
#[allow(clippy::result_large_err)]
impl SceneBuilder {
    /// A builder for a scene named `name` (also the default output directory
    /// `out/<name>`), starting from the defaults of the scene format.
    pub fn new(name: impl Into<String>) -> SceneBuilder {
        let name = name.into();
        let defaults = Scene::default();
        let time = TimeSettings::default();
        SceneBuilder {
            output: OutputSettings::for_scene(&name),
            name,
            domain: defaults.domain,
            duration: time.duration,
            fps: time.fps,
            step: StepChoice::Default,
            max_substeps_per_frame: time.max_substeps_per_frame,
            solver: defaults.solver,
            materials: Vec::new(),
            bodies: Vec::new(),
            colliders: Vec::new(),
            rigid_bodies: Vec::new(),
            default_attributes: true,
            camera: defaults.camera,
            render: defaults.render,
            compute: defaults.compute,
            flow: FlowChoice::Snow,
            wind: None,
        }
    }

    // -- domain ------------------------------------------------------------

    /// The simulation box from `min` to `max` with grid spacing `cell_size`
    /// (`[domain]` `min`, `max`, `cell_size`); the walls stay as they are.
    pub fn domain(mut self, min: Vec3, max: Vec3, cell_size: f32) -> SceneBuilder {
        self.domain.min = min;
        self.domain.max = max;
        self.domain.cell_size = cell_size;
        self
    }

    /// The unit box `[0, 1]³` with grid spacing `cell_size`.
    pub fn unit_box(self, cell_size: f32) -> SceneBuilder {
        self.domain(Vec3::ZERO, Vec3::ONE, cell_size)
    }

    /// How the six walls of the box treat snow (`domain.walls`).
    pub fn walls(mut self, contact: Contact) -> SceneBuilder {
        self.domain.walls = contact;
        self
    }

    // -- time --------------------------------------------------------------

    /// Simulated seconds (`time.duration`).
    pub fn duration(mut self, seconds: f64) -> SceneBuilder {
        self.duration = seconds;
        self
    }

    /// Output frames per simulated second (`time.fps`). Unless the step is
    /// set with [`fixed_dt`](Self::fixed_dt), [`adaptive`](Self::adaptive)
    /// or [`time_step`](Self::time_step), the bound on the adaptive step
    /// follows the frame rate, as in a scene file.
    pub fn fps(mut self, fps: f64) -> SceneBuilder {
        self.fps = fps;
        self
    }

    /// A fixed step of `dt` seconds (`step = "fixed"`, `dt`).
    pub fn fixed_dt(self, dt: f32) -> SceneBuilder {
        self.time_step(TimeStep::Fixed { dt })
    }

    /// The adaptive step with CFL number `cfl` and Δt at most `max_dt`
    /// seconds (`step = "adaptive"`, `cfl`, `dt`).
    pub fn adaptive(self, cfl: f32, max_dt: f32) -> SceneBuilder {
        self.time_step(TimeStep::Adaptive { cfl, max_dt })
    }

    /// The adaptive step with CFL number `cfl` and the default bound on Δt
    /// for the frame rate (`cfl` alone).
    pub fn cfl(mut self, cfl: f32) -> SceneBuilder {
        self.step = StepChoice::Cfl(cfl);
        self
    }

    /// Exactly this time-step policy.
    pub fn time_step(mut self, step: TimeStep) -> SceneBuilder {
        self.step = StepChoice::Exact(step);
        self
    }

    /// Most substeps a frame may take (`time.max_substeps_per_frame`).
    pub fn max_substeps_per_frame(mut self, limit: u32) -> SceneBuilder {
        self.max_substeps_per_frame = limit;
        self
    }

    /// Duration, frame rate, step and substep limit at once.
    pub fn time(mut self, time: TimeSettings) -> SceneBuilder {
        self.duration = time.duration;
        self.fps = time.fps;
        self.step = StepChoice::Exact(time.step);
        self.max_substeps_per_frame = time.max_substeps_per_frame;
        self
    }

    // -- solver ------------------------------------------------------------

    /// The transfer scheme (`solver.transfer`).
    pub fn transfer(mut self, transfer: Transfer) -> SceneBuilder {
        self.solver.transfer = transfer;
        self
    }

    /// The FLIP share α of the PIC/FLIP blend (`solver.flip`).
    pub fn flip_blend(mut self, alpha: f32) -> SceneBuilder {
        self.solver.flip_blend = alpha;
        self
    }

    /// Gravitational acceleration in m/s² (`solver.gravity`).
    pub fn gravity(mut self, gravity: Vec3) -> SceneBuilder {
        self.solver.gravity = gravity;
        self
    }

    /// Seed of the particle jitter (`solver.seed`).
    pub fn seed(mut self, seed: u64) -> SceneBuilder {
        self.solver.seed = seed;
        self
    }

    /// The grid integrator (`solver.integrator`), e.g.
    /// `Integrator::SemiImplicit(ImplicitSettings::default())`.
    pub fn integrator(mut self, integrator: Integrator) -> SceneBuilder {
        self.solver.integrator = integrator;
        self
    }

    /// All solver settings at once.
    pub fn solver(mut self, solver: SolverSettings) -> SceneBuilder {
        self.solver = solver;
        self
    }

    // -- snow --------------------------------------------------------------

    /// Adds a material; bodies refer to it by its index, the number of
    /// materials added before it (the first is 0). Without any, bodies are
    /// of [`Material::default`] (the `snow` preset), as in a scene file.
    pub fn material(mut self, material: Material) -> SceneBuilder {
        self.add_material(material);
        self
    }

    /// Adds a material and returns its index, for [`Body::material`].
    pub fn add_material(&mut self, material: Material) -> usize {
        self.materials.push(material);
        self.materials.len() - 1
    }

    /// Adds a body of snow, e.g. `Body::sphere(center, 0.1).velocity(v)`.
    pub fn body(mut self, body: Body) -> SceneBuilder {
        self.bodies.push(body);
        self
    }

    /// Adds a collider, e.g. `Collider::sphere(center, 0.2).moving(v).friction(0.5)`.
    pub fn collider(mut self, collider: Collider) -> SceneBuilder {
        self.colliders.push(collider);
        self
    }

    /// Adds a rigid body the snow pushes, e.g.
    /// `RigidBody::cuboid(center, size).density(700.0)`.
    pub fn rigid_body(mut self, body: RigidBody) -> SceneBuilder {
        self.rigid_bodies.push(body);
        self
    }

    // -- flow --------------------------------------------------------------

    /// Makes the scene a curl-noise flow with these settings (the obstacles
    /// and emitters added with [`obstacle`](Self::obstacle) and
    /// [`emitter`](Self::emitter) come after theirs). Without it, a flow
    /// scene gets [`FlowSettings::for_domain`] of its domain, as a scene file
    /// does.
    pub fn flow(mut self, settings: FlowSettings) -> SceneBuilder {
        match &mut self.flow {
            FlowChoice::Flow { settings: slot, .. } => *slot = Some(settings),
            FlowChoice::Snow => {
                self.flow = FlowChoice::Flow {
                    settings: Some(settings),
                    obstacles: Vec::new(),
                    emitters: Vec::new(),
                }
            }
        }
        self
    }

    /// Adds a particle emitter, making the scene a flow.
    pub fn emitter(mut self, emitter: FlowEmitter) -> SceneBuilder {
        self.flow.parts().1.push(emitter);
        self
    }

    /// Adds a sphere obstacle, making the scene a flow.
    pub fn obstacle(mut self, obstacle: FlowObstacle) -> SceneBuilder {
        self.flow.parts().0.push(obstacle);
        self
    }

    // -- output and pictures -----------------------------------------------

    /// The output directory (`output.directory`; default `out/<name>`).
    pub fn output_dir(mut self, directory: impl Into<PathBuf>) -> SceneBuilder {
        self.output.directory = directory.into();
        self
    }

    /// The particle cache formats written each frame (`output.formats`).
    pub fn formats(mut self, formats: impl IntoIterator<Item = CacheFormat>) -> SceneBuilder {
        self.output.formats = formats.into_iter().collect();
        self
    }

    /// The attributes written besides position (`output.attributes`).
    pub fn attributes(mut self, attributes: impl IntoIterator<Item = Attribute>) -> SceneBuilder {
        self.output.attributes = attributes.into_iter().collect();
        self.default_attributes = false;
        self
    }

    /// A checkpoint every `frames` frames, 0 for none (`output.checkpoint_every`).
    pub fn checkpoint_every(mut self, frames: u32) -> SceneBuilder {
        self.output.checkpoint_every = frames;
        self
    }

    /// All output settings at once.
    pub fn output(mut self, output: OutputSettings) -> SceneBuilder {
        self.output = output;
        self.default_attributes = false;
        self
    }

    /// The camera (`[camera]`).
    pub fn camera(mut self, camera: Camera) -> SceneBuilder {
        self.camera = camera;
        self
    }

    /// The picture settings (`[render]`).
    pub fn render(mut self, render: RenderSettings) -> SceneBuilder {
        self.render = render;
        self
    }

    /// The compute backend (`compute.backend`).
    pub fn backend(mut self, backend: Backend) -> SceneBuilder {
        self.compute.backend = backend;
        self
    }

    /// Air blowing over the snow (`[wind]`).
    pub fn wind(mut self, wind: Wind) -> SceneBuilder {
        self.wind = Some(wind);
        self
    }

    // -- the scene ---------------------------------------------------------

    /// The scene, checked by [`Scene::validate`]: the rules and messages of
    /// a scene file, with the key path of the offending value (e.g.
    /// `bodies[0].radius`) in [`SceneError::key`].
    pub fn build(self) -> Result<Scene, SceneError> {
        let scene = self.build_unchecked();
        scene.validate()?;
        Ok(scene)
    }

    /// The scene without the checks of [`build`](Self::build), e.g. to
    /// change it further before calling [`Scene::validate`].
    pub fn build_unchecked(self) -> Scene {
        let step = match self.step {
            StepChoice::Default => TimeStep::default_for_fps(self.fps),
            StepChoice::Cfl(cfl) => TimeStep::Adaptive {
                cfl,
                max_dt: TimeStep::default_max_dt(self.fps),
            },
            StepChoice::Exact(step) => step,
        };
        let kind = match self.flow {
            FlowChoice::Snow => SceneKind::Snow,
            FlowChoice::Flow {
                settings,
                obstacles,
                emitters,
            } => {
                let mut settings =
                    settings.unwrap_or_else(|| FlowSettings::for_domain(&self.domain));
                settings.obstacles.extend(obstacles);
                settings.emitters.extend(emitters);
                SceneKind::Flow(Box::new(settings))
            }
        };
        let mut materials = self.materials;
        if materials.is_empty() && !self.bodies.is_empty() {
            materials.push(Material::default());
        }
        let mut output = self.output;
        if self.default_attributes {
            output.attributes = OutputSettings::default_attributes(&kind);
        }
        Scene {
            name: self.name,
            domain: self.domain,
            time: TimeSettings {
                duration: self.duration,
                fps: self.fps,
                step,
                max_substeps_per_frame: self.max_substeps_per_frame,
            },
            solver: self.solver,
            materials,
            bodies: self.bodies,
            colliders: self.colliders,
            rigid_bodies: self.rigid_bodies,
            output,
            camera: self.camera,
            render: self.render,
            kind,
            compute: self.compute,
            wind: self.wind,
        }
    }
}
