//! Whether each rigid body starts clear of the domain's walls, of the
//! colliders (where they are at time 0) and of the other rigid bodies.
//!
//! A body is tested by points of it: its centre and a few hundred points
//! spread over its surface, or for a mesh its vertices. Where one lies
//! deeper than a quarter cell inside another solid (by that solid's signed
//! distance, read in its own frame), the body starts inside it. Boxes
//! around the solids keep the pairs tested few: a sweep along x, then the
//! boxes' overlap.

use glam::{Mat3, Quat, Vec3};

use super::issue::{Check, Issue, KeyPath};
use super::values::{AXES, Num, format_vec, round_up_3_digits};
use crate::scene::model::{Collider, ColliderGeometry, Domain, Scene};
use crate::scene::rigid_body::RigidBody;

/// How deep, as a share of the cell size, a body may start in another solid.
const TOLERANCE_SHARE: f32 = 0.25;

/// Points spread over a ball's surface (a capsule's ends share them).
const BALL_POINTS: usize = 256;

/// Points along each edge of a box face's grid.
const FACE_GRID: usize = 7;

/// Points around each ring of a cylinder or capsule.
const RING_POINTS: usize = 16;

/// Rings along a cylinder's or capsule's side, ends included.
const SIDE_RINGS: usize = 7;

/// Points of a sphere, box, cylinder or capsule in its own frame: its
/// centre, then points spread over its surface (none for other shapes).
pub(super) fn surface_points(geometry: &ColliderGeometry) -> Vec<Vec3> {
    match *geometry {
        ColliderGeometry::Sphere { center, radius } => {
            let mut points = vec![center];
            points.extend(ball_directions().map(|u| center + radius * u));
            points
        }
        ColliderGeometry::Box { center, size } => box_points(center, 0.5 * size),
        ColliderGeometry::Cylinder {
            center,
            radius,
            height,
        } => cylinder_points(center, radius, 0.5 * height),
        ColliderGeometry::Capsule {
            center,
            radius,
            height,
        } => capsule_points(center, radius, 0.5 * height - radius),
        _ => Vec::new(),
    }
}

/// Unit vectors spread evenly over the sphere (a Fibonacci lattice) and
/// the six along the axes.
fn ball_directions() -> impl Iterator<Item = Vec3> {
    let golden_angle = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let axes = [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ];
    let lattice = (0..BALL_POINTS).map(move |i| {
        let y = 1.0 - (2 * i + 1) as f32 / BALL_POINTS as f32;
        let across = (1.0 - y * y).max(0.0).sqrt();
        let angle = golden_angle * i as f32;
        Vec3::new(across * angle.cos(), y, across * angle.sin())
    });
    axes.into_iter().chain(lattice)
}

/// The centre, and a grid on each face, edges and corners included.
fn box_points(center: Vec3, half: Vec3) -> Vec<Vec3> {
    let step = |k: usize| 2.0 * k as f32 / (FACE_GRID - 1) as f32 - 1.0;
    let mut points = vec![center];
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [-1.0, 1.0] {
            for i in 0..FACE_GRID {
                for j in 0..FACE_GRID {
                    let mut unit = Vec3::ZERO;
                    unit[axis] = side;
                    unit[u] = step(i);
                    unit[v] = step(j);
                    points.push(center + unit * half);
                }
            }
        }
    }
    points
}

/// A ring of `radius` about the y axis at height `y` above `center`.
fn ring(center: Vec3, radius: f32, y: f32) -> impl Iterator<Item = Vec3> {
    (0..RING_POINTS).map(move |k| {
        let angle = std::f32::consts::TAU * k as f32 / RING_POINTS as f32;
        center + Vec3::new(radius * angle.cos(), y, radius * angle.sin())
    })
}

/// Heights of the side's rings, from `-half` to `half`.
fn side_heights(half: f32) -> impl Iterator<Item = f32> {
    (0..SIDE_RINGS).map(move |k| half * (2.0 * k as f32 / (SIDE_RINGS - 1) as f32 - 1.0))
}

/// The centre, rings along the side (the rims among them) and on the caps.
fn cylinder_points(center: Vec3, radius: f32, half: f32) -> Vec<Vec3> {
    let mut points = vec![center];
    for y in side_heights(half) {
        points.extend(ring(center, radius, y));
    }
    for y in [-half, half] {
        points.push(center + Vec3::new(0.0, y, 0.0));
        for share in [1.0 / 3.0, 2.0 / 3.0] {
            points.extend(ring(center, share * radius, y));
        }
    }
    points
}

/// The centre, rings along the side and points over both round ends.
fn capsule_points(center: Vec3, radius: f32, half_segment: f32) -> Vec<Vec3> {
    let mut points = vec![center];
    for y in side_heights(half_segment) {
        points.extend(ring(center, radius, y));
    }
    points.extend(ball_directions().map(|u| {
        let end = if u.y >= 0.0 {
            half_segment
        } else {
            -half_segment
        };
        center + radius * u + Vec3::new(0.0, end, 0.0)
    }));
    points
}

/// A solid where it is at the start: its geometry, in its own frame, turned
/// by `rotation` about its reference point `anchor`, which lies at `pivot`.
struct Placed<'a> {
    geometry: &'a ColliderGeometry,
    anchor: Vec3,
    pivot: Vec3,
    rotation: Quat,
    /// A box around it in the world (infinite for a plane).
    low: Vec3,
    high: Vec3,
}

impl<'a> Placed<'a> {
    /// `None` for what has no distance to read: a mesh sequence (only the
    /// solver samples its frames), or a mesh whose field is not built.
    fn new(geometry: &'a ColliderGeometry, pivot: Vec3, rotation: Quat) -> Option<Placed<'a>> {
        let anchor = geometry.reference_point();
        let (low, high) = match *geometry {
            ColliderGeometry::HalfPlane { .. } => (Vec3::NEG_INFINITY, Vec3::INFINITY),
            _ => {
                let (low, high) = own_bounds(geometry)?;
                let turn = Mat3::from_quat(rotation);
                let abs = Mat3::from_cols(turn.x_axis.abs(), turn.y_axis.abs(), turn.z_axis.abs());
                let middle = pivot + rotation * (0.5 * (low + high) - anchor);
                let half = abs * (0.5 * (high - low));
                (middle - half, middle + half)
            }
        };
        Some(Placed {
            geometry,
            anchor,
            pivot,
            rotation,
            low,
            high,
        })
    }

    fn body(body: &'a RigidBody) -> Option<Placed<'a>> {
        Placed::new(&body.geometry, body.reference_point(), body_turn(body))
    }

    fn collider(collider: &'a Collider) -> Option<Placed<'a>> {
        let pose = collider.pose_at(0.0);
        Placed::new(&collider.geometry, pose.position, pose.rotation)
    }

    /// Signed distance (negative inside) and outward normal at a world point.
    fn distance(&self, point: Vec3) -> (f32, Vec3) {
        let own = self.anchor + self.rotation.inverse() * (point - self.pivot);
        let (distance, normal) = self.geometry.signed_distance(own);
        (distance, self.rotation * normal)
    }

    /// Whether the solid's box, grown by `margin`, holds `point`.
    fn may_hold(&self, point: Vec3, margin: f32) -> bool {
        point.cmpge(self.low - margin).all() && point.cmple(self.high + margin).all()
    }
}

/// How a body's geometry is turned at the start, about its reference
/// point: its rotation less what the geometry already carries.
fn body_turn(body: &RigidBody) -> Quat {
    body.rotation * body.baked_rotation().inverse()
}

/// The box around a geometry in its own frame.
fn own_bounds(geometry: &ColliderGeometry) -> Option<(Vec3, Vec3)> {
    let around = |center: Vec3, half: Vec3| Some((center - half, center + half));
    match *geometry {
        ColliderGeometry::Sphere { center, radius } => around(center, Vec3::splat(radius)),
        ColliderGeometry::Box { center, size } => around(center, 0.5 * size),
        ColliderGeometry::Cylinder {
            center,
            radius,
            height,
        }
        | ColliderGeometry::Capsule {
            center,
            radius,
            height,
        } => around(center, Vec3::new(radius, 0.5 * height, radius)),
        ColliderGeometry::Mesh(ref mesh) if mesh.field.is_loaded() => Some(mesh.bounds()),
        _ => None,
    }
}

/// How deep the deepest of `points` lies inside `solid`, past `tolerance`,
/// with the solid's outward normal there.
fn deepest(points: &[Vec3], solid: &Placed<'_>, tolerance: f32) -> Option<(f32, Vec3)> {
    points
        .iter()
        .filter(|point| solid.may_hold(**point, tolerance))
        .map(|&point| solid.distance(point))
        .filter(|(distance, _)| *distance < -tolerance)
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(distance, normal)| (-distance, normal))
}

/// Each body's points in the world, the walls, the colliders, the other
/// bodies: the first body found inside another solid is the error.
pub(super) fn check_overlaps(scene: &Scene, own_points: &[Vec<Vec3>]) -> Check {
    let tolerance = TOLERANCE_SHARE * scene.domain.cell_size;
    let placed: Vec<Option<Placed<'_>>> = scene.rigid_bodies.iter().map(Placed::body).collect();
    let points: Vec<Vec<Vec3>> = scene
        .rigid_bodies
        .iter()
        .zip(own_points)
        .map(|(body, points)| {
            let (pivot, rotation) = (body.reference_point(), body_turn(body));
            points
                .iter()
                .map(|&point| pivot + rotation * (point - pivot))
                .collect()
        })
        .collect();
    let body_path = |index: usize| KeyPath::of("rigid_bodies").index(index);
    for (index, points) in points.iter().enumerate() {
        check_walls(&body_path(index), points, &scene.domain, tolerance)?;
        for (other, collider) in scene.colliders.iter().enumerate() {
            let Some(solid) = Placed::collider(collider) else {
                continue;
            };
            if let Some(found) = deepest(points, &solid, tolerance) {
                let other = KeyPath::of("colliders").index(other);
                return Err(inside(&body_path(index), &other, found, tolerance));
            }
        }
    }
    let boxes: Vec<(Vec3, Vec3)> = placed
        .iter()
        .zip(&points)
        .map(|(solid, points)| match solid {
            Some(solid) => (solid.low, solid.high),
            None => points_box(points),
        })
        .collect();
    for (a, b) in touching_boxes(&boxes, tolerance) {
        for (this, other) in [(a, b), (b, a)] {
            let Some(solid) = &placed[other] else {
                continue;
            };
            if let Some(found) = deepest(&points[this], solid, tolerance) {
                return Err(inside(
                    &body_path(this),
                    &body_path(other),
                    found,
                    tolerance,
                ));
            }
        }
    }
    Ok(())
}

/// The box around some points.
fn points_box(points: &[Vec3]) -> (Vec3, Vec3) {
    points
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(low, high), &p| {
            (low.min(p), high.max(p))
        })
}

/// The pairs `(a, b)`, `a < b`, of boxes that overlap when grown by
/// `margin`: sorted by their low x, each box meets the ones after it that
/// start before it ends.
fn touching_boxes(boxes: &[(Vec3, Vec3)], margin: f32) -> Vec<(usize, usize)> {
    let mut order: Vec<usize> = (0..boxes.len()).collect();
    order.sort_by(|&a, &b| boxes[a].0.x.total_cmp(&boxes[b].0.x).then(a.cmp(&b)));
    let mut pairs = Vec::new();
    for (rank, &a) in order.iter().enumerate() {
        let (low, high) = boxes[a];
        for &b in &order[rank + 1..] {
            let (other_low, other_high) = boxes[b];
            if other_low.x > high.x + margin {
                break;
            }
            let apart = other_low.cmpgt(high + margin) | low.cmpgt(other_high + margin);
            if !apart.any() {
                pairs.push((a.min(b), a.max(b)));
            }
        }
    }
    pairs.sort_unstable();
    pairs
}

/// A body reaching past the domain's walls by more than `tolerance`.
fn check_walls(path: &KeyPath, points: &[Vec3], domain: &Domain, tolerance: f32) -> Check {
    let mut worst: Option<(f32, usize, f32)> = None;
    for point in points {
        for axis in 0..3 {
            for (past, inward) in [
                (domain.min[axis] - point[axis], 1.0),
                (point[axis] - domain.max[axis], -1.0),
            ] {
                if past > tolerance && worst.is_none_or(|(deepest, _, _)| past > deepest) {
                    worst = Some((past, axis, inward));
                }
            }
        }
    }
    let Some((past, axis, inward)) = worst else {
        return Ok(());
    };
    let mut normal = Vec3::ZERO;
    normal[axis] = inward;
    Err(Issue::new(
        path.key("center"),
        format!(
            "{path} starts outside the domain: it reaches {} m past the walls along {}",
            about(past),
            AXES[axis]
        ),
        format!(
            "move it {} by about {} m, or make the domain larger; a body may start touching \
             the walls, within a quarter cell ({} m)",
            direction(normal),
            about(past),
            Num::from(tolerance)
        ),
    ))
}

/// A body found inside another solid.
fn inside(path: &KeyPath, other: &KeyPath, (depth, normal): (f32, Vec3), tolerance: f32) -> Issue {
    Issue::new(
        path.key("center"),
        format!(
            "{path} starts inside {other}: its surface reaches {} m into it",
            about(depth)
        ),
        format!(
            "move {path} {} by about {} m, clear of {other}, or make it smaller; solids may \
             start touching, within a quarter cell ({} m)",
            direction(normal),
            about(depth),
            Num::from(tolerance)
        ),
    )
}

/// A depth to three digits, rounded up (so that moving by it clears the
/// solid), but not for the last bits of an `f32`: 0.05 stays 0.05.
fn about(depth: f32) -> Num {
    round_up_3_digits(f64::from(depth) * (1.0 - 1e-5))
}

/// A direction in words: "up", "along -x", or the vector.
fn direction(normal: Vec3) -> String {
    let named = [
        (Vec3::Y, "up"),
        (Vec3::NEG_Y, "down"),
        (Vec3::X, "along +x"),
        (Vec3::NEG_X, "along -x"),
        (Vec3::Z, "along +z"),
        (Vec3::NEG_Z, "along -z"),
    ];
    match named.iter().find(|(axis, _)| normal.dot(*axis) > 0.95) {
        Some((_, words)) => (*words).to_string(),
        None => format!("along {}", format_vec((normal * 100.0).round() / 100.0)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn surface_points_lie_on_the_surface() {
        let shapes = [
            ColliderGeometry::Sphere {
                center: Vec3::ONE,
                radius: 0.3,
            },
            ColliderGeometry::Box {
                center: Vec3::ONE,
                size: Vec3::new(0.2, 0.4, 0.6),
            },
            ColliderGeometry::Cylinder {
                center: Vec3::ONE,
                radius: 0.2,
                height: 0.5,
            },
            ColliderGeometry::Capsule {
                center: Vec3::ONE,
                radius: 0.2,
                height: 0.9,
            },
        ];
        for shape in &shapes {
            let points = surface_points(shape);
            assert_eq!(points[0], Vec3::ONE, "the centre comes first");
            assert!(points.len() > 150, "{shape:?}: {} points", points.len());
            for point in &points[1..] {
                let (distance, _) = shape.signed_distance(*point);
                assert!(distance.abs() < 1e-5, "{shape:?} at {point}: {distance}");
            }
            let (low, high) = own_bounds(shape).unwrap();
            let (sampled_low, sampled_high) = points_box(&points);
            assert!(sampled_low.abs_diff_eq(low, 1e-5) && sampled_high.abs_diff_eq(high, 1e-5));
        }
    }

    #[test]
    fn boxes_pair_up_only_where_they_touch() {
        let boxes = [
            (Vec3::ZERO, Vec3::ONE),
            (Vec3::new(0.5, 2.0, 0.0), Vec3::new(1.5, 3.0, 1.0)),
            (Vec3::new(0.9, 0.9, 0.9), Vec3::splat(1.9)),
            (Vec3::new(5.0, 0.0, 0.0), Vec3::splat(6.0)),
        ];
        assert_eq!(touching_boxes(&boxes, 0.0), vec![(0, 2)]);
        assert_eq!(touching_boxes(&boxes, 1.0), vec![(0, 1), (0, 2), (1, 2)]);
    }
}
