//! Triangles and lines built on the host: the unit sphere and box that
//! colliders scale, a mesh collider's triangles with smooth normals, a plane
//! clipped to the container, and the container's edges.

use bytemuck::{Pod, Zeroable};
use firn_mesh::TriangleMesh;
use glam::Vec3;

/// A vertex of a shaded surface (`SolidIn` locations 0 and 1 in `solids.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct SurfaceVertex {
    /// Position.
    pub(super) position: [f32; 3],
    /// Outward normal (not necessarily unit length).
    pub(super) normal: [f32; 3],
}

impl SurfaceVertex {
    fn new(position: Vec3, normal: Vec3) -> SurfaceVertex {
        SurfaceVertex {
            position: position.to_array(),
            normal: normal.to_array(),
        }
    }
}

/// Segments around the unit sphere's equator (half as many pole to pole).
const SPHERE_SEGMENTS: u32 = 48;

/// Triangles of the unit sphere, normals equal to positions.
pub(super) fn unit_sphere() -> Vec<SurfaceVertex> {
    let rings = SPHERE_SEGMENTS / 2;
    let point = |ring: u32, segment: u32| {
        let polar = std::f32::consts::PI * ring as f32 / rings as f32;
        let azimuth = std::f32::consts::TAU * segment as f32 / SPHERE_SEGMENTS as f32;
        let p = Vec3::new(
            polar.sin() * azimuth.cos(),
            polar.cos(),
            polar.sin() * azimuth.sin(),
        );
        SurfaceVertex::new(p, p)
    };
    let mut vertices = Vec::with_capacity((rings * SPHERE_SEGMENTS * 6) as usize);
    for ring in 0..rings {
        for segment in 0..SPHERE_SEGMENTS {
            let [a, b] = [point(ring, segment), point(ring, segment + 1)];
            let [c, d] = [point(ring + 1, segment), point(ring + 1, segment + 1)];
            vertices.extend([a, c, d, a, d, b]);
        }
    }
    vertices
}

/// Triangles of the cylinder of radius 1 and height 1 about the y axis
/// (from y = -0.5 to 0.5): a smooth side and flat caps.
pub(super) fn unit_cylinder() -> Vec<SurfaceVertex> {
    let around = |segment: u32| {
        let azimuth = std::f32::consts::TAU * segment as f32 / SPHERE_SEGMENTS as f32;
        Vec3::new(azimuth.cos(), 0.0, azimuth.sin())
    };
    let mut vertices = Vec::with_capacity((SPHERE_SEGMENTS * 12) as usize);
    for segment in 0..SPHERE_SEGMENTS {
        let (a, b) = (around(segment), around(segment + 1));
        let (low, high) = (Vec3::new(0.0, -0.5, 0.0), Vec3::new(0.0, 0.5, 0.0));
        let side = |p: Vec3, y: Vec3| SurfaceVertex::new(p + y, p);
        vertices.extend([side(a, low), side(a, high), side(b, high)]);
        vertices.extend([side(a, low), side(b, high), side(b, low)]);
        let cap = |p: Vec3, normal: Vec3| SurfaceVertex::new(p, normal);
        vertices.extend([
            cap(high, Vec3::Y),
            cap(b + high, Vec3::Y),
            cap(a + high, Vec3::Y),
        ]);
        vertices.extend([
            cap(low, Vec3::NEG_Y),
            cap(a + low, Vec3::NEG_Y),
            cap(b + low, Vec3::NEG_Y),
        ]);
    }
    vertices
}

/// Triangles of the box from -0.5 to 0.5 on every axis, with face normals.
pub(super) fn unit_cube() -> Vec<SurfaceVertex> {
    let mut vertices = Vec::with_capacity(36);
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let normal = Vec3::AXES[axis] * sign;
            let u = Vec3::AXES[(axis + 1) % 3] * 0.5;
            let v = Vec3::AXES[(axis + 2) % 3] * 0.5;
            let center = normal * 0.5;
            let corners = [
                center - u - v,
                center + u - v,
                center + u + v,
                center - u + v,
            ];
            for index in [0, 1, 2, 0, 2, 3] {
                vertices.push(SurfaceVertex::new(corners[index], normal));
            }
        }
    }
    vertices
}

/// Cosine of the largest angle between a face and its vertex's averaged
/// normal that is still shaded smoothly; sharper corners keep the face's
/// own normal, so a box stays flat while a scanned surface looks round.
const CREASE_COS: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// A mesh's triangles with area-weighted vertex normals, except across
/// creases sharper than [`CREASE_COS`].
pub(super) fn mesh_triangles(mesh: &TriangleMesh) -> Vec<SurfaceVertex> {
    let position = |index: u32| mesh.vertices[index as usize];
    let face_normal =
        |[a, b, c]: [u32; 3]| (position(b) - position(a)).cross(position(c) - position(a));
    let mut smooth = vec![Vec3::ZERO; mesh.vertices.len()];
    for &triangle in &mesh.triangles {
        for index in triangle {
            smooth[index as usize] += face_normal(triangle);
        }
    }
    mesh.triangles
        .iter()
        .flat_map(|&triangle| {
            let face = face_normal(triangle).normalize_or_zero();
            triangle.map(|index| {
                let averaged = smooth[index as usize].normalize_or_zero();
                let normal = if averaged.dot(face) >= CREASE_COS {
                    averaged
                } else {
                    face
                };
                SurfaceVertex::new(position(index), normal)
            })
        })
        .collect()
}

/// Half the edge of the square drawn for a plane when there is no container
/// to clip it to, in metres.
const UNBOUNDED_PLANE_HALF_EXTENT: f32 = 100.0;

/// Triangles of the plane through `point` with `normal` inside the box
/// `bounds` (all of it within a large square when there is no box), with
/// the plane's normal; empty where the plane misses the box.
pub(super) fn plane_polygon(
    point: Vec3,
    normal: Vec3,
    bounds: Option<(Vec3, Vec3)>,
) -> Vec<SurfaceVertex> {
    let normal = normal.normalize_or_zero();
    let (u, v) = normal.any_orthonormal_pair();
    let corners: Vec<Vec3> = match bounds {
        Some((min, max)) => box_section(point, normal, min, max),
        None => [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .map(|(a, b)| point + (u * a + v * b) * UNBOUNDED_PLANE_HALF_EXTENT)
            .to_vec(),
    };
    if corners.len() < 3 {
        return Vec::new();
    }
    let center = corners.iter().sum::<Vec3>() / corners.len() as f32;
    let angle = |p: &Vec3| (*p - center).dot(v).atan2((*p - center).dot(u));
    let mut sorted = corners;
    sorted.sort_by(|a, b| angle(a).total_cmp(&angle(b)));
    (1..sorted.len() - 1)
        .flat_map(|i| [sorted[0], sorted[i], sorted[i + 1]])
        .map(|p| SurfaceVertex::new(p, normal))
        .collect()
}

/// Where the plane crosses the edges of the box, slightly enlarged so a
/// plane on a face of the box still cuts it (as firn_render::stage's margin
/// keeps a wall on the container's face).
fn box_section(point: Vec3, normal: Vec3, min: Vec3, max: Vec3) -> Vec<Vec3> {
    let margin = Vec3::splat(1e-3 * (max - min).max_element());
    box_edges(min - margin, max + margin)
        .into_iter()
        .filter_map(|[a, b]| {
            let (da, db) = ((a - point).dot(normal), (b - point).dot(normal));
            (da * db <= 0.0 && da != db).then(|| a + (b - a) * (da / (da - db)))
        })
        .collect()
}

/// The twelve edges of an axis-aligned box.
pub(super) fn box_edges(min: Vec3, max: Vec3) -> Vec<[Vec3; 2]> {
    let corner = |index: usize| {
        Vec3::select(
            glam::BVec3::new(index & 1 != 0, index & 2 != 0, index & 4 != 0),
            max,
            min,
        )
    };
    (0..8)
        .flat_map(|index| [1, 2, 4].into_iter().map(move |bit| (index, bit)))
        .filter(|&(index, bit)| index & bit == 0)
        .map(|(index, bit)| [corner(index), corner(index | bit)])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_shapes_are_closed_and_unit_sized() {
        let sphere = unit_sphere();
        assert_eq!(sphere.len() % 3, 0);
        assert!(
            sphere
                .iter()
                .all(|v| (Vec3::from(v.position).length() - 1.0).abs() < 1e-5)
        );
        let cylinder = unit_cylinder();
        assert_eq!(cylinder.len() % 3, 0);
        assert!(cylinder.iter().all(|v| {
            let p = Vec3::from(v.position);
            p.y.abs() == 0.5 && (p.x * p.x + p.z * p.z).sqrt() <= 1.0 + 1e-6
        }));
        let cube = unit_cube();
        assert_eq!(cube.len(), 36);
        assert!(
            cube.iter()
                .all(|v| Vec3::from(v.position).abs().max_element() == 0.5)
        );
    }

    #[test]
    fn a_box_has_twelve_unit_edges() {
        let edges = box_edges(Vec3::ZERO, Vec3::ONE);
        assert_eq!(edges.len(), 12);
        assert!(
            edges
                .iter()
                .all(|[a, b]| ((*a - *b).length() - 1.0).abs() < 1e-6)
        );
    }

    #[test]
    fn a_wall_on_the_container_face_becomes_a_rectangle() {
        let triangles = plane_polygon(Vec3::ZERO, Vec3::X, Some((Vec3::ZERO, Vec3::ONE)));
        // Four corners of the section, fanned into two triangles.
        assert_eq!(triangles.len(), 6);
        let area: f32 = triangles
            .chunks(3)
            .map(|t| {
                let [a, b, c] = [0, 1, 2].map(|i| Vec3::from(t[i].position));
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        assert!((area - 1.0).abs() < 0.01, "area {area}");
    }

    #[test]
    fn a_plane_missing_the_box_draws_nothing() {
        assert!(plane_polygon(Vec3::splat(5.0), Vec3::Y, Some((Vec3::ZERO, Vec3::ONE))).is_empty());
    }

    #[test]
    fn a_cube_keeps_its_faces_flat() {
        let corners: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
            .collect();
        let cube = TriangleMesh {
            vertices: corners,
            triangles: vec![[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6]],
        };
        for vertex in mesh_triangles(&cube) {
            assert_eq!(Vec3::from(vertex.normal).abs(), Vec3::Z);
        }
    }

    #[test]
    fn a_tetrahedron_gets_outward_vertex_normals() {
        let mesh = TriangleMesh {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        };
        let center = Vec3::splat(0.25);
        for vertex in mesh_triangles(&mesh) {
            let outward = Vec3::from(vertex.position) - center;
            assert!(Vec3::from(vertex.normal).dot(outward) > 0.0);
        }
    }
}
