//! The scene model: plain data a program can build in code or load from a
//! scene file with [`Scene::load`](crate::Scene::load).
//!
//! Units are SI throughout: metres, seconds, kilograms, pascals.
//!
//! The defaults of the scene format live here, as [`Default`] impls, named
//! constants and small constructors ([`Body::sphere`], [`Collider::plane`],
//! ...). The format's resolver fills omitted keys from them and
//! [`SceneBuilder`](super::builder::SceneBuilder) starts from them, so a scene
//! file and a scene built in code agree on every value left out.

use std::path::PathBuf;

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

use super::clumps::Clumps;
use super::compute::ComputeSettings;
use super::flow::SceneKind;
use super::material::Material;
use super::mesh::{MeshBody, MeshCollider};
use super::mesh_sequence::MeshSequenceCollider;
use super::motion::{Keyframe, Motion, PathShape, Pose};
use super::render::{Camera, RenderSettings};
use super::rigid_body::RigidBody;
use super::wind::{Spindrift, Wind};

/// A complete snow scene, resolved: presets expanded, defaults filled in.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    /// Short name, used for the default output directory.
    pub name: String,
    /// The simulation box and its grid.
    pub domain: Domain,
    /// Duration, frame rate and time-step policy.
    pub time: TimeSettings,
    /// Transfer scheme, gravity and other solver settings.
    pub solver: SolverSettings,
    /// Materials the bodies refer to by index.
    pub materials: Vec<Material>,
    /// Bodies of snow that become particles at the start.
    pub bodies: Vec<Body>,
    /// Rigid colliders besides the domain walls.
    pub colliders: Vec<Collider>,
    /// Solids that move under gravity, the snow's push and their contacts
    /// (`[[rigid_bodies]]`; absent from manifests and checkpoints written
    /// before they existed).
    #[serde(default)]
    pub rigid_bodies: Vec<RigidBody>,
    /// Where and what to write.
    pub output: OutputSettings,
    /// Where the pictures are taken from.
    pub camera: Camera,
    /// What pictures are made.
    pub render: RenderSettings,
    /// Snow, or a curl-noise particle flow with its settings.
    pub kind: SceneKind,
    /// Which backend computes the scene (`[compute]`; absent from manifests
    /// and checkpoints written before it existed).
    #[serde(default)]
    pub compute: ComputeSettings,
    /// Air blowing over the snow (`[wind]`; snow scenes only; absent from
    /// manifests and checkpoints written before it existed).
    #[serde(default)]
    pub wind: Option<Wind>,
}

impl Scene {
    /// The name of [`Scene::default`], and of a scene parsed from text whose
    /// origin is not a `.toml` file.
    pub const DEFAULT_NAME: &'static str = "scene";

    /// The wind's spindrift (`[wind.spindrift]`), if the scene lifts drift
    /// off its snow.
    pub fn spindrift(&self) -> Option<&Spindrift> {
        self.wind.as_ref()?.spindrift.as_ref()
    }
}

impl Default for Scene {
    /// The defaults of the scene format with no snow: named
    /// [`Scene::DEFAULT_NAME`] (`"scene"`), the unit box `[0, 1]³` with a
    /// grid spacing of [`Domain::DEFAULT_CELL_SIZE`] (0.05 m, 20 cells per
    /// axis) and separate walls with friction 0.2, one simulated second at
    /// 30 fps with the adaptive step (CFL 0.4, Δt at most 1 ms), PIC/FLIP
    /// (α = 0.95) with the explicit integrator, gravity (0, −9.81, 0) and
    /// seed 1, no materials, bodies or colliders, no wind, output to
    /// `out/scene`, and the default camera, render and compute settings.
    ///
    /// It does not [`validate`](Scene::validate): a snow scene needs at least
    /// one body. Build scenes with [`Scene::builder`] instead, or fill in
    /// `materials` and `bodies` (and a fitting `name` and `output`).
    fn default() -> Scene {
        Scene {
            name: Scene::DEFAULT_NAME.to_string(),
            domain: Domain::default(),
            time: TimeSettings::default(),
            solver: SolverSettings::default(),
            materials: Vec::new(),
            bodies: Vec::new(),
            colliders: Vec::new(),
            rigid_bodies: Vec::new(),
            output: OutputSettings::for_scene(Scene::DEFAULT_NAME),
            camera: Camera::default(),
            render: RenderSettings::default(),
            kind: SceneKind::Snow,
            compute: ComputeSettings::default(),
            wind: None,
        }
    }
}

/// The axis-aligned simulation box, its grid spacing and its walls.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Domain {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
    /// Grid spacing h (cell edge length).
    pub cell_size: f32,
    /// How the six walls of the box treat snow that reaches them.
    pub walls: Contact,
}

impl Domain {
    /// Grid spacing of [`Domain::default`]: 0.05 m, 20 cells along each edge
    /// of the unit box. A scene file has no default; it must give `cell_size`.
    pub const DEFAULT_CELL_SIZE: f32 = 0.05;

    /// The box from `min` to `max` with grid spacing `cell_size` and the
    /// default walls ([`Contact::default`]).
    pub fn new(min: Vec3, max: Vec3, cell_size: f32) -> Domain {
        Domain {
            min,
            max,
            cell_size,
            walls: Contact::default(),
        }
    }

    /// The unit box `[0, 1]³` with grid spacing `cell_size` and the default walls.
    pub fn unit_box(cell_size: f32) -> Domain {
        Domain::new(Vec3::ZERO, Vec3::ONE, cell_size)
    }

    /// Number of grid cells along each axis (rounded up to cover the box).
    pub fn cells(&self) -> [u32; 3] {
        let extent = (self.max - self.min) / self.cell_size;
        [extent.x, extent.y, extent.z].map(|e| (e - 1e-4).ceil().max(1.0) as u32)
    }

    /// Whether a point lies inside the box (boundary included).
    pub fn contains(&self, point: Vec3) -> bool {
        point.cmpge(self.min).all() && point.cmple(self.max).all()
    }
}

/// Simulated duration, output frame rate and the time-step policy.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeSettings {
    /// Simulated seconds.
    pub duration: f64,
    /// Output frames per simulated second.
    pub fps: f64,
    /// How each substep's Δt is chosen.
    pub step: TimeStep,
    /// Most substeps one frame may take: a scene whose first Δt would need
    /// more is refused when it is loaded, and a run whose Δt falls so low
    /// that a frame would need more stops. Left out of the JSON form when it
    /// is the default, so that runs recorded before it existed resume.
    #[serde(
        default = "TimeSettings::default_max_substeps_per_frame",
        skip_serializing_if = "TimeSettings::is_default_max_substeps_per_frame"
    )]
    pub max_substeps_per_frame: u32,
}

impl Default for Domain {
    /// The unit box `[0, 1]³` with a grid spacing of
    /// [`Domain::DEFAULT_CELL_SIZE`] (0.05 m) and the default walls.
    fn default() -> Domain {
        Domain::unit_box(Domain::DEFAULT_CELL_SIZE)
    }
}

impl TimeSettings {
    /// Output frames per simulated second when the scene gives none (`time.fps`).
    pub const DEFAULT_FPS: f64 = 30.0;

    /// Simulated seconds of [`TimeSettings::default`]. A scene file has no
    /// default; it must give `time.duration`.
    pub const DEFAULT_DURATION: f64 = 1.0;

    /// Most substeps per frame when the scene gives no
    /// `time.max_substeps_per_frame`: a hundred thousand, some 300 times
    /// what the bundled scenes take.
    pub const DEFAULT_MAX_SUBSTEPS_PER_FRAME: u32 = 100_000;

    /// `duration` simulated seconds at [`TimeSettings::DEFAULT_FPS`] with the
    /// default adaptive step for that frame rate
    /// ([`TimeStep::default_for_fps`]).
    pub fn new(duration: f64) -> TimeSettings {
        TimeSettings {
            duration,
            fps: TimeSettings::DEFAULT_FPS,
            step: TimeStep::default_for_fps(TimeSettings::DEFAULT_FPS),
            max_substeps_per_frame: TimeSettings::DEFAULT_MAX_SUBSTEPS_PER_FRAME,
        }
    }

    fn default_max_substeps_per_frame() -> u32 {
        TimeSettings::DEFAULT_MAX_SUBSTEPS_PER_FRAME
    }

    fn is_default_max_substeps_per_frame(limit: &u32) -> bool {
        *limit == TimeSettings::DEFAULT_MAX_SUBSTEPS_PER_FRAME
    }

    /// The shortest Δt a substep may take before a frame would need more
    /// than `max_substeps_per_frame` substeps: 1 / (fps × limit) seconds.
    pub fn shortest_dt(&self) -> f64 {
        1.0 / (self.fps * f64::from(self.max_substeps_per_frame.max(1)))
    }

    /// Number of output frames after the initial state (frame 0).
    pub fn frame_count(&self) -> u32 {
        (self.duration * self.fps - 1e-9).ceil().max(0.0) as u32
    }
}

impl Default for TimeSettings {
    /// One simulated second ([`TimeSettings::DEFAULT_DURATION`]) at 30 fps,
    /// adaptive step with CFL 0.4 and Δt at most 1 ms.
    fn default() -> TimeSettings {
        TimeSettings::new(TimeSettings::DEFAULT_DURATION)
    }
}

/// The time-step policy.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum TimeStep {
    /// A fixed Δt (the thesis steps a fixed 1 ms).
    Fixed {
        /// The step in seconds.
        dt: f32,
    },
    /// Δt from the CFL condition on particle speed and elastic wave speed,
    /// never above `max_dt`.
    Adaptive {
        /// CFL number: the fraction of a cell a wave or particle may cross per step.
        cfl: f32,
        /// Upper bound on Δt in seconds.
        max_dt: f32,
    },
}

impl TimeStep {
    /// CFL number of the adaptive step when the scene gives none (`time.cfl`).
    pub const DEFAULT_CFL: f32 = 0.4;

    /// Upper bound on the adaptive Δt when the scene gives none (`time.dt`),
    /// unless one frame is shorter: see [`TimeStep::default_max_dt`].
    pub const DEFAULT_MAX_DT: f32 = 1e-3;

    /// The default bound on the adaptive Δt at `fps` frames per second:
    /// 1 ms, or one frame if frames are shorter than that.
    pub fn default_max_dt(fps: f64) -> f32 {
        if fps > 0.0 {
            TimeStep::DEFAULT_MAX_DT.min((1.0 / fps) as f32)
        } else {
            TimeStep::DEFAULT_MAX_DT
        }
    }

    /// The default step at `fps` frames per second: adaptive with
    /// [`TimeStep::DEFAULT_CFL`] and [`TimeStep::default_max_dt`].
    pub fn default_for_fps(fps: f64) -> TimeStep {
        TimeStep::Adaptive {
            cfl: TimeStep::DEFAULT_CFL,
            max_dt: TimeStep::default_max_dt(fps),
        }
    }
}

/// How particle and grid momentum are exchanged.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Transfer {
    /// PIC/FLIP blend with cubic B-splines, as in Stomakhin et al. 2013 and the
    /// thesis (the default).
    #[default]
    PicFlip,
    /// Affine PIC (Jiang et al. 2015) with quadratic B-splines; conserves angular momentum.
    Apic,
}

/// Solver settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SolverSettings {
    /// Transfer scheme.
    pub transfer: Transfer,
    /// FLIP share α of the PIC/FLIP blend (thesis step 8; 0.95 by default).
    pub flip_blend: f32,
    /// Gravitational acceleration in m/s².
    pub gravity: Vec3,
    /// Seed for particle jitter; the same seed gives the same particles.
    pub seed: u64,
    /// How the grid velocities are advanced (Stomakhin et al. 2013, step 6).
    pub integrator: Integrator,
}

impl Default for SolverSettings {
    /// PIC/FLIP with α = 0.95, gravity (0, −9.81, 0) m/s², seed 1 and the
    /// explicit integrator.
    fn default() -> SolverSettings {
        SolverSettings {
            transfer: Transfer::default(),
            flip_blend: 0.95,
            gravity: Vec3::new(0.0, -9.81, 0.0),
            seed: 1,
            integrator: Integrator::default(),
        }
    }
}

/// How the grid velocities v_i^{n+1} are computed from the grid forces.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Integrator {
    /// Forward (symplectic) Euler: v_i^{n+1} = v_i* (the thesis; step 6 skipped).
    /// Δt must resolve the elastic waves. The default.
    #[default]
    Explicit,
    /// Stomakhin et al. 2013, eq. 9: solve (I + β Δt² M⁻¹ H) v^{n+1} = v* on the
    /// grid, with H the Hessian of the elastic energy, by preconditioned
    /// conjugate residuals. Δt is then limited by particle motion only.
    SemiImplicit(ImplicitSettings),
}

/// Parameters of the semi-implicit update.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImplicitSettings {
    /// Implicitness β: 0 is explicit, 1 backward Euler.
    pub beta: f32,
    /// Relative residual at which the linear solve stops.
    pub tolerance: f32,
    /// Most solver iterations per substep.
    pub max_iterations: u32,
}

impl ImplicitSettings {
    /// The defaults of the scene format: β = 0.5, tolerance 1e-3, 100 iterations.
    pub const DEFAULT: ImplicitSettings = ImplicitSettings {
        beta: 0.5,
        tolerance: 1e-3,
        max_iterations: 100,
    };
}

impl Default for ImplicitSettings {
    /// [`ImplicitSettings::DEFAULT`].
    fn default() -> ImplicitSettings {
        ImplicitSettings::DEFAULT
    }
}

/// A body of snow: a shape filled with particles of one material.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Body {
    /// The filled region.
    pub shape: Shape,
    /// Initial velocity of every particle.
    pub velocity: Vec3,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// Particles per grid cell (8 by default), placed on a jittered lattice.
    pub particles_per_cell: u32,
    /// Uneven packing in clumps joined by looser seams (none by default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clumps: Option<Clumps>,
}

impl Body {
    /// Particles per cell when the body gives none (`particles_per_cell`).
    pub const DEFAULT_PARTICLES_PER_CELL: u32 = 8;

    /// A body filling `shape`, at rest, of material 0, with
    /// [`Body::DEFAULT_PARTICLES_PER_CELL`] particles per cell.
    pub fn new(shape: Shape) -> Body {
        Body {
            shape,
            velocity: Vec3::ZERO,
            material: 0,
            particles_per_cell: Body::DEFAULT_PARTICLES_PER_CELL,
            clumps: None,
        }
    }

    /// A ball of snow (`shape = "sphere"`).
    pub fn sphere(center: Vec3, radius: f32) -> Body {
        Body::new(Shape::Sphere { center, radius })
    }

    /// An axis-aligned box of snow (`shape = "box"`) with edge lengths `size`.
    pub fn cuboid(center: Vec3, size: Vec3) -> Body {
        Body::new(Shape::Box { center, size })
    }

    /// A solid cylinder of snow (`shape = "cylinder"`); `axis` is normalised
    /// as in a scene file (a zero axis is left for validation to report).
    pub fn cylinder(center: Vec3, axis: Vec3, radius: f32, height: f32) -> Body {
        Body::new(Shape::Cylinder {
            center,
            axis: unit_or_zero(axis),
            radius,
            height,
        })
    }

    /// The inside of a loaded triangle mesh (`shape = "mesh"`; see
    /// [`MeshBody::load`]).
    pub fn mesh(mesh: MeshBody) -> Body {
        Body::new(Shape::Mesh(Box::new(mesh)))
    }

    /// The same body with every particle starting at `velocity` (m/s).
    pub fn velocity(mut self, velocity: Vec3) -> Body {
        self.velocity = velocity;
        self
    }

    /// The same body of material `index` into [`Scene::materials`].
    pub fn material(mut self, index: usize) -> Body {
        self.material = index;
        self
    }

    /// The same body with `count` particles per grid cell (1 to 64).
    pub fn particles_per_cell(mut self, count: u32) -> Body {
        self.particles_per_cell = count;
        self
    }

    /// The same body packed in `clumps`.
    pub fn clumps(mut self, clumps: Clumps) -> Body {
        self.clumps = Some(clumps);
        self
    }
}

/// A direction scaled to unit length; the zero vector (and one that is not
/// finite) is left as it is, for validation to report.
pub(crate) fn unit_or_zero(v: Vec3) -> Vec3 {
    let length = v.length();
    if length > 0.0 && length.is_finite() {
        v / length
    } else {
        v
    }
}

/// A solid primitive that bodies fill.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "kebab-case")]
pub enum Shape {
    /// A ball.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
    },
    /// An axis-aligned box.
    Box {
        /// Centre.
        center: Vec3,
        /// Edge lengths along x, y, z.
        size: Vec3,
    },
    /// A solid circular cylinder.
    Cylinder {
        /// Centre of the cylinder (half way along its axis).
        center: Vec3,
        /// Unit direction of the axis.
        axis: Vec3,
        /// Radius.
        radius: f32,
        /// Length along the axis.
        height: f32,
    },
    /// The inside of a triangle mesh, by its generalized winding number.
    Mesh(Box<MeshBody>),
}

impl Shape {
    /// Whether a point is inside the shape.
    pub fn contains(&self, point: Vec3) -> bool {
        match *self {
            Shape::Sphere { center, radius } => {
                (point - center).length_squared() <= radius * radius
            }
            Shape::Box { center, size } => ((point - center).abs() * 2.0).cmple(size).all(),
            Shape::Cylinder {
                center,
                axis,
                radius,
                height,
            } => {
                let offset = point - center;
                let along = offset.dot(axis);
                let across = offset - along * axis;
                along.abs() <= 0.5 * height && across.length_squared() <= radius * radius
            }
            Shape::Mesh(ref mesh) => mesh.contains(point),
        }
    }

    /// Axis-aligned bounding box as (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match *self {
            Shape::Sphere { center, radius } => (center - radius, center + radius),
            Shape::Box { center, size } => (center - 0.5 * size, center + 0.5 * size),
            Shape::Cylinder {
                center,
                axis,
                radius,
                height,
            } => {
                // Per axis: half the height projected, plus the disc's extent.
                let disc = (Vec3::ONE - axis * axis).max(Vec3::ZERO).powf(0.5) * radius;
                let half = (axis * 0.5 * height).abs() + disc;
                (center - half, center + half)
            }
            Shape::Mesh(ref mesh) => (mesh.min, mesh.max),
        }
    }
}

/// How a collider (or wall) treats snow that touches it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    /// Sticky, slip or separate.
    pub mode: ContactMode,
    /// Coulomb friction coefficient μ (thesis Quellcode 12).
    pub friction: f32,
}

impl Contact {
    /// The contact of walls and colliders when the scene gives none:
    /// [`ContactMode::Separate`] with friction μ = 0.2.
    pub const DEFAULT: Contact = Contact {
        mode: ContactMode::Separate,
        friction: 0.2,
    };

    /// A contact of the given mode and friction coefficient.
    pub fn new(mode: ContactMode, friction: f32) -> Contact {
        Contact { mode, friction }
    }

    /// [`ContactMode::Sticky`]: snow in contact moves with the surface (the
    /// friction, which sticky contact does not use, is the default 0.2).
    pub fn sticky() -> Contact {
        Contact::new(ContactMode::Sticky, Contact::DEFAULT.friction)
    }

    /// [`ContactMode::Slip`] with Coulomb friction `friction`.
    pub fn slip(friction: f32) -> Contact {
        Contact::new(ContactMode::Slip, friction)
    }

    /// [`ContactMode::Separate`] with Coulomb friction `friction`.
    pub fn separate(friction: f32) -> Contact {
        Contact::new(ContactMode::Separate, friction)
    }
}

impl Default for Contact {
    /// [`Contact::DEFAULT`]: separate, friction 0.2.
    fn default() -> Contact {
        Contact::DEFAULT
    }
}

/// Boundary condition applied to velocities relative to the collider.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ContactMode {
    /// Snow in contact moves with the collider.
    Sticky,
    /// The normal velocity is removed both ways; snow slides with friction but
    /// cannot leave the surface.
    Slip,
    /// The thesis' law: only approaching snow is stopped in the normal
    /// direction, with Coulomb friction on the tangential part; snow may leave.
    Separate,
}

/// A rigid obstacle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Collider {
    /// Geometry in the collider's own frame, placed at time zero.
    pub geometry: ColliderGeometry,
    /// How the geometry moves and turns ([`crate::scene::motion`]).
    pub motion: Motion,
    /// Contact behaviour.
    pub contact: Contact,
    /// Orientation about the reference point while the motion gives none
    /// (keyframes carry their own): a mesh's is in its placement instead.
    #[serde(default)]
    pub rotation: Quat,
}

impl Collider {
    /// A static collider of `geometry` with the default contact
    /// ([`Contact::default`]).
    pub fn new(geometry: ColliderGeometry) -> Collider {
        Collider {
            geometry,
            motion: Motion::Static,
            contact: Contact::default(),
            rotation: Quat::IDENTITY,
        }
    }

    /// The half-space below a plane through `point` (`shape = "plane"`);
    /// `normal` points into the free side and is normalised as in a scene
    /// file.
    pub fn plane(point: Vec3, normal: Vec3) -> Collider {
        Collider::new(ColliderGeometry::HalfPlane {
            point,
            normal: unit_or_zero(normal),
        })
    }

    /// A solid ball (`shape = "sphere"`).
    pub fn sphere(center: Vec3, radius: f32) -> Collider {
        Collider::new(ColliderGeometry::Sphere { center, radius })
    }

    /// A solid axis-aligned box (`shape = "box"`) with edge lengths `size`.
    pub fn cuboid(center: Vec3, size: Vec3) -> Collider {
        Collider::new(ColliderGeometry::Box { center, size })
    }

    /// A loaded triangle mesh (`shape = "mesh"`; see [`MeshCollider::load`]).
    pub fn mesh(mesh: MeshCollider) -> Collider {
        Collider::new(ColliderGeometry::Mesh(Box::new(mesh)))
    }

    /// A solid cylinder (`shape = "cylinder"`) of `radius` and `height`,
    /// its axis along y in its own frame (turn it with
    /// [`Collider::rotated`]).
    pub fn cylinder(center: Vec3, radius: f32, height: f32) -> Collider {
        Collider::new(ColliderGeometry::Cylinder {
            center,
            radius,
            height,
        })
    }

    /// Holds the collider at its starting pose from now on: no motion, and
    /// a deforming mesh keeps its first file.
    pub fn hold_still(&mut self) {
        let start = self.pose_at(0.0);
        self.motion = Motion::Static;
        self.rotation = start.rotation;
        self.geometry = self.geometry.moved_to(start.position);
        if let ColliderGeometry::MeshSequence(sequence) = &mut self.geometry {
            **sequence = sequence.first_frame_only();
        }
    }

    /// The same collider moving at a constant `velocity` (m/s), not
    /// turning.
    pub fn moving(self, velocity: Vec3) -> Collider {
        self.moving_and_spinning(velocity, Vec3::ZERO)
    }

    /// The same collider moving at a constant `velocity` (m/s) and turning
    /// at a constant `angular_velocity` (rad/s) about its reference point.
    pub fn moving_and_spinning(mut self, velocity: Vec3, angular_velocity: Vec3) -> Collider {
        self.motion = Motion::Linear {
            velocity,
            angular_velocity,
        };
        self
    }

    /// The same collider turned to `rotation` about its reference point.
    pub fn rotated(mut self, rotation: Quat) -> Collider {
        self.rotation = rotation;
        self
    }

    /// The same collider moving through keyframed poses of its reference
    /// point (at least two, in strictly increasing time), straight from key
    /// to key.
    pub fn keyframed(mut self, keys: impl IntoIterator<Item = Keyframe>) -> Collider {
        self.motion = Motion::Keyframed {
            keys: keys.into_iter().collect(),
            path: PathShape::Linear,
        };
        self
    }

    /// Where the collider is at time `t` and how it moves there.
    pub fn pose_at(&self, t: f64) -> Pose {
        self.motion
            .pose_at(self.geometry.reference_point(), self.rotation, t)
    }

    /// Whether the collider is ever turned or turning.
    pub fn turns(&self) -> bool {
        self.motion.turns(self.rotation)
    }

    /// The same collider with `contact`.
    pub fn contact(mut self, contact: Contact) -> Collider {
        self.contact = contact;
        self
    }

    /// The same collider with contact mode `mode` (its friction unchanged).
    pub fn mode(mut self, mode: ContactMode) -> Collider {
        self.contact.mode = mode;
        self
    }

    /// The same collider with Coulomb friction `friction` (its mode unchanged).
    pub fn friction(mut self, friction: f32) -> Collider {
        self.contact.friction = friction;
        self
    }
}

/// Collider geometry; snow is kept outside of it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "kebab-case")]
pub enum ColliderGeometry {
    /// Everything on the side opposite the normal is solid.
    HalfPlane {
        /// A point on the plane.
        point: Vec3,
        /// Unit normal pointing out of the solid, into the free side.
        normal: Vec3,
    },
    /// A solid ball.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
    },
    /// A solid axis-aligned box.
    Box {
        /// Centre.
        center: Vec3,
        /// Edge lengths along x, y, z.
        size: Vec3,
    },
    /// A solid cylinder whose axis is y in the collider's own frame.
    Cylinder {
        /// Centre (the middle of the axis).
        center: Vec3,
        /// Radius.
        radius: f32,
        /// Length along the axis.
        height: f32,
    },
    /// A solid capsule (a cylinder with hemispherical ends) whose axis is y
    /// in the collider's own frame.
    Capsule {
        /// Centre (the middle of the axis).
        center: Vec3,
        /// Radius of the cylinder and of its ends.
        radius: f32,
        /// Whole length along the axis, end to end (at least 2 radius).
        height: f32,
    },
    /// A solid triangle mesh, through its signed distance field.
    Mesh(Box<MeshCollider>),
    /// A triangle mesh that deforms, one file per frame; the solver samples
    /// each frame's distances when the run reaches it.
    MeshSequence(Box<MeshSequenceCollider>),
}

/// Per-particle attributes that caches can carry besides position.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Attribute {
    /// Velocity vector (m/s).
    Velocity,
    /// Plastic volume change J_P = det F_P (below 1: compacted).
    PlasticJ,
    /// Elastic volume change J_E = det F_E.
    ElasticJ,
    /// Current density m_p / V_p (kg/m³).
    Density,
    /// Particle mass (kg).
    Mass,
    /// Material index.
    Material,
}

/// Particle cache formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CacheFormat {
    /// Binary little-endian PLY point clouds (Blender, Houdini, MeshLab, ParaView).
    Ply,
    /// VTK XML PolyData (.vtp) with a .pvd time collection (ParaView).
    Vtk,
    /// OpenVDB volumes (.vdb): the snow's density, optionally its surface as a
    /// level set (Blender, Houdini); see [`VdbSettings`].
    Vdb,
    /// One USD stage per run (`particles.usda`, per-frame value clips in
    /// `usd/`): the particles as time-sampled points, and the colliders
    /// (Houdini, Omniverse, Blender).
    Usd,
    /// The snow's surface as a closed triangle mesh per frame, in binary PLY
    /// and OBJ (Blender, Houdini, MeshLab, ParaView); see [`MeshSettings`].
    Mesh,
}

/// The `[output.vdb]` table: how the `vdb` format turns particles into
/// volumes.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VdbSettings {
    /// Voxel edge length in metres; `None` uses the grid's `cell_size`.
    pub voxel_size: Option<f32>,
    /// Also write the snow's surface as a narrow-band level set (`surface`).
    pub level_set: bool,
}

impl VdbSettings {
    /// The voxel edge length for a scene whose grid cells are `cell_size`.
    pub fn voxel_size_for(&self, cell_size: f32) -> f32 {
        self.voxel_size.unwrap_or(cell_size)
    }
}

/// The `[output.mesh]` table: how the `mesh` format reconstructs the snow's
/// surface from its particles (the density on voxels, smoothed, and the
/// closed surface where it crosses a share of the rest density).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshSettings {
    /// Voxel edge length in metres; `None` uses the grid's `cell_size`.
    pub voxel_size: Option<f32>,
    /// Passes of a [1 2 1]/4 blur over the density along each axis before
    /// the surface is taken (0: none); each pass rounds off features of
    /// about a voxel.
    pub smoothing: u32,
    /// The surface is where the density crosses this share of the snow's
    /// rest density (between 0 and 1, exclusive).
    pub iso: f32,
}

impl MeshSettings {
    /// Blur passes when the scene gives none.
    pub const DEFAULT_SMOOTHING: u32 = 1;
    /// Iso share of the rest density when the scene gives none.
    pub const DEFAULT_ISO: f32 = 0.5;

    /// The voxel edge length for a scene whose grid cells are `cell_size`.
    pub fn voxel_size_for(&self, cell_size: f32) -> f32 {
        self.voxel_size.unwrap_or(cell_size)
    }
}

impl Default for MeshSettings {
    fn default() -> MeshSettings {
        MeshSettings {
            voxel_size: None,
            smoothing: MeshSettings::DEFAULT_SMOOTHING,
            iso: MeshSettings::DEFAULT_ISO,
        }
    }
}

/// What to write, and where.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutputSettings {
    /// Output directory (relative paths are relative to the working directory).
    pub directory: PathBuf,
    /// Cache formats written each frame.
    pub formats: Vec<CacheFormat>,
    /// Attributes written besides position.
    pub attributes: Vec<Attribute>,
    /// Write a checkpoint every this many frames (0: never).
    pub checkpoint_every: u32,
    /// How the `vdb` format makes its volumes.
    pub vdb: VdbSettings,
    /// How the `mesh` format makes the snow's surface.
    pub mesh: MeshSettings,
}

impl OutputSettings {
    /// Checkpoint interval in frames when the scene gives none
    /// (`output.checkpoint_every`).
    pub const DEFAULT_CHECKPOINT_EVERY: u32 = 10;

    /// The output of a snow scene named `name` when the scene gives none:
    /// directory `out/<name>` ([`OutputSettings::default_directory`]), PLY
    /// and VTK caches, the attributes of
    /// [`OutputSettings::default_attributes`] for snow, and a checkpoint
    /// every 10 frames.
    pub fn for_scene(name: &str) -> OutputSettings {
        OutputSettings {
            directory: OutputSettings::default_directory(name),
            formats: vec![CacheFormat::Ply, CacheFormat::Vtk],
            attributes: OutputSettings::default_attributes(&SceneKind::Snow),
            checkpoint_every: OutputSettings::DEFAULT_CHECKPOINT_EVERY,
            vdb: VdbSettings::default(),
            mesh: MeshSettings::default(),
        }
    }

    /// The output directory of a scene named `name`: `out/<name>`, relative
    /// to the working directory.
    pub fn default_directory(name: &str) -> PathBuf {
        PathBuf::from("out").join(name)
    }

    /// The attributes written when the scene names none: velocity, J_P and
    /// density for snow; velocity for a flow (its particles carry nothing
    /// else).
    pub fn default_attributes(kind: &SceneKind) -> Vec<Attribute> {
        match kind {
            SceneKind::Snow => vec![Attribute::Velocity, Attribute::PlasticJ, Attribute::Density],
            SceneKind::Flow(_) => vec![Attribute::Velocity],
        }
    }
}

impl Default for OutputSettings {
    /// [`OutputSettings::for_scene`] of [`Scene::DEFAULT_NAME`]: `out/scene`.
    fn default() -> OutputSettings {
        OutputSettings::for_scene(Scene::DEFAULT_NAME)
    }
}

impl ColliderGeometry {
    /// The point that moves with the collider: the plane point or the centre.
    pub fn reference_point(&self) -> Vec3 {
        match *self {
            ColliderGeometry::HalfPlane { point, .. } => point,
            ColliderGeometry::Sphere { center, .. }
            | ColliderGeometry::Box { center, .. }
            | ColliderGeometry::Cylinder { center, .. }
            | ColliderGeometry::Capsule { center, .. } => center,
            ColliderGeometry::Mesh(ref mesh) => mesh.center,
            ColliderGeometry::MeshSequence(ref sequence) => sequence.reference_point(),
        }
    }

    /// How far the solid reaches from its reference point (infinite for a
    /// plane): the radius of its rim when it turns.
    pub fn reach(&self) -> f32 {
        match *self {
            ColliderGeometry::HalfPlane { .. } => f32::INFINITY,
            ColliderGeometry::Sphere { radius, .. } => radius,
            ColliderGeometry::Box { size, .. } => 0.5 * size.length(),
            ColliderGeometry::Cylinder { radius, height, .. } => radius.hypot(0.5 * height),
            ColliderGeometry::Capsule { height, .. } => 0.5 * height,
            ColliderGeometry::Mesh(ref mesh) => reach_of(mesh.bounds(), mesh.center),
            ColliderGeometry::MeshSequence(ref sequence) => {
                reach_of(sequence.bounds(), sequence.reference_point())
            }
        }
    }

    /// The same geometry with its reference point moved to `position`.
    pub fn moved_to(&self, position: Vec3) -> ColliderGeometry {
        let mut moved = self.clone();
        match &mut moved {
            ColliderGeometry::HalfPlane { point, .. } => *point = position,
            ColliderGeometry::Sphere { center, .. }
            | ColliderGeometry::Box { center, .. }
            | ColliderGeometry::Cylinder { center, .. }
            | ColliderGeometry::Capsule { center, .. } => *center = position,
            ColliderGeometry::Mesh(mesh) => mesh.center = position,
            // A sequence moves by its files only (the format refuses
            // motion for it), so its reference point never changes.
            ColliderGeometry::MeshSequence(_) => {}
        }
        moved
    }

    /// Signed distance (negative inside the solid) and outward unit normal at `point`.
    #[inline]
    pub fn signed_distance(&self, point: Vec3) -> (f32, Vec3) {
        match *self {
            ColliderGeometry::HalfPlane {
                point: origin,
                normal,
            } => ((point - origin).dot(normal), normal),
            ColliderGeometry::Sphere { center, radius } => {
                let offset = point - center;
                let length = offset.length();
                let normal = if length > 0.0 {
                    offset / length
                } else {
                    Vec3::Y
                };
                (length - radius, normal)
            }
            ColliderGeometry::Box { center, size } => {
                box_signed_distance(point - center, 0.5 * size)
            }
            ColliderGeometry::Cylinder {
                center,
                radius,
                height,
            } => cylinder_signed_distance(point - center, radius, 0.5 * height),
            ColliderGeometry::Capsule {
                center,
                radius,
                height,
            } => capsule_signed_distance(point - center, radius, 0.5 * height - radius),
            ColliderGeometry::Mesh(ref mesh) => mesh.signed_distance(point),
            // Without a time the deforming surface is nowhere: the solver
            // reads it through the narrow-band fields of its frames.
            ColliderGeometry::MeshSequence(_) => (f32::INFINITY, Vec3::Y),
        }
    }
}

/// How far a box reaches from a point inside it.
fn reach_of((low, high): (Vec3, Vec3), center: Vec3) -> f32 {
    (low - center).abs().max((high - center).abs()).length()
}

/// Signed distance and outward normal of an axis-aligned box centred at the origin.
#[inline]
fn box_signed_distance(p: Vec3, half: Vec3) -> (f32, Vec3) {
    let q = p.abs() - half;
    if q.max_element() > 0.0 {
        let outside = q.max(Vec3::ZERO);
        let length = outside.length();
        (length, (outside * p.signum()) / length)
    } else {
        // Inside: the nearest face is the one with the largest (least negative) q.
        let axis = if q.x >= q.y && q.x >= q.z {
            0
        } else if q.y >= q.z {
            1
        } else {
            2
        };
        let mut normal = Vec3::ZERO;
        normal[axis] = p[axis].signum();
        (q[axis], normal)
    }
}

/// Signed distance and outward normal of a capsule about the origin whose
/// axis segment runs along y from −`half_segment` to `half_segment`.
#[inline]
fn capsule_signed_distance(p: Vec3, radius: f32, half_segment: f32) -> (f32, Vec3) {
    let offset = p - Vec3::new(0.0, p.y.clamp(-half_segment, half_segment), 0.0);
    let length = offset.length();
    let normal = if length > 0.0 {
        offset / length
    } else {
        Vec3::X
    };
    (length - radius, normal)
}

/// Signed distance and outward normal of a cylinder centred at the origin,
/// its axis along y, of `radius` and half length `half_height`.
#[inline]
fn cylinder_signed_distance(p: Vec3, radius: f32, half_height: f32) -> (f32, Vec3) {
    let across = (p.x * p.x + p.z * p.z).sqrt();
    let outward = if across > 0.0 {
        Vec3::new(p.x / across, 0.0, p.z / across)
    } else {
        Vec3::X
    };
    let along = if p.y >= 0.0 { Vec3::Y } else { Vec3::NEG_Y };
    let (side, cap) = (across - radius, p.y.abs() - half_height);
    if side > 0.0 || cap > 0.0 {
        let (side, cap) = (side.max(0.0), cap.max(0.0));
        let length = (side * side + cap * cap).sqrt();
        (length, (outward * side + along * cap) / length)
    } else if side >= cap {
        (side, outward)
    } else {
        (cap, along)
    }
}
