//! Meshes and helpers shared by the integration tests.

use std::f64::consts::PI;

use firn_mesh::TriangleMesh;
use glam::{DVec3, Vec3};

/// The bunny shipped with firn.
pub const BUNNY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/meshes/bunny.obj");

/// The faces of a cube whose corner i is at (i & 1, i & 2, i & 4) ≠ 0 per
/// axis, as outward-facing quads.
pub const CUBE_QUADS: [[usize; 4]; 6] = [
    [0, 2, 3, 1],
    [4, 5, 7, 6],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 4, 6, 2],
    [1, 3, 7, 5],
];

/// A quad split into two triangles around its first corner.
pub fn fan(quad: [usize; 4]) -> [[usize; 3]; 2] {
    [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
}

/// The cube [lo, hi]³ with outward-facing triangles.
pub fn cube(lo: f32, hi: f32) -> TriangleMesh {
    let vertices = (0..8)
        .map(|i| {
            Vec3::new(
                pick(i & 1, lo, hi),
                pick(i & 2, lo, hi),
                pick(i & 4, lo, hi),
            )
        })
        .collect();
    let triangles = CUBE_QUADS
        .into_iter()
        .flat_map(fan)
        .map(|triangle| triangle.map(|corner| corner as u32))
        .collect();
    TriangleMesh {
        vertices,
        triangles,
    }
}

fn pick(bit: u32, lo: f32, hi: f32) -> f32 {
    if bit == 0 { lo } else { hi }
}

/// An icosphere of the given radius: the icosahedron, each triangle split
/// in four `subdivisions` times, vertices pushed onto the sphere.
pub fn icosphere(radius: f32, subdivisions: u32) -> TriangleMesh {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut vertices: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&p| Vec3::from_array(p).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                vertices.push((vertices[a as usize] + vertices[b as usize]).normalize());
                vertices.len() as u32 - 1
            })
        };
        triangles = triangles
            .iter()
            .flat_map(|&[a, b, c]| {
                let ab = midpoint(a, b, &mut vertices);
                let bc = midpoint(b, c, &mut vertices);
                let ca = midpoint(c, a, &mut vertices);
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let vertices = vertices.into_iter().map(|v| v * radius).collect();
    TriangleMesh {
        vertices,
        triangles,
    }
}

/// The exact winding number: every triangle's solid angle in f64.
pub fn brute_force_winding(mesh: &TriangleMesh, q: Vec3) -> f64 {
    let q = q.as_dvec3();
    let sum: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.vertices[i as usize].as_dvec3() - q);
            solid_angle(a, b, c)
        })
        .sum();
    sum / (4.0 * PI)
}

fn solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let det = a.dot(b.cross(c));
    2.0 * det.atan2(la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la)
}

/// Lattice points `lo + spacing * (i + 0.5, j + 0.5, k + 0.5)` filling the
/// box `[lo, hi]` (cell centres), with their counts per axis.
pub fn lattice(lo: Vec3, hi: Vec3, spacing: f32) -> (Vec<Vec3>, [usize; 3]) {
    let n = ((hi - lo) / spacing).ceil().as_uvec3();
    let mut points = Vec::with_capacity((n.x * n.y * n.z) as usize);
    for k in 0..n.z {
        for j in 0..n.y {
            for i in 0..n.x {
                points.push(lo + (glam::UVec3::new(i, j, k).as_vec3() + 0.5) * spacing);
            }
        }
    }
    (points, [n.x as usize, n.y as usize, n.z as usize])
}

/// A small deterministic xorshift generator of points in a box.
pub struct Random(pub u64);

impl Random {
    pub fn unit(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    pub fn point(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        lo + (hi - lo) * Vec3::new(self.unit(), self.unit(), self.unit())
    }
}
