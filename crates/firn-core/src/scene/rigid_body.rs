//! Rigid bodies (`[[rigid_bodies]]`): solids that fall, tumble and collide
//! with each other and with the colliders under rapier (crates/firn-rigid),
//! while the snow pushes them and they push the snow (the two-way coupling
//! in firn-mpm's grid update, docs/architecture.md).

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

use super::model::{ColliderGeometry, Contact, ContactMode};

/// A solid body the snow and the other solids move.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RigidBody {
    /// The body's shape at its starting position: a sphere, box, cylinder or
    /// capsule in the body's own frame (axes along x, y, z, a cylinder's and
    /// a capsule's along y), or a mesh placed with its starting rotation
    /// already applied (its signed distance field is sampled so).
    pub geometry: ColliderGeometry,
    /// How the solid of a mesh body meets other solids.
    pub solid: MeshSolid,
    /// Orientation at the start, about the reference point.
    pub rotation: Quat,
    /// How heavy it is.
    pub mass: BodyMass,
    /// Velocity of the reference point at the start, m/s.
    pub velocity: Vec3,
    /// Angular velocity at the start, rad/s.
    pub angular_velocity: Vec3,
    /// How it meets the snow; its friction acts against other solids too.
    pub contact: Contact,
    /// Coefficient of restitution against other solids (0: no bounce).
    pub restitution: f32,
}

/// A rigid body's mass, given directly or through its density.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BodyMass {
    /// Density, kg/m³: the mass and inertia follow from the solid's volume.
    Density(f32),
    /// Mass, kg: the inertia is the solid's at uniform density.
    Mass(f32),
}

/// The solid that stands for a mesh body against other solids (the snow
/// always meets the mesh itself, through its signed distance field).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MeshSolid {
    /// The mesh's convex hull.
    #[default]
    Hull,
    /// A decomposition of the mesh into convex pieces (for concave shapes).
    Decomposition,
}

impl RigidBody {
    /// The density a body has when given none, kg/m³ (wood).
    pub const DEFAULT_DENSITY: f32 = 500.0;

    /// The contact a body has with the snow when given none: separating,
    /// with the friction of wood on snow.
    pub fn default_contact() -> Contact {
        Contact::new(ContactMode::Separate, 0.3)
    }

    /// A body of `geometry`, at rest and unturned, of the default density
    /// and contact, not bouncing.
    pub fn new(geometry: ColliderGeometry) -> RigidBody {
        RigidBody {
            geometry,
            solid: MeshSolid::default(),
            rotation: Quat::IDENTITY,
            mass: BodyMass::Density(RigidBody::DEFAULT_DENSITY),
            velocity: Vec3::ZERO,
            angular_velocity: Vec3::ZERO,
            contact: RigidBody::default_contact(),
            restitution: 0.0,
        }
    }

    /// A solid ball.
    pub fn sphere(center: Vec3, radius: f32) -> RigidBody {
        RigidBody::new(ColliderGeometry::Sphere { center, radius })
    }

    /// A solid box with edges `size` along its own axes.
    pub fn cuboid(center: Vec3, size: Vec3) -> RigidBody {
        RigidBody::new(ColliderGeometry::Box { center, size })
    }

    /// The same body with density `density`, kg/m³.
    pub fn density(mut self, density: f32) -> RigidBody {
        self.mass = BodyMass::Density(density);
        self
    }

    /// The same body with mass `mass`, kg.
    pub fn mass(mut self, mass: f32) -> RigidBody {
        self.mass = BodyMass::Mass(mass);
        self
    }

    /// The same body turned by `rotation` at the start (not for a mesh,
    /// whose placement carries its rotation).
    pub fn rotated(mut self, rotation: Quat) -> RigidBody {
        self.rotation = rotation;
        self
    }

    /// The same body moving at `velocity` (m/s) and turning at
    /// `angular_velocity` (rad/s) at the start.
    pub fn moving(mut self, velocity: Vec3, angular_velocity: Vec3) -> RigidBody {
        self.velocity = velocity;
        self.angular_velocity = angular_velocity;
        self
    }

    /// The same body with contact `contact` against the snow.
    pub fn contact(mut self, contact: Contact) -> RigidBody {
        self.contact = contact;
        self
    }

    /// The point the body's position names: the centre of its shape (for a
    /// mesh, of its bounding box at the start).
    pub fn reference_point(&self) -> Vec3 {
        self.geometry.reference_point()
    }

    /// The rotation the geometry's own frame already carries: a mesh's
    /// starting rotation, which its field was sampled with; none for the
    /// other shapes. A body turned to `rotation` reads its geometry turned
    /// by `rotation · baked⁻¹`.
    pub fn baked_rotation(&self) -> Quat {
        match self.geometry {
            ColliderGeometry::Mesh(_) => self.rotation,
            _ => Quat::IDENTITY,
        }
    }
}
