//! The scene model: plain data a program can build in code or load from a
//! scene file with [`Scene::load`](crate::Scene::load).
//!
//! Units are SI throughout: metres, seconds, kilograms, pascals.

use std::path::PathBuf;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::compute::ComputeSettings;
use super::flow::SceneKind;
use super::material::Material;
use super::mesh::{MeshBody, MeshCollider};
use super::render::{Camera, RenderSettings};

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
}

impl TimeSettings {
    /// Number of output frames after the initial state (frame 0).
    pub fn frame_count(&self) -> u32 {
        (self.duration * self.fps - 1e-9).ceil().max(0.0) as u32
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

/// How particle and grid momentum are exchanged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Transfer {
    /// PIC/FLIP blend with cubic B-splines, as in Stomakhin et al. 2013 and the thesis.
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

/// How the grid velocities v_i^{n+1} are computed from the grid forces.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Integrator {
    /// Forward (symplectic) Euler: v_i^{n+1} = v_i* (the thesis; step 6 skipped).
    /// Δt must resolve the elastic waves.
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
    /// Geometry at time zero.
    pub geometry: ColliderGeometry,
    /// How the geometry moves.
    pub motion: Motion,
    /// Contact behaviour.
    pub contact: Contact,
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
    /// A solid triangle mesh, through its signed distance field.
    Mesh(Box<MeshCollider>),
}

/// How a collider moves; its reference point is the plane point or centre.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Motion {
    /// Does not move.
    Static,
    /// Moves with a constant velocity.
    Linear {
        /// Velocity in m/s.
        velocity: Vec3,
    },
    /// Moves through keyframed positions of its reference point, linearly
    /// interpolated; it rests at the first and last key outside their times.
    Keyframed {
        /// Keys sorted by strictly increasing time.
        keys: Vec<Keyframe>,
    },
}

/// A keyframe of a moving collider.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Keyframe {
    /// Time in seconds.
    pub time: f64,
    /// Position of the collider's reference point at that time.
    pub position: Vec3,
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
}

impl Motion {
    /// Position and velocity of a reference point that starts at `start`, at time `t`.
    pub fn state_at(&self, start: Vec3, t: f64) -> (Vec3, Vec3) {
        match self {
            Motion::Static => (start, Vec3::ZERO),
            Motion::Linear { velocity } => (start + *velocity * t as f32, *velocity),
            Motion::Keyframed { keys } => keyframe_state(keys, t),
        }
    }
}

/// Piecewise-linear position through the keys and the velocity of the current segment.
fn keyframe_state(keys: &[Keyframe], t: f64) -> (Vec3, Vec3) {
    let (Some(first), Some(last)) = (keys.first(), keys.last()) else {
        return (Vec3::ZERO, Vec3::ZERO);
    };
    if t <= first.time {
        return (first.position, Vec3::ZERO);
    }
    if t >= last.time {
        return (last.position, Vec3::ZERO);
    }
    let next = keys.partition_point(|key| key.time <= t);
    let (a, b) = (keys[next - 1], keys[next]);
    let span = (b.time - a.time) as f32;
    let s = ((t - a.time) / (b.time - a.time)) as f32;
    let velocity = (b.position - a.position) / span;
    (a.position.lerp(b.position, s), velocity)
}

impl ColliderGeometry {
    /// The point that moves with the collider: the plane point or the centre.
    pub fn reference_point(&self) -> Vec3 {
        match *self {
            ColliderGeometry::HalfPlane { point, .. } => point,
            ColliderGeometry::Sphere { center, .. } | ColliderGeometry::Box { center, .. } => {
                center
            }
            ColliderGeometry::Mesh(ref mesh) => mesh.center,
        }
    }

    /// The same geometry with its reference point moved to `position`.
    pub fn moved_to(&self, position: Vec3) -> ColliderGeometry {
        let mut moved = self.clone();
        match &mut moved {
            ColliderGeometry::HalfPlane { point, .. } => *point = position,
            ColliderGeometry::Sphere { center, .. } | ColliderGeometry::Box { center, .. } => {
                *center = position
            }
            ColliderGeometry::Mesh(mesh) => mesh.center = position,
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
            ColliderGeometry::Mesh(ref mesh) => mesh.signed_distance(point),
        }
    }
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
