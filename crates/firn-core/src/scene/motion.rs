//! How a collider moves: the pose of its reference point (the plane point
//! or the centre) over time, translation and rotation together.
//!
//! A collider turns about its reference point. Its geometry is given in its
//! own frame, placed by a rotation R(t) and a position c(t): a world point x
//! is the body point c₀ + R(t)⁻¹ (x − c(t)), where c₀ is the reference point
//! of the scene file. The collider's velocity at x is
//!
//! ```text
//! v_c(x) = v(t) + ω(t) × (x − c(t)),
//! ```
//!
//! which the contact laws act relative to. Rotations interpolate by slerp
//! between keys (so ω is constant over a segment); positions linearly, or
//! along a Catmull-Rom curve through the keys (`path = "catmull-rom"`),
//! whose tangents are the keys' finite differences in time, so a path
//! through unevenly spaced keys has no kinks.

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

/// How a collider moves; its reference point is the plane point or centre.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Motion {
    /// Does not move.
    Static,
    /// Moves with a constant velocity and turns with a constant angular
    /// velocity about its reference point.
    Linear {
        /// Velocity in m/s.
        velocity: Vec3,
        /// Angular velocity in rad/s (its direction is the axis, by the
        /// right-hand rule; its length the rate).
        #[serde(default)]
        angular_velocity: Vec3,
    },
    /// Moves through keyframed poses of its reference point; it rests at
    /// the first and last key outside their times.
    Keyframed {
        /// Keys sorted by strictly increasing time.
        keys: Vec<Keyframe>,
        /// How positions go from key to key.
        #[serde(default)]
        path: PathShape,
    },
}

/// How a keyframed collider's position goes from key to key.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PathShape {
    /// Straight lines at constant speed (the velocity jumps at each key).
    #[default]
    Linear,
    /// A Catmull-Rom curve through the keys: position and velocity are
    /// continuous.
    CatmullRom,
}

/// A keyframe of a moving collider.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Keyframe {
    /// Time in seconds.
    pub time: f64,
    /// Position of the collider's reference point at that time.
    pub position: Vec3,
    /// Orientation at that time (the collider's own `rotation` where a key
    /// gives none).
    #[serde(default)]
    pub rotation: Quat,
}

impl Keyframe {
    /// The collider's reference point is at `position` at `time` seconds,
    /// unturned.
    pub fn new(time: f64, position: Vec3) -> Keyframe {
        Keyframe {
            time,
            position,
            rotation: Quat::IDENTITY,
        }
    }

    /// The same key with orientation `rotation`.
    pub fn rotated(mut self, rotation: Quat) -> Keyframe {
        self.rotation = rotation;
        self
    }
}

/// Where a collider is at one instant and how it moves there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Position of the reference point.
    pub position: Vec3,
    /// Orientation: from the collider's own frame to the world's, about
    /// the reference point.
    pub rotation: Quat,
    /// Velocity of the reference point, m/s.
    pub velocity: Vec3,
    /// Angular velocity, rad/s.
    pub angular_velocity: Vec3,
}

impl Pose {
    /// Whether the collider is turned or turning: the geometry must then be
    /// read through the rotation and the contact velocity has its ω × r.
    pub fn turns(&self) -> bool {
        self.rotation != Quat::IDENTITY || self.angular_velocity != Vec3::ZERO
    }
}

impl Motion {
    /// Position and velocity of a reference point that starts at `start`, at time `t`.
    pub fn state_at(&self, start: Vec3, t: f64) -> (Vec3, Vec3) {
        let pose = self.pose_at(start, Quat::IDENTITY, t);
        (pose.position, pose.velocity)
    }

    /// The pose at time `t` of a collider whose reference point starts at
    /// `start` with orientation `orientation` (keyframes carry their own).
    pub fn pose_at(&self, start: Vec3, orientation: Quat, t: f64) -> Pose {
        match self {
            Motion::Static => Pose {
                position: start,
                rotation: orientation,
                velocity: Vec3::ZERO,
                angular_velocity: Vec3::ZERO,
            },
            Motion::Linear {
                velocity,
                angular_velocity,
            } => Pose {
                position: start + *velocity * t as f32,
                rotation: turned_by(*angular_velocity, t) * orientation,
                velocity: *velocity,
                angular_velocity: *angular_velocity,
            },
            Motion::Keyframed { keys, path } => keyframe_pose(keys, *path, t),
        }
    }

    /// Whether the collider ever turns (a rotation in its keys or an
    /// angular velocity); `orientation` is its own starting orientation.
    pub fn turns(&self, orientation: Quat) -> bool {
        orientation != Quat::IDENTITY
            || match self {
                Motion::Static => false,
                Motion::Linear {
                    angular_velocity, ..
                } => *angular_velocity != Vec3::ZERO,
                Motion::Keyframed { keys, .. } => {
                    keys.iter().any(|key| key.rotation != Quat::IDENTITY)
                }
            }
    }
}

/// A rotation given in degrees about x, then y, then z (the fixed axes),
/// as a scene file's `rotation` and Blender's XYZ Euler angles.
pub fn rotation_from_degrees(degrees: Vec3) -> Quat {
    let radians = degrees * (std::f32::consts::PI / 180.0);
    Quat::from_rotation_z(radians.z)
        * Quat::from_rotation_y(radians.y)
        * Quat::from_rotation_x(radians.x)
}

/// The rotation by `angular_velocity` over `t` seconds (identity at rest,
/// so a collider that does not turn keeps its orientation's bits).
fn turned_by(angular_velocity: Vec3, t: f64) -> Quat {
    if angular_velocity == Vec3::ZERO {
        Quat::IDENTITY
    } else {
        Quat::from_scaled_axis(angular_velocity * t as f32)
    }
}

/// The pose at `t` along the keys: resting at the first and last key
/// outside their times, else in the segment around `t`.
fn keyframe_pose(keys: &[Keyframe], path: PathShape, t: f64) -> Pose {
    let (Some(first), Some(last)) = (keys.first(), keys.last()) else {
        return Pose {
            position: Vec3::ZERO,
            rotation: Quat::IDENTITY,
            velocity: Vec3::ZERO,
            angular_velocity: Vec3::ZERO,
        };
    };
    let resting = |key: &Keyframe| Pose {
        position: key.position,
        rotation: key.rotation,
        velocity: Vec3::ZERO,
        angular_velocity: Vec3::ZERO,
    };
    if t <= first.time {
        return resting(first);
    }
    if t >= last.time {
        return resting(last);
    }
    let next = keys.partition_point(|key| key.time <= t);
    let (a, b) = (keys[next - 1], keys[next]);
    let span = (b.time - a.time) as f32;
    let s = ((t - a.time) / (b.time - a.time)) as f32;
    let (position, velocity) = match path {
        PathShape::Linear => (
            a.position.lerp(b.position, s),
            (b.position - a.position) / span,
        ),
        PathShape::CatmullRom => catmull_rom(keys, next - 1, s),
    };
    let (rotation, angular_velocity) = if a.rotation == b.rotation {
        (a.rotation, Vec3::ZERO)
    } else {
        (
            a.rotation.slerp(b.rotation, s),
            rotation_rate(a.rotation, b.rotation, span),
        )
    };
    Pose {
        position,
        rotation,
        velocity,
        angular_velocity,
    }
}

/// The constant angular velocity of a slerp from `from` to `to` over
/// `span` seconds, the short way round.
fn rotation_rate(from: Quat, to: Quat, span: f32) -> Vec3 {
    let mut step = to * from.conjugate();
    if step.w < 0.0 {
        step = -step;
    }
    step.to_scaled_axis() / span
}

/// Position and velocity at fraction `s` of the segment from key `index`
/// to the next on the Catmull-Rom curve: a cubic Hermite segment whose
/// tangents at each key are the finite differences of the keys around it
/// in time (one-sided at the first and last key).
fn catmull_rom(keys: &[Keyframe], index: usize, s: f32) -> (Vec3, Vec3) {
    let tangent = |k: usize| {
        let before = &keys[k.saturating_sub(1)];
        let after = &keys[(k + 1).min(keys.len() - 1)];
        (after.position - before.position) / (after.time - before.time) as f32
    };
    let (a, b) = (&keys[index], &keys[index + 1]);
    let span = (b.time - a.time) as f32;
    let (ta, tb) = (tangent(index) * span, tangent(index + 1) * span);
    let (s2, s3) = (s * s, s * s * s);
    let position = a.position * (2.0 * s3 - 3.0 * s2 + 1.0)
        + ta * (s3 - 2.0 * s2 + s)
        + b.position * (-2.0 * s3 + 3.0 * s2)
        + tb * (s3 - s2);
    let slope = a.position * (6.0 * s2 - 6.0 * s)
        + ta * (3.0 * s2 - 4.0 * s + 1.0)
        + b.position * (-6.0 * s2 + 6.0 * s)
        + tb * (3.0 * s2 - 2.0 * s);
    (position, slope / span)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spinning_collider_turns_at_its_angular_velocity() {
        let motion = Motion::Linear {
            velocity: Vec3::X,
            angular_velocity: Vec3::new(0.0, 2.0, 0.0),
        };
        let pose = motion.pose_at(Vec3::ZERO, Quat::IDENTITY, 0.5);
        assert_eq!(pose.position, Vec3::new(0.5, 0.0, 0.0));
        let turned = pose.rotation * Vec3::X;
        assert!((turned - Vec3::new(1.0f32.cos(), 0.0, -(1.0f32.sin()))).length() < 1e-6);
    }

    #[test]
    fn keyed_rotations_slerp_at_a_constant_rate_the_short_way() {
        // −q is the same turn as q (a quarter about +z), written the long
        // way round.
        let quarter = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let keys = [
            Keyframe::new(0.0, Vec3::ZERO),
            Keyframe::new(2.0, Vec3::ZERO).rotated(-quarter),
        ];
        let motion = Motion::Keyframed {
            keys: keys.to_vec(),
            path: PathShape::Linear,
        };
        let pose = motion.pose_at(Vec3::ZERO, Quat::IDENTITY, 1.0);
        let expected = Vec3::new(0.0, 0.0, std::f32::consts::FRAC_PI_4);
        assert!((pose.angular_velocity - expected).length() < 1e-6);
        let eighth = Quat::from_rotation_z(std::f32::consts::FRAC_PI_4);
        assert!(pose.rotation.dot(eighth).abs() > 1.0 - 1e-6);
    }

    #[test]
    fn a_catmull_rom_path_passes_through_its_keys_with_a_continuous_velocity() {
        let keys = vec![
            Keyframe::new(0.0, Vec3::ZERO),
            Keyframe::new(1.0, Vec3::new(1.0, 1.0, 0.0)),
            Keyframe::new(3.0, Vec3::new(2.0, 0.0, 0.0)),
        ];
        let motion = Motion::Keyframed {
            keys,
            path: PathShape::CatmullRom,
        };
        let at = |t: f64| motion.pose_at(Vec3::ZERO, Quat::IDENTITY, t);
        assert!((at(1.0).position - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-6);
        let (before, after) = (at(1.0 - 1e-4), at(1.0 + 1e-4));
        assert!((before.velocity - after.velocity).length() < 1e-2);
        // The velocity is the position's derivative.
        let slope = (at(0.5 + 1e-3).position - at(0.5 - 1e-3).position) / 2e-3;
        assert!((slope - at(0.5).velocity).length() < 1e-2);
    }
}
