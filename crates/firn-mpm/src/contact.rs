//! Collisions with rigid bodies and the domain walls (thesis §3.4 steps 5
//! and 9, Quellcode 12), always relative to the collider's own velocity.

use firn_core::math::lanes::{F32s, Vec3s};
use firn_core::scene::{Collider, ColliderGeometry, Contact, ContactMode, Domain};
use glam::{Quat, Vec3, Vec3A};

mod deforming;

pub use deforming::DeformingSurface;
use deforming::SequenceCache;

/// New velocity of snow moving with `velocity` against a collider surface with
/// outward `normal` that itself moves with `collider_velocity`.
///
/// - sticky: the snow takes the collider's velocity;
/// - separate (the thesis' law): if the snow approaches (v_n < 0), its normal
///   velocity is removed and Coulomb friction acts on the tangential part:
///   it sticks if |v_t| ≤ −μ v_n, else v_t shrinks by −μ v_n; separating snow
///   is left alone;
/// - slip: like separate, but a separating normal velocity is removed too.
#[inline(always)]
pub fn apply_contact(
    velocity: Vec3,
    collider_velocity: Vec3,
    normal: Vec3,
    contact: Contact,
) -> Vec3 {
    contact_response(velocity, collider_velocity, normal, contact).0
}

/// [`apply_contact`], plus which velocity components the contact fixed: the
/// semi-implicit solve keeps those fixed ([`crate::implicit`]).
#[inline(always)]
pub fn contact_response(
    velocity: Vec3,
    collider_velocity: Vec3,
    normal: Vec3,
    contact: Contact,
) -> (Vec3, Constraint) {
    let relative = velocity - collider_velocity;
    let normal_speed = relative.dot(normal);
    let tangential = relative - normal * normal_speed;
    match contact.mode {
        ContactMode::Sticky => (collider_velocity, Constraint::Fixed),
        ContactMode::Separate if normal_speed >= 0.0 => (velocity, Constraint::Free),
        ContactMode::Slip if normal_speed >= 0.0 => {
            (collider_velocity + tangential, Constraint::Normal(normal))
        }
        ContactMode::Separate | ContactMode::Slip => {
            match with_friction(tangential, normal_speed, contact.friction) {
                Some(sliding) => (collider_velocity + sliding, Constraint::Normal(normal)),
                None => (collider_velocity, Constraint::Fixed),
            }
        }
    }
}

/// Coulomb friction on the tangential velocity for an approach speed
/// `normal_speed` < 0: the reduced tangential velocity, or `None` when
/// friction makes the snow stick.
#[inline(always)]
fn with_friction(tangential: Vec3, normal_speed: f32, friction: f32) -> Option<Vec3> {
    let length = tangential.length();
    let limit = -friction * normal_speed;
    (length > limit).then(|| tangential * (1.0 - limit / length))
}

/// The velocity components of a grid node that contacts fix; the rest are
/// free. Applied as an orthogonal projection P_i (Baraff and Witkin's filter),
/// so that the semi-implicit solve works on the free subspace only.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Constraint {
    /// No contact: every component is free.
    #[default]
    Free,
    /// The component along this unit normal is fixed.
    Normal(Vec3),
    /// Only the component along this unit direction is free (two contacts).
    Line(Vec3),
    /// Every component is fixed (sticky, sticking by friction, or no mass).
    Fixed,
}

impl Constraint {
    /// The constraint after a further contact fixes `other` as well.
    #[inline(always)]
    pub fn and(self, other: Constraint) -> Constraint {
        // Directions closer than this (|sin| of the angle) count as the same.
        const PARALLEL: f32 = 1e-3;
        match (self, other) {
            (Constraint::Free, c) | (c, Constraint::Free) => c,
            (Constraint::Fixed, _) | (_, Constraint::Fixed) => Constraint::Fixed,
            (Constraint::Normal(a), Constraint::Normal(b)) => {
                let free = a.cross(b);
                let length = free.length();
                if length < PARALLEL {
                    Constraint::Normal(a)
                } else {
                    Constraint::Line(free / length)
                }
            }
            (Constraint::Line(d), Constraint::Normal(n))
            | (Constraint::Normal(n), Constraint::Line(d)) => {
                if d.dot(n).abs() < PARALLEL {
                    Constraint::Line(d)
                } else {
                    Constraint::Fixed
                }
            }
            (Constraint::Line(_), Constraint::Line(_)) => Constraint::Fixed,
        }
    }

    /// P_i v: `velocity` with its fixed components removed.
    #[inline(always)]
    pub fn project(self, velocity: Vec3) -> Vec3 {
        match self {
            Constraint::Free => velocity,
            Constraint::Normal(n) => velocity - n * n.dot(velocity),
            Constraint::Line(d) => d * d.dot(velocity),
            Constraint::Fixed => Vec3::ZERO,
        }
    }
}

/// A collider at one instant: where it is and how fast it moves.
#[derive(Clone, Debug)]
pub struct PlacedCollider {
    /// Geometry at this instant, in the collider's own orientation (at its
    /// current reference point).
    pub geometry: ColliderGeometry,
    /// Velocity of the collider's reference point.
    pub velocity: Vec3,
    /// Contact behaviour.
    pub contact: Contact,
    /// How it is turned and turns, for a collider that does; `None` keeps
    /// the unturned arithmetic (and its bits) for every other.
    pub spin: Option<Spin>,
    /// The surface of a deforming mesh collider at this instant.
    pub surface: Option<DeformingSurface>,
}

/// The turn of a placed collider: a world point x is the geometry's point
/// c + R⁻¹ (x − c) (c the current reference point), and the collider moves
/// there at v + ω × (x − c).
#[derive(Clone, Copy, Debug)]
pub struct Spin {
    /// The reference point c.
    pub center: Vec3,
    /// R, from the collider's frame to the world's.
    pub rotation: Quat,
    /// R⁻¹.
    pub inverse: Quat,
    /// ω, rad/s.
    pub angular_velocity: Vec3,
}

impl PlacedCollider {
    /// Applies the contact law if `point` is inside (or on) the collider.
    #[inline(always)]
    pub fn collide(&self, point: Vec3, velocity: Vec3) -> Vec3 {
        self.collide_constrained(point, velocity).0
    }

    /// [`PlacedCollider::collide`], plus the components the contact fixed.
    #[inline(always)]
    pub fn collide_constrained(&self, point: Vec3, velocity: Vec3) -> (Vec3, Constraint) {
        if let Some(spin) = &self.spin {
            return self.collide_turned(spin, point, velocity);
        }
        if let Some(surface) = &self.surface {
            return self.collide_deforming(surface, point, velocity);
        }
        let (distance, normal) = match self.geometry {
            // The domain walls, which every particle and node meets six
            // times a substep: the same sum as `signed_distance`, inline.
            ColliderGeometry::HalfPlane {
                point: origin,
                normal,
            } => ((point - origin).dot(normal), normal),
            ref geometry => geometry.signed_distance(point),
        };
        if distance <= 0.0 {
            contact_response(velocity, self.velocity, normal, self.contact)
        } else {
            (velocity, Constraint::Free)
        }
    }

    /// Signed distance (negative inside) and outward unit normal at
    /// `point`, however the collider is placed, turned or deformed.
    pub fn distance_and_normal(&self, point: Vec3) -> (f32, Vec3) {
        if let Some(spin) = &self.spin {
            return turned_distance(&self.geometry, spin, point);
        }
        if let Some(surface) = &self.surface {
            let (distance, normal, _) = surface.sample(point);
            return (distance, normal);
        }
        self.geometry.signed_distance(point)
    }

    /// Signed distance at `point` (negative inside), however the collider
    /// is placed, turned or deformed.
    pub fn signed_distance(&self, point: Vec3) -> f32 {
        if let Some(spin) = &self.spin {
            return turned_distance(&self.geometry, spin, point).0;
        }
        if let Some(surface) = &self.surface {
            return surface.distance(point);
        }
        self.geometry.signed_distance(point).0
    }

    /// [`PlacedCollider::collide_constrained`] for a deforming mesh: the
    /// contact relative to the surface's own velocity where it touches.
    fn collide_deforming(
        &self,
        surface: &DeformingSurface,
        point: Vec3,
        velocity: Vec3,
    ) -> (Vec3, Constraint) {
        if surface.distance(point) > 0.0 {
            return (velocity, Constraint::Free);
        }
        let (_, normal, surface_velocity) = surface.sample(point);
        contact_response(velocity, surface_velocity, normal, self.contact)
    }

    /// [`PlacedCollider::collide_constrained`] for a turned or turning
    /// collider: the distance read in its own frame, the normal turned back,
    /// and the contact relative to its velocity at `point`, v + ω × r.
    fn collide_turned(&self, spin: &Spin, point: Vec3, velocity: Vec3) -> (Vec3, Constraint) {
        let (distance, normal) = turned_distance(&self.geometry, spin, point);
        if distance <= 0.0 {
            let surface_velocity = self.velocity + spin.angular_velocity.cross(point - spin.center);
            contact_response(velocity, surface_velocity, normal, self.contact)
        } else {
            (velocity, Constraint::Free)
        }
    }
}

/// The signed distance and outward normal of `geometry` turned by `spin` at
/// `point`: read in its own frame at c + R⁻¹ (x − c), the normal turned back
/// by R.
#[inline(always)]
fn turned_distance(geometry: &ColliderGeometry, spin: &Spin, point: Vec3) -> (f32, Vec3) {
    let (distance, normal) =
        geometry.signed_distance(spin.center + spin.inverse * (point - spin.center));
    (distance, spin.rotation * normal)
}

/// The scene's colliders plus the six domain walls, and the fields the
/// deforming ones have built.
#[derive(Clone, Debug)]
pub struct ColliderSet {
    colliders: Vec<Collider>,
    sequences: Vec<SequenceCache>,
}

impl ColliderSet {
    /// Scene colliders followed by the walls of `domain` as static half-planes.
    pub fn new(domain: &Domain, colliders: &[Collider]) -> ColliderSet {
        let mut all = colliders.to_vec();
        for axis in 0..3 {
            let mut normal = Vec3::ZERO;
            normal[axis] = 1.0;
            for (point, normal) in [(domain.min, normal), (domain.max, -normal)] {
                all.push(Collider {
                    contact: domain.walls,
                    ..Collider::new(ColliderGeometry::HalfPlane { point, normal })
                });
            }
        }
        ColliderSet {
            sequences: vec![SequenceCache::default(); all.len()],
            colliders: all,
        }
    }

    /// The colliders, scene ones first, then the walls.
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }

    /// Every collider placed at time `time`; a deforming one builds the
    /// fields of the mesh frames around `time` when it has not yet.
    pub fn placed_at(&mut self, time: f64) -> Vec<PlacedCollider> {
        self.colliders
            .iter()
            .zip(&mut self.sequences)
            .map(|(collider, cache)| {
                let pose = collider.pose_at(time);
                let surface = match &collider.geometry {
                    ColliderGeometry::MeshSequence(sequence) => {
                        Some(cache.surface_at(sequence, time))
                    }
                    _ => None,
                };
                PlacedCollider {
                    geometry: collider.geometry.moved_to(pose.position),
                    velocity: pose.velocity,
                    contact: collider.contact,
                    spin: pose.turns().then(|| Spin {
                        center: pose.position,
                        rotation: pose.rotation,
                        inverse: pose.rotation.inverse(),
                        angular_velocity: pose.angular_velocity,
                    }),
                    surface,
                }
            })
            .collect()
    }
}

/// Applies every collider in turn to a velocity at `point`.
#[inline(always)]
pub fn collide_all(colliders: &[PlacedCollider], point: Vec3, mut velocity: Vec3) -> Vec3 {
    for collider in colliders {
        velocity = collider.collide(point, velocity);
    }
    velocity
}

/// The colliders of a substep, arranged so that a point can skip the
/// axis-aligned half-planes (the six domain walls, and any such scene plane)
/// when it lies strictly on the free side of all of them, as almost every
/// particle and node does.
///
/// Skipping is exact: a half-plane with normal ±e_k changes a velocity only
/// where its signed distance (x − o)·n ≤ 0, and for a finite point that
/// distance is positive exactly when x_k > o_k (normal +e_k) or x_k < o_k
/// (normal −e_k). Where the box test fails (near a wall, or a non-finite
/// point), every collider is applied in order, as [`collide_all`] does. So
/// [`Colliders::collide`] gives the bits of [`collide_all`] everywhere.
#[derive(Clone, Debug)]
pub struct Colliders<'a> {
    /// Every collider, in order.
    all: &'a [PlacedCollider],
    /// The colliders that are not axis-aligned half-planes, in order.
    others: Vec<&'a PlacedCollider>,
    /// Points strictly above this (per axis) are clear of the planes facing +e_k.
    clear_above: Vec3A,
    /// Points strictly below this are clear of the planes facing −e_k.
    clear_below: Vec3A,
}

impl<'a> Colliders<'a> {
    /// Sorts `all` into axis-aligned half-planes and the rest.
    pub fn new(all: &'a [PlacedCollider]) -> Colliders<'a> {
        let mut clear_above = Vec3A::NEG_INFINITY;
        let mut clear_below = Vec3A::INFINITY;
        let mut others = Vec::new();
        for collider in all {
            match axis_plane(collider) {
                Some((axis, true, offset)) => {
                    clear_above[axis] = clear_above[axis].max(offset);
                }
                Some((axis, false, offset)) => {
                    clear_below[axis] = clear_below[axis].min(offset);
                }
                None => others.push(collider),
            }
        }
        Colliders {
            all,
            others,
            clear_above,
            clear_below,
        }
    }

    /// [`Colliders::collide`] on the first `count` lanes of `points` and
    /// `velocities`: the box test runs in SIMD lanes, and a lane goes
    /// through `collide` only where it fails or other colliders exist (the
    /// same bits as `collide` lane by lane).
    #[inline(always)]
    pub fn collide_lanes<const N: usize>(
        &self,
        points: &Vec3s<N>,
        velocities: &mut Vec3s<N>,
        count: usize,
    ) {
        let above = |x: F32s<N>, bound: f32| F32s::splat(bound).lt(x);
        let below = |x: F32s<N>, bound: f32| x.lt(F32s::splat(bound));
        let clear = above(points.x, self.clear_above.x)
            .and(above(points.y, self.clear_above.y))
            .and(above(points.z, self.clear_above.z))
            .and(below(points.x, self.clear_below.x))
            .and(below(points.y, self.clear_below.y))
            .and(below(points.z, self.clear_below.z));
        for lane in 0..count {
            if clear.0[lane] == 0 || !self.others.is_empty() {
                let velocity = self.collide(points.lane(lane), velocities.lane(lane));
                velocities.set_lane(lane, velocity);
            }
        }
    }

    /// Every collider applied in turn to a velocity at `point`; the same
    /// bits as [`collide_all`].
    #[inline(always)]
    pub fn collide(&self, point: Vec3, mut velocity: Vec3) -> Vec3 {
        let point_lanes = Vec3A::from(point);
        let clear =
            (point_lanes.cmpgt(self.clear_above) & point_lanes.cmplt(self.clear_below)).all();
        if !clear {
            return collide_all(self.all, point, velocity);
        }
        for collider in &self.others {
            velocity = collider.collide(point, velocity);
        }
        velocity
    }
}

/// `(axis, faces_up, offset)` of a half-plane whose normal is exactly +e_axis
/// (`faces_up`) or −e_axis through a point with coordinate `offset` there.
fn axis_plane(collider: &PlacedCollider) -> Option<(usize, bool, f32)> {
    let ColliderGeometry::HalfPlane { point, normal } = &collider.geometry else {
        return None;
    };
    if collider.spin.is_some() {
        return None;
    }
    (0..3).find_map(|axis| {
        let mut unit = Vec3::ZERO;
        unit[axis] = 1.0;
        if *normal == unit {
            Some((axis, true, point[axis]))
        } else if *normal == -unit {
            Some((axis, false, point[axis]))
        } else {
            None
        }
    })
}

/// [`collide_all`], plus every component that some contact fixed.
#[inline(always)]
pub fn collide_all_constrained(
    colliders: &[PlacedCollider],
    point: Vec3,
    mut velocity: Vec3,
) -> (Vec3, Constraint) {
    let mut constraint = Constraint::Free;
    for collider in colliders {
        let (collided, fixed) = collider.collide_constrained(point, velocity);
        velocity = collided;
        constraint = constraint.and(fixed);
    }
    (velocity, constraint)
}

#[cfg(test)]
mod tests;
