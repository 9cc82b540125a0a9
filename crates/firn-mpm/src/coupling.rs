//! Two-way coupling with rigid bodies (`[[rigid_bodies]]`, simulated by
//! rapier in firn-rigid): the impulse exchange through the grid of Hu et
//! al. 2018 (MLS-MPM, section 4, two-way rigid coupling).
//!
//! In the grid update every body is a collider placed where it is at the
//! start of the substep, moving at v + ω × (x − c) with its contact mode
//! and friction ([`crate::contact`]). Where a body changes a node's
//! velocity from v_i to v_i', the node's snow gains the momentum
//! Δp_i = m_i (v_i' − v_i); the body gets −Σ Δp_i and the angular impulse
//! −Σ (x_i − c) × Δp_i about its centre of mass c, and rapier steps it by
//! the same Δt with them. What the snow gains the body loses, node by node,
//! so linear and angular momentum are kept exactly by the exchange (the
//! transfers, APIC, keep them too). The sums are 64-bit fixed point
//! ([`FIXED_SCALE`]), so they are the same for any thread count, block
//! order or split between processes. In a run split between processes
//! every part holds the bodies whole: each sums the nodes it counts
//! ([`NodeOwners`]), the parts add their sums up (integers, so in any
//! order), and each steps its copy of rapier's world with the same sums.

use firn_core::scene::{Collider, RigidBody, Scene};
use firn_rigid::{BodyImpulse, BodyState, RigidError, RigidWorld};
use glam::{DVec3, IVec3, Vec3};

use crate::block_sums::NodeOwners;
use crate::contact::{PlacedCollider, Spin};

/// Fixed-point units per N s of the impulse sums: a resolution of
/// 2.3e-10 N s and a range of ±2.1e9 N s.
pub const FIXED_SCALE: f64 = 4_294_967_296.0;

/// One body's momentum exchange with the snow in a substep, summed in
/// fixed point: the snow's Δp and its moment about the body's centre of
/// mass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ImpulseSum {
    /// Σ Δp_i, in units of 1 / [`FIXED_SCALE`] N s.
    pub linear: [i64; 3],
    /// Σ (x_i − c) × Δp_i, in units of 1 / [`FIXED_SCALE`] N m s.
    pub angular: [i64; 3],
}

impl ImpulseSum {
    /// Adds a node's Δp at arm `arm` from the centre of mass.
    fn add(&mut self, momentum: Vec3, arm: Vec3) {
        let moment = arm.cross(momentum);
        for axis in 0..3 {
            self.linear[axis] = self.linear[axis].wrapping_add(to_fixed(momentum[axis]));
            self.angular[axis] = self.angular[axis].wrapping_add(to_fixed(moment[axis]));
        }
    }

    /// Adds another sum (exact and order-free: integers).
    pub fn merge(&mut self, other: &ImpulseSum) {
        for axis in 0..3 {
            self.linear[axis] = self.linear[axis].wrapping_add(other.linear[axis]);
            self.angular[axis] = self.angular[axis].wrapping_add(other.angular[axis]);
        }
    }

    /// The impulse on the body: the opposite of what the snow gained.
    pub fn on_body(&self) -> BodyImpulse {
        let value = |words: [i64; 3]| {
            -Vec3::new(
                (words[0] as f64 / FIXED_SCALE) as f32,
                (words[1] as f64 / FIXED_SCALE) as f32,
                (words[2] as f64 / FIXED_SCALE) as f32,
            )
        };
        BodyImpulse {
            linear: value(self.linear),
            angular: value(self.angular),
        }
    }

    /// The snow's momentum gain, N s.
    pub fn snow_momentum(&self) -> DVec3 {
        DVec3::from_array(self.linear.map(|word| word as f64 / FIXED_SCALE))
    }
}

/// A value in fixed point, rounded to nearest.
fn to_fixed(value: f32) -> i64 {
    (f64::from(value) * FIXED_SCALE).round() as i64
}

/// A body as the grid meets it in one substep.
#[derive(Clone, Debug)]
pub struct PlacedBody {
    /// The body as a collider placed where it is at the start of the
    /// substep, always with a [`Spin`]: its reference point moves at
    /// v + ω × (x − c) and it turns at ω.
    pub collider: PlacedCollider,
    /// Its centre of mass c, about which the moments of the exchange are
    /// taken.
    pub center_of_mass: Vec3,
    /// The ball around the reference point that holds the whole body:
    /// nodes outside it are never touched.
    pub reach: f32,
}

/// The bodies as the grid meets them in one substep.
#[derive(Clone, Debug, Default)]
pub struct BodyContacts {
    bodies: Vec<PlacedBody>,
    /// In a part of a split run, which nodes this part counts in the sums
    /// (each node in one part only); `None` counts every node.
    owners: Option<NodeOwners>,
}

impl BodyContacts {
    /// Whether there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.bodies.len()
    }

    /// These contacts in a part of a split run, which adds to the sums only
    /// the nodes `owners` says it counts (the other parts, which hold the
    /// same nodes with the same sums, add the rest).
    pub fn counted_by(self, owners: NodeOwners) -> BodyContacts {
        BodyContacts {
            owners: Some(owners),
            ..self
        }
    }

    /// The bodies, in scene order (for a backend that meets them itself,
    /// such as the GPU's grid update).
    pub fn bodies(&self) -> &[PlacedBody] {
        &self.bodies
    }

    /// The bodies that may touch a node in the box from `low` to `high`
    /// (a grid block's nodes), in body order.
    pub fn near(&self, low: Vec3, high: Vec3) -> Vec<usize> {
        (0..self.bodies.len())
            .filter(|&index| {
                let body = &self.bodies[index];
                let center = body.collider.geometry.reference_point();
                let nearest = center.clamp(low, high);
                (nearest - center).length_squared() <= body.reach * body.reach
            })
            .collect()
    }

    /// Applies the contact of the bodies `near` (from [`BodyContacts::near`])
    /// to the velocity `velocity` of grid node `node` at `point` with snow
    /// mass `mass`, adding each body's exchange to its sum in `sums` where
    /// this part counts the node.
    #[inline]
    pub fn collide(
        &self,
        near: &[usize],
        (node, point): (IVec3, Vec3),
        mass: f32,
        mut velocity: Vec3,
        sums: &mut [ImpulseSum],
    ) -> Vec3 {
        for &index in near {
            let body = &self.bodies[index];
            let collided = body.collider.collide(point, velocity);
            if collided != velocity {
                if self.counts(node) {
                    sums[index].add(mass * (collided - velocity), point - body.center_of_mass);
                }
                velocity = collided;
            }
        }
        velocity
    }

    /// Whether this part counts grid node `node` in the sums.
    fn counts(&self, node: IVec3) -> bool {
        self.owners
            .as_ref()
            .is_none_or(|owners| owners.counts(node))
    }
}

/// The scene's rigid bodies: rapier's world, and what the grid needs to
/// meet each.
#[derive(Clone, Debug)]
pub struct RigidBodies {
    world: RigidWorld,
    /// The bodies' states as rapier has them now (read once per step).
    states: Vec<BodyState>,
    bodies: Vec<RigidBody>,
    /// Σ of the linear impulse the snow gave each body since these were
    /// made (from the scene or a snapshot), N s.
    pushed: Vec<DVec3>,
}

impl RigidBodies {
    /// The bodies of `scene` at their start, or `None` if it has none.
    pub fn new(scene: &Scene) -> Result<Option<RigidBodies>, RigidError> {
        if scene.rigid_bodies.is_empty() {
            return Ok(None);
        }
        let world = RigidWorld::new(scene)?;
        Ok(Some(RigidBodies {
            states: world.states(),
            world,
            bodies: scene.rigid_bodies.clone(),
            pushed: vec![DVec3::ZERO; scene.rigid_bodies.len()],
        }))
    }

    /// The bodies of `scene` as saved by [`RigidBodies::to_bytes`].
    pub fn from_bytes(scene: &Scene, bytes: &[u8]) -> Result<RigidBodies, RigidError> {
        let world = RigidWorld::from_bytes(scene, bytes)?;
        Ok(RigidBodies {
            states: world.states(),
            world,
            bodies: scene.rigid_bodies.clone(),
            pushed: vec![DVec3::ZERO; scene.rigid_bodies.len()],
        })
    }

    /// Adds `body` at its start, from the next substep on.
    pub fn add(&mut self, body: &RigidBody) -> Result<(), RigidError> {
        self.world.add(body)?;
        self.states = self.world.states();
        self.bodies.push(body.clone());
        self.pushed.push(DVec3::ZERO);
        Ok(())
    }

    /// The whole state, for a snapshot.
    pub fn to_bytes(&self) -> Vec<u8> {
        self.world.to_bytes()
    }

    /// Every body's state, in scene order.
    pub fn states(&self) -> Vec<BodyState> {
        self.states.clone()
    }

    /// The linear impulse the snow gave each body since these were made
    /// (from the scene or a snapshot), N s, in scene order.
    pub fn pushed(&self) -> &[DVec3] {
        &self.pushed
    }

    /// The bodies placed where they are now, as the grid meets them.
    pub fn contacts(&self) -> BodyContacts {
        let bodies = self
            .bodies
            .iter()
            .zip(&self.states)
            .map(|(body, state)| {
                let rotation = state.rotation * body.baked_rotation().inverse();
                let placed = PlacedCollider {
                    geometry: body.geometry.moved_to(state.position),
                    velocity: state.velocity_at(state.position),
                    contact: body.contact,
                    spin: Some(Spin {
                        center: state.position,
                        rotation,
                        inverse: rotation.inverse(),
                        angular_velocity: state.angular_velocity,
                    }),
                    surface: None,
                };
                PlacedBody {
                    collider: placed,
                    center_of_mass: state.center_of_mass,
                    reach: body.geometry.reach(),
                }
            })
            .collect();
        BodyContacts {
            bodies,
            owners: None,
        }
    }

    /// The fastest any body's material moves: |v| + |ω| times its reach
    /// from the centre of mass, m/s (what the next Δt must follow too).
    pub fn max_speed(&self) -> f32 {
        self.bodies
            .iter()
            .zip(&self.states)
            .map(|(body, state)| {
                let reach =
                    body.geometry.reach() + (state.center_of_mass - state.position).length();
                state.velocity.length() + state.angular_velocity.length() * reach
            })
            .fold(0.0, f32::max)
    }

    /// Applies what the snow gave each body during a substep of length
    /// `dt` and steps the bodies (and the moving `colliders`, placed at
    /// `time_end`) by it.
    pub fn advance(&mut self, sums: &[ImpulseSum], dt: f32, colliders: &[Collider], time_end: f64) {
        for (pushed, sum) in self.pushed.iter_mut().zip(sums) {
            *pushed -= sum.snow_momentum();
        }
        let impulses: Vec<BodyImpulse> = sums.iter().map(ImpulseSum::on_body).collect();
        self.world.step(&impulses, dt, colliders, time_end);
        self.states = self.world.states();
    }
}
