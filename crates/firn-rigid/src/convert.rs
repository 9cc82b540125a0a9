//! firn's glam types to rapier's and back, component by component (rapier
//! is built on another glam version).

use rapier3d::prelude::{Pose, Rotation, Vector};

/// A firn vector as rapier's.
pub(crate) fn to_rapier(v: glam::Vec3) -> Vector {
    Vector::from_array(v.to_array())
}

/// A rapier vector as firn's.
pub(crate) fn from_rapier(v: Vector) -> glam::Vec3 {
    glam::Vec3::from_array(v.to_array())
}

/// A firn rotation as rapier's.
pub(crate) fn rotation_to_rapier(q: glam::Quat) -> Rotation {
    Rotation::from_array(q.to_array())
}

/// A rapier rotation as firn's.
pub(crate) fn rotation_from_rapier(q: Rotation) -> glam::Quat {
    glam::Quat::from_array(q.to_array())
}

/// The pose at `position` turned by `rotation`.
pub(crate) fn pose(position: glam::Vec3, rotation: glam::Quat) -> Pose {
    Pose::from_parts(to_rapier(position), rotation_to_rapier(rotation))
}
