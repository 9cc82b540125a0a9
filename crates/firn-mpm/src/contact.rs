//! Collisions with rigid bodies and the domain walls (thesis §3.4 steps 5
//! and 9, Quellcode 12), always relative to the collider's own velocity.

use firn_core::scene::{Collider, ColliderGeometry, Contact, ContactMode, Domain, Motion};
use glam::Vec3;

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
    let relative = velocity - collider_velocity;
    let normal_speed = relative.dot(normal);
    let tangential = relative - normal * normal_speed;
    match contact.mode {
        ContactMode::Sticky => collider_velocity,
        ContactMode::Separate if normal_speed >= 0.0 => velocity,
        ContactMode::Slip if normal_speed >= 0.0 => collider_velocity + tangential,
        ContactMode::Separate | ContactMode::Slip => {
            collider_velocity + with_friction(tangential, normal_speed, contact.friction)
        }
    }
}

/// Coulomb friction on the tangential velocity for an approach speed
/// `normal_speed` < 0.
#[inline(always)]
fn with_friction(tangential: Vec3, normal_speed: f32, friction: f32) -> Vec3 {
    let length = tangential.length();
    let limit = -friction * normal_speed;
    if length <= limit {
        Vec3::ZERO
    } else {
        tangential * (1.0 - limit / length)
    }
}

/// A collider at one instant: where it is and how fast it moves.
#[derive(Clone, Debug)]
pub struct PlacedCollider {
    /// Geometry at this instant.
    pub geometry: ColliderGeometry,
    /// Velocity of the collider.
    pub velocity: Vec3,
    /// Contact behaviour.
    pub contact: Contact,
}

impl PlacedCollider {
    /// Applies the contact law if `point` is inside (or on) the collider.
    #[inline(always)]
    pub fn collide(&self, point: Vec3, velocity: Vec3) -> Vec3 {
        let (distance, normal) = self.geometry.signed_distance(point);
        if distance <= 0.0 {
            apply_contact(velocity, self.velocity, normal, self.contact)
        } else {
            velocity
        }
    }
}

/// The scene's colliders plus the six domain walls.
#[derive(Clone, Debug)]
pub struct ColliderSet {
    colliders: Vec<Collider>,
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
                    geometry: ColliderGeometry::HalfPlane { point, normal },
                    motion: Motion::Static,
                    contact: domain.walls,
                });
            }
        }
        ColliderSet { colliders: all }
    }

    /// Every collider placed at time `time`.
    pub fn placed_at(&self, time: f64) -> Vec<PlacedCollider> {
        self.colliders
            .iter()
            .map(|collider| {
                let (position, velocity) = collider
                    .motion
                    .state_at(collider.geometry.reference_point(), time);
                PlacedCollider {
                    geometry: collider.geometry.moved_to(position),
                    velocity,
                    contact: collider.contact,
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

#[cfg(test)]
mod tests {
    use super::*;

    const UP: Vec3 = Vec3::Y;

    fn contact(mode: ContactMode, friction: f32) -> Contact {
        Contact { mode, friction }
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-6
    }

    #[test]
    fn sticking_when_friction_wins() {
        // v_n = −2, |v_t| = 1 ≤ μ·2 with μ = 0.6: the snow sticks.
        let v = apply_contact(
            Vec3::new(1.0, -2.0, 0.0),
            Vec3::ZERO,
            UP,
            contact(ContactMode::Separate, 0.6),
        );
        assert!(close(v, Vec3::ZERO), "{v}");
    }

    #[test]
    fn sliding_loses_mu_times_normal_speed() {
        // v_n = −1, v_t = (3, 0, 4) with |v_t| = 5, μ = 0.5: |v_t| becomes 4.5.
        let v = apply_contact(
            Vec3::new(3.0, -1.0, 4.0),
            Vec3::ZERO,
            UP,
            contact(ContactMode::Separate, 0.5),
        );
        assert!(close(v, Vec3::new(2.7, 0.0, 3.6)), "{v}");
    }

    #[test]
    fn separating_snow_is_untouched_by_the_thesis_law() {
        let v = Vec3::new(1.0, 2.0, 0.0);
        assert_eq!(
            apply_contact(v, Vec3::ZERO, UP, contact(ContactMode::Separate, 0.5)),
            v
        );
        // Slip removes the normal part but not the tangential one.
        let slip = apply_contact(v, Vec3::ZERO, UP, contact(ContactMode::Slip, 0.5));
        assert!(close(slip, Vec3::new(1.0, 0.0, 0.0)), "{slip}");
    }

    #[test]
    fn frictionless_contact_keeps_the_tangential_velocity() {
        let v = apply_contact(
            Vec3::new(1.0, -3.0, 0.0),
            Vec3::ZERO,
            UP,
            contact(ContactMode::Separate, 0.0),
        );
        assert!(close(v, Vec3::new(1.0, 0.0, 0.0)), "{v}");
    }

    #[test]
    fn moving_collider_works_in_its_own_frame() {
        // A floor rising at 1 m/s; snow falling at 1 m/s and sliding at 2 m/s.
        // Relative: v_n = −2, v_t = 2; μ = 0.25 removes 0.5 → v_t = 1.5.
        let floor_velocity = Vec3::new(0.0, 1.0, 0.0);
        let v = apply_contact(
            Vec3::new(2.0, -1.0, 0.0),
            floor_velocity,
            UP,
            contact(ContactMode::Separate, 0.25),
        );
        assert!(close(v, Vec3::new(1.5, 1.0, 0.0)), "{v}");
        // Snow resting on it (relative velocity zero) moves with it.
        let rest = apply_contact(
            floor_velocity,
            floor_velocity,
            UP,
            contact(ContactMode::Separate, 0.25),
        );
        assert!(close(rest, floor_velocity));
        // A sticky collider imposes its velocity.
        let sticky = apply_contact(
            Vec3::new(5.0, -5.0, 1.0),
            floor_velocity,
            UP,
            contact(ContactMode::Sticky, 0.0),
        );
        assert!(close(sticky, floor_velocity));
    }

    #[test]
    fn only_points_inside_a_collider_are_affected() {
        let ball = PlacedCollider {
            geometry: ColliderGeometry::Sphere {
                center: Vec3::ZERO,
                radius: 1.0,
            },
            velocity: Vec3::ZERO,
            contact: contact(ContactMode::Separate, 0.0),
        };
        let towards_centre = Vec3::new(-1.0, 0.0, 0.0);
        assert_eq!(
            ball.collide(Vec3::new(1.5, 0.0, 0.0), towards_centre),
            towards_centre
        );
        assert!(close(
            ball.collide(Vec3::new(0.9, 0.0, 0.0), towards_centre),
            Vec3::ZERO
        ));
    }
}
