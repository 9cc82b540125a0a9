//! Signed distance fields on a regular grid, for mesh colliders.

use glam::{UVec3, Vec3};
use rayon::prelude::*;

use crate::{TriangleMesh, WindingNumber};

/// Signed distances to a mesh on a regular grid (negative inside), for
/// colliders: a particle's distance and push-out direction come from one
/// trilinear lookup instead of a search over all triangles. Each grid value
/// is the exact distance to the closest triangle, signed by the generalized
/// winding number, so open scanned meshes still get a consistent inside.
#[derive(Clone)]
pub struct SignedDistanceField {
    grid: Grid,
    values: Vec<f32>,
}

impl std::fmt::Debug for SignedDistanceField {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SignedDistanceField")
            .field("grid", &self.grid)
            .field("values", &self.values.len())
            .finish()
    }
}

/// Where the grid points are: `origin + spacing * (i, j, k)`.
#[derive(Clone, Copy, Debug)]
struct Grid {
    origin: Vec3,
    spacing: f32,
    dims: UVec3,
}

impl SignedDistanceField {
    /// Samples the field for `mesh` on a grid of the given `spacing` that
    /// covers its bounds grown by `padding` on every side (at least two
    /// points per axis), in parallel over z-slices and deterministically.
    /// A mesh without triangles gives the grid's diagonal everywhere.
    ///
    /// Panics if `spacing` is not positive and finite, `padding` is
    /// negative or not finite, the grid would need more than a billion
    /// points along an axis, or a triangle refers to a missing vertex.
    pub fn build(mesh: &TriangleMesh, spacing: f32, padding: f32) -> SignedDistanceField {
        assert!(
            spacing.is_finite() && spacing > 0.0,
            "SDF spacing must be positive, got {spacing}"
        );
        assert!(
            padding.is_finite() && padding >= 0.0,
            "SDF padding must be >= 0, got {padding}"
        );
        let grid = Grid::covering(mesh.bounds(), spacing, padding);
        let winding = WindingNumber::new(mesh);
        let far = (grid.max() - grid.origin).length();
        let mut values = vec![0.0; grid.len()];
        values
            .par_chunks_mut(grid.dims.x as usize * grid.dims.y as usize)
            .enumerate()
            .for_each(|(k, slice)| grid.fill_slice(&winding, k as u32, far, slice));
        SignedDistanceField { grid, values }
    }

    /// The signed distance at `point` (trilinear in the grid, negative
    /// inside) and the outward unit normal, the normalized gradient of that
    /// distance. Outside the grid box the distance is the distance to the
    /// box plus the value at the closest point of the box (so it keeps
    /// growing), and the normal is the gradient of that sum. Where the
    /// gradient vanishes the normal points from the box centre to `point`.
    pub fn sample(&self, point: Vec3) -> (f32, Vec3) {
        let (lo, hi) = self.bounds();
        let clamped = point.clamp(lo, hi);
        let (value, gradient) = self.trilinear(clamped);
        let outside = point - clamped;
        let gap = outside.length();
        let gradient = if gap > 0.0 {
            Vec3::select(outside.cmpne(Vec3::ZERO), outside / gap, gradient)
        } else {
            gradient
        };
        let normal = gradient
            .try_normalize()
            .or_else(|| (point - 0.5 * (lo + hi)).try_normalize())
            .unwrap_or(Vec3::Y);
        (value + gap, normal)
    }

    /// The grid box `(min, max)`: the mesh bounds grown by the padding,
    /// rounded up to whole cells.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.grid.origin, self.grid.max())
    }

    /// The distance between neighbouring grid points.
    pub fn spacing(&self) -> f32 {
        self.grid.spacing
    }

    /// Grid points per axis.
    pub fn dims(&self) -> UVec3 {
        self.grid.dims
    }

    /// The samples, x fastest, then y, then z (for uploading to a GPU).
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// Memory held by the field in bytes, to budget fine grids.
    pub fn byte_size(&self) -> usize {
        std::mem::size_of::<Self>() + self.values.len() * std::mem::size_of::<f32>()
    }

    /// Trilinear value and gradient at a point inside the grid box.
    fn trilinear(&self, p: Vec3) -> (f32, Vec3) {
        let g = (p - self.grid.origin) / self.grid.spacing;
        let cell = g.floor().as_uvec3().min(self.grid.dims - UVec3::splat(2));
        let t = (g - cell.as_vec3()).clamp(Vec3::ZERO, Vec3::ONE);
        let c = |i: u32, j: u32, k: u32| self.values[self.grid.index(cell + UVec3::new(i, j, k))];
        let lerp = |a: f32, b: f32, s: f32| a + (b - a) * s;
        let (c00, c10) = (
            lerp(c(0, 0, 0), c(1, 0, 0), t.x),
            lerp(c(0, 1, 0), c(1, 1, 0), t.x),
        );
        let (c01, c11) = (
            lerp(c(0, 0, 1), c(1, 0, 1), t.x),
            lerp(c(0, 1, 1), c(1, 1, 1), t.x),
        );
        let (c0, c1) = (lerp(c00, c10, t.y), lerp(c01, c11, t.y));
        let dx = |j: u32, k: u32| c(1, j, k) - c(0, j, k);
        let gx = lerp(
            lerp(dx(0, 0), dx(1, 0), t.y),
            lerp(dx(0, 1), dx(1, 1), t.y),
            t.z,
        );
        let gy = lerp(c10 - c00, c11 - c01, t.z);
        let gradient = Vec3::new(gx, gy, c1 - c0) / self.grid.spacing;
        (lerp(c0, c1, t.z), gradient)
    }
}

impl Grid {
    /// The grid over `bounds` grown by `padding`, whole cells of `spacing`.
    fn covering((lo, hi): (Vec3, Vec3), spacing: f32, padding: f32) -> Grid {
        let cells = ((hi - lo + Vec3::splat(2.0 * padding)) / spacing).ceil();
        assert!(
            cells.max_element() < 1.0e9,
            "SDF grid too fine: {cells} cells; use a larger spacing"
        );
        let dims = (cells.as_uvec3() + UVec3::ONE).max(UVec3::splat(2));
        Grid {
            origin: lo - Vec3::splat(padding),
            spacing,
            dims,
        }
    }

    fn len(&self) -> usize {
        [self.dims.y, self.dims.z]
            .into_iter()
            .try_fold(self.dims.x as usize, |n, d| n.checked_mul(d as usize))
            .expect("SDF grid has too many points; use a larger spacing")
    }

    fn max(&self) -> Vec3 {
        self.origin + (self.dims - UVec3::ONE).as_vec3() * self.spacing
    }

    fn index(&self, at: UVec3) -> usize {
        let (nx, ny) = (self.dims.x as usize, self.dims.y as usize);
        (at.z as usize * ny + at.y as usize) * nx + at.x as usize
    }

    /// Fills z-slice `k`, x fastest; each closest triangle seeds the next
    /// search, in a fixed order, so the result is the same on any thread.
    fn fill_slice(&self, winding: &WindingNumber, k: u32, far: f32, values: &mut [f32]) {
        let mut hint = None;
        for (j, row) in values.chunks_mut(self.dims.x as usize).enumerate() {
            for (i, value) in row.iter_mut().enumerate() {
                let p = self.origin + UVec3::new(i as u32, j as u32, k).as_vec3() * self.spacing;
                let closest = winding.bvh().closest(p, hint);
                hint = closest.map(|(_, t)| t);
                let distance = closest.map_or(far, |(d2, _)| d2.sqrt());
                *value = if winding.contains(p) {
                    -distance
                } else {
                    distance
                };
            }
        }
    }
}
