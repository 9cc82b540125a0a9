//! The indexed triangle mesh and the similarity-style transform that places
//! it in a scene.

use glam::{Quat, Vec3};

/// An indexed triangle mesh: shared vertex positions and triangles as three
/// indices into `vertices`, counter-clockwise seen from outside (outward
/// normals), which is what every loader in this crate produces.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub vertices: Vec<Vec3>,
    /// Triangles as indices into `vertices`.
    pub triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// The volume the triangles enclose, by the divergence theorem (the sum
    /// of the signed tetrahedra each triangle spans with the origin), as a
    /// magnitude: exact for a closed mesh of either orientation, close for
    /// one with small holes.
    pub fn enclosed_volume(&self) -> f64 {
        let corner = |index: u32| self.vertices[index as usize].as_dvec3();
        let signed: f64 = self
            .triangles
            .iter()
            .map(|&[a, b, c]| corner(a).dot(corner(b).cross(corner(c))) / 6.0)
            .sum();
        signed.abs()
    }

    /// The axis-aligned bounding box `(min, max)` of all vertices; both are
    /// zero for a mesh without vertices.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        if self.vertices.is_empty() {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        self.vertices
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            })
    }

    /// A copy with every vertex moved by `transform`. A mirroring transform
    /// (an odd number of negative scale factors) also reverses every
    /// triangle, so the normals keep pointing outwards and the winding
    /// number stays +1 inside.
    pub fn transformed(&self, transform: &MeshTransform) -> TriangleMesh {
        let vertices = self.vertices.iter().map(|&v| transform.apply(v)).collect();
        let mirrored = transform.scale.x * transform.scale.y * transform.scale.z < 0.0;
        let triangles = if mirrored {
            self.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect()
        } else {
            self.triangles.clone()
        };
        TriangleMesh {
            vertices,
            triangles,
        }
    }

    /// The signed volume enclosed by the mesh by the divergence theorem,
    /// the sum of the signed tetrahedra (origin, a, b, c) accumulated in
    /// f64: positive for outward-facing triangles, negative for an inside-out
    /// mesh. For an open mesh it is the volume closed off towards the origin.
    ///
    /// Panics if a triangle refers to a vertex that does not exist.
    pub fn signed_volume(&self) -> f64 {
        let position = |i: u32| self.vertices[i as usize].as_dvec3();
        let sum: f64 = self
            .triangles
            .iter()
            .map(|&[a, b, c]| position(a).dot(position(b).cross(position(c))))
            .sum();
        sum / 6.0
    }
}

/// Places a mesh in the scene: scale first, then rotate, then translate,
/// so a unit-size mesh can be sized, turned and positioned independently.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshTransform {
    /// Per-axis scale factors, applied first.
    pub scale: Vec3,
    /// Rotation, applied after scaling.
    pub rotation: Quat,
    /// Translation, applied last.
    pub translation: Vec3,
}

impl MeshTransform {
    /// The transform that leaves every point where it is.
    pub const IDENTITY: MeshTransform = MeshTransform {
        scale: Vec3::ONE,
        rotation: Quat::IDENTITY,
        translation: Vec3::ZERO,
    };

    /// Maps a point: `translation + rotation * (scale * p)`.
    pub fn apply(&self, p: Vec3) -> Vec3 {
        self.translation + self.rotation * (self.scale * p)
    }
}

impl Default for MeshTransform {
    fn default() -> Self {
        Self::IDENTITY
    }
}
