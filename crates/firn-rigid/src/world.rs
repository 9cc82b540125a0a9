//! A scene's rigid bodies, colliders and walls in one rapier world.

use firn_core::scene::{BodyMass, Collider, ColliderGeometry, Motion, RigidBody, Scene};
use glam::{Mat3, Quat, Vec3};
use rapier3d::prelude::{
    ColliderBuilder, PhysicsWorld, RigidBodyBuilder, RigidBodyHandle, RigidBodyType,
};

use crate::convert::{from_rapier, pose, rotation_from_rapier, to_rapier};
use crate::shapes::{MeshAs, collider_shape};

/// Why a rigid world cannot be made or restored.
#[derive(Debug, thiserror::Error)]
pub enum RigidError {
    /// A mesh body or collider cannot become a rapier shape.
    #[error("{0}")]
    Mesh(String),
    /// A saved world does not fit this scene.
    #[error("the saved rigid bodies cannot be restored: {0}")]
    State(String),
}

/// A body's state at an instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyState {
    /// The reference point (the centre of the body's shape as the scene
    /// gave it), m.
    pub position: Vec3,
    /// Orientation, as the scene's `rotation` at the start.
    pub rotation: Quat,
    /// Velocity of the centre of mass, m/s.
    pub velocity: Vec3,
    /// Angular velocity, rad/s.
    pub angular_velocity: Vec3,
    /// Centre of mass, m.
    pub center_of_mass: Vec3,
    /// Mass, kg.
    pub mass: f32,
    /// Inertia tensor about the centre of mass, in world axes, kg m².
    pub inertia: Mat3,
}

impl BodyState {
    /// Velocity of the body's material at `point`: v + ω × (x − c).
    pub fn velocity_at(&self, point: Vec3) -> Vec3 {
        self.velocity + self.angular_velocity.cross(point - self.center_of_mass)
    }

    /// Linear momentum m v, N s.
    pub fn momentum(&self) -> Vec3 {
        self.mass * self.velocity
    }

    /// Angular momentum about the origin, c × m v + I ω, N m s.
    pub fn angular_momentum(&self) -> Vec3 {
        self.center_of_mass.cross(self.momentum()) + self.inertia * self.angular_velocity
    }
}

/// What the snow gave a body in one substep: a linear impulse and an
/// angular impulse about the body's centre of mass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BodyImpulse {
    /// N s.
    pub linear: Vec3,
    /// N m s.
    pub angular: Vec3,
}

/// The rigid bodies of a scene with its colliders and the domain walls,
/// simulated by rapier.
pub struct RigidWorld {
    physics: PhysicsWorld,
    /// One handle per scene rigid body, in scene order.
    bodies: Vec<RigidBodyHandle>,
    /// The scene colliders that move, each with its kinematic body.
    movers: Vec<(usize, RigidBodyHandle)>,
}

impl Clone for RigidWorld {
    /// A copy through the saved state (rapier's world is not `Clone`),
    /// which holds everything its steps read.
    fn clone(&self) -> RigidWorld {
        RigidWorld::from_saved(&self.to_bytes()).expect("a world reads back what it saved")
    }
}

impl std::fmt::Debug for RigidWorld {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RigidWorld")
            .field("bodies", &self.bodies.len())
            .field("movers", &self.movers.len())
            .finish()
    }
}

impl RigidWorld {
    /// The scene's rigid bodies at their start, its colliders at time zero
    /// and the six domain walls, under the scene's gravity.
    pub fn new(scene: &Scene) -> Result<RigidWorld, RigidError> {
        let mut world = RigidWorld {
            physics: PhysicsWorld::new(),
            bodies: Vec::new(),
            movers: Vec::new(),
        };
        world.physics.gravity = to_rapier(scene.solver.gravity);
        for body in &scene.rigid_bodies {
            let handle = world.add_body(body)?;
            world.bodies.push(handle);
        }
        for (index, collider) in scene.colliders.iter().enumerate() {
            world.add_collider(index, collider)?;
        }
        world.add_walls(scene);
        Ok(world)
    }

    fn add_body(&mut self, body: &RigidBody) -> Result<RigidBodyHandle, RigidError> {
        let rigid = RigidBodyBuilder::dynamic()
            .pose(pose(body.reference_point(), body.rotation))
            .linvel(to_rapier(body.velocity))
            .angvel(to_rapier(body.angular_velocity))
            .can_sleep(false)
            .ccd_enabled(true)
            .build();
        let handle = self.physics.bodies.insert(rigid);
        let shape = collider_shape(&body.geometry, body.rotation, MeshAs::Body(body.solid))?
            .ok_or_else(|| RigidError::Mesh("a deforming mesh cannot be a rigid body".into()))?;
        let shape = match body.mass {
            BodyMass::Density(density) => shape.density(density),
            BodyMass::Mass(mass) => shape.mass(mass),
        };
        self.attach(
            shape
                .friction(body.contact.friction)
                .restitution(body.restitution),
            handle,
        );
        Ok(handle)
    }

    /// A scene collider: fixed where it never moves, else a kinematic body
    /// that [`RigidWorld::step`] moves along its motion.
    fn add_collider(&mut self, index: usize, collider: &Collider) -> Result<(), RigidError> {
        let start = collider.pose_at(0.0);
        let Some(shape) = collider_shape(&collider.geometry, Quat::IDENTITY, MeshAs::Triangles)?
        else {
            return Ok(());
        };
        let kind = match collider.motion {
            Motion::Static => RigidBodyType::Fixed,
            _ => RigidBodyType::KinematicPositionBased,
        };
        let position = match collider.geometry {
            ColliderGeometry::Mesh(ref mesh) => mesh.placement.center,
            _ => start.position,
        };
        let rigid = RigidBodyBuilder::new(kind)
            .pose(pose(position, start.rotation))
            .build();
        let handle = self.physics.bodies.insert(rigid);
        self.attach(shape.friction(collider.contact.friction), handle);
        if kind != RigidBodyType::Fixed {
            self.movers.push((index, handle));
        }
        Ok(())
    }

    /// The six faces of the domain box, facing in.
    fn add_walls(&mut self, scene: &Scene) {
        let domain = &scene.domain;
        for axis in 0..3 {
            let mut normal = Vec3::ZERO;
            normal[axis] = 1.0;
            for (point, normal) in [(domain.min, normal), (domain.max, -normal)] {
                let wall = ColliderGeometry::HalfPlane { point, normal };
                let rigid = RigidBodyBuilder::fixed()
                    .pose(pose(point, Quat::IDENTITY))
                    .build();
                let handle = self.physics.bodies.insert(rigid);
                let shape = collider_shape(&wall, Quat::IDENTITY, MeshAs::Triangles)
                    .ok()
                    .flatten()
                    .unwrap_or_else(|| ColliderBuilder::ball(0.0));
                self.attach(shape.friction(domain.walls.friction), handle);
            }
        }
    }

    fn attach(&mut self, shape: ColliderBuilder, body: RigidBodyHandle) {
        let physics = &mut self.physics;
        physics
            .colliders
            .insert_with_parent(shape.build(), body, &mut physics.bodies);
    }

    /// Adds `body` at its start (after the scene's: scene order is kept).
    pub fn add(&mut self, body: &RigidBody) -> Result<(), RigidError> {
        let handle = self.add_body(body)?;
        self.bodies.push(handle);
        Ok(())
    }

    /// Number of rigid bodies.
    pub fn len(&self) -> usize {
        self.bodies.len()
    }

    /// Whether the scene has no rigid bodies.
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }

    /// Every body's state, in scene order.
    pub fn states(&self) -> Vec<BodyState> {
        self.bodies
            .iter()
            .map(|&handle| {
                let body = &self.physics.bodies[handle];
                let rotation = rotation_from_rapier(*body.rotation());
                let turn = Mat3::from_quat(rotation);
                let local = body.mass_properties().local_mprops;
                let inertia = mat3_from_rapier(local.reconstruct_inertia_matrix());
                BodyState {
                    position: from_rapier(body.translation()),
                    rotation,
                    velocity: from_rapier(body.linvel()),
                    angular_velocity: from_rapier(body.angvel()),
                    center_of_mass: from_rapier(body.center_of_mass()),
                    mass: body.mass(),
                    inertia: turn * inertia * turn.transpose(),
                }
            })
            .collect()
    }

    /// One step of length `dt`: applies `impulses` (one per body, what the
    /// snow gave it during the substep), moves the moving `colliders` (the
    /// scene's) to their poses at `time_end`, then lets rapier integrate.
    pub fn step(
        &mut self,
        impulses: &[BodyImpulse],
        dt: f32,
        colliders: &[Collider],
        time_end: f64,
    ) {
        assert_eq!(impulses.len(), self.bodies.len(), "one impulse per body");
        for (&handle, impulse) in self.bodies.iter().zip(impulses) {
            let body = &mut self.physics.bodies[handle];
            body.apply_impulse(to_rapier(impulse.linear), true);
            body.apply_torque_impulse(to_rapier(impulse.angular), true);
        }
        for &(index, handle) in &self.movers {
            let collider = &colliders[index];
            let placed = collider.pose_at(time_end);
            let position = match collider.geometry {
                ColliderGeometry::Mesh(ref mesh) => {
                    placed.position - mesh.center + mesh.placement.center
                }
                _ => placed.position,
            };
            self.physics.bodies[handle]
                .set_next_kinematic_position(pose(position, placed.rotation));
        }
        self.physics.integration_parameters.dt = dt;
        self.physics.step();
    }

    /// The world's whole state, for a checkpoint.
    pub fn to_bytes(&self) -> Vec<u8> {
        bincode::serialize(&(&self.physics, &self.bodies, &self.movers))
            .expect("a rapier world serialises")
    }

    /// A world saved by [`RigidWorld::to_bytes`] for `scene`.
    pub fn from_bytes(scene: &Scene, bytes: &[u8]) -> Result<RigidWorld, RigidError> {
        let world = RigidWorld::from_saved(bytes)?;
        if world.bodies.len() != scene.rigid_bodies.len() {
            return Err(RigidError::State(format!(
                "it holds {} bodies and the scene {}",
                world.bodies.len(),
                scene.rigid_bodies.len()
            )));
        }
        Ok(world)
    }

    fn from_saved(bytes: &[u8]) -> Result<RigidWorld, RigidError> {
        let (physics, bodies, movers) =
            bincode::deserialize(bytes).map_err(|err| RigidError::State(err.to_string()))?;
        Ok(RigidWorld {
            physics,
            bodies,
            movers,
        })
    }
}

/// A rapier matrix as firn's.
fn mat3_from_rapier(m: rapier3d::prelude::Matrix) -> Mat3 {
    Mat3::from_cols_array(&m.to_cols_array())
}
