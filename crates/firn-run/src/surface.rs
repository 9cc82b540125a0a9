//! The snow's surface as a closed triangle mesh, reconstructed from its
//! particles (the `mesh` cache format and the `surface` render style).
//!
//! 1. Density: each particle's mass spread over the voxels around it with
//!    quadratic B-spline weights ([`density_grid`], as for the `vdb`
//!    format), on the sparse grid of 8³ leaves.
//! 2. Smoothing: `smoothing` passes of a [1 2 1]/4 blur along x, y and z.
//!    Each pass keeps the mass and rounds off bumps of about a voxel (single
//!    particles, the particle lattice).
//! 3. Surface: marching tetrahedra where the density crosses `iso` times the
//!    rest density. Each cube between eight voxel centres is cut into the six
//!    tetrahedra around its main diagonal (Kuhn's subdivision); the cut
//!    repeats from cube to cube, so neighbouring tetrahedra share their faces
//!    and the surface pieces meet edge to edge. A tetrahedron with one or
//!    three corners inside gives a triangle, one with two gives a quad (two
//!    triangles). Vertices lie on voxel-to-voxel edges, linearly
//!    interpolated, and are shared through their edge.
//!
//! Why not marching cubes or a library: marching tetrahedra needs no
//! 256-case table and has no ambiguous faces, so the mesh is closed and
//! consistently oriented by construction (every edge in exactly two
//! triangles, counter-clockwise seen from outside) for any density, which
//! the tests check. `splashsurf_lib` (the SPH surface reconstruction crate)
//! would bring its own neighbourhood search and a parallel pipeline whose
//! output order depends on the thread count; this module reuses the VDB
//! deposit and runs on one thread, so the files are the same bytes for the
//! same run on any number of threads.
//!
//! Inside is density > iso. Voxel (i, j, k) is centred at
//! `min + (i + ½, j + ½, k + ½)·voxel`, as in [`crate::volumes`].

use std::collections::{BTreeSet, HashMap};

use firn_core::scene::{MeshSettings, Scene};
use firn_io::vdb::{LEAF_DIM, LEAF_VOXELS, voxel_of};
use firn_io::{FloatGrid, GridClass};
use firn_mesh::TriangleMesh;
use glam::{IVec3, Vec3};

use crate::volumes::density_grid;

/// The snow's surface for the scene's `[output.mesh]` settings, from the
/// particles at `positions` with `masses`.
pub fn scene_surface(scene: &Scene, positions: &[Vec3], masses: &[f32]) -> TriangleMesh {
    let settings = &scene.output.mesh;
    let rest_density = scene
        .materials
        .iter()
        .map(|material| material.density)
        .fold(0.0, f32::max);
    snow_surface(
        positions,
        masses,
        scene.domain.min,
        settings.voxel_size_for(scene.domain.cell_size),
        settings,
        rest_density,
    )
}

/// The closed surface of particles at `positions` with `masses`, on voxels
/// of edge `voxel` that tile space from `min`, where their density smoothed
/// as `settings` say crosses `settings.iso` times `rest_density`.
pub fn snow_surface(
    positions: &[Vec3],
    masses: &[f32],
    min: Vec3,
    voxel: f32,
    settings: &MeshSettings,
    rest_density: f32,
) -> TriangleMesh {
    let mut density = density_grid(positions, masses, min, voxel);
    for _ in 0..settings.smoothing {
        for axis in 0..3 {
            density = blur_along(&density, axis);
        }
    }
    let mut mesh = iso_surface(&density, settings.iso * rest_density);
    let centre = min + Vec3::splat(0.5 * voxel);
    for vertex in &mut mesh.vertices {
        *vertex = centre + *vertex * voxel;
    }
    mesh
}

/// Distance in leaf offsets between neighbouring voxels along x, y, z.
const STRIDES: [usize; 3] = [64, 8, 1];

/// `grid` blurred with weights [1 2 1]/4 along `axis` (mass-preserving: each
/// voxel hands half its value to itself and a quarter to each neighbour).
pub fn blur_along(grid: &FloatGrid, axis: usize) -> FloatGrid {
    let mut blurred = FloatGrid::new(
        "density",
        GridClass::FogVolume,
        grid.voxel_size,
        grid.origin,
        0.0,
    );
    let stride = STRIDES[axis];
    for (origin, leaf) in grid.leaves() {
        let target = blurred.leaf_mut(origin);
        for offset in 0..LEAF_VOXELS {
            let value = leaf.value(offset);
            if value == 0.0 {
                continue;
            }
            let local = voxel_of([0; 3], offset)[axis];
            target.add(offset, 0.5 * value);
            if local > 0 {
                target.add(offset - stride, 0.25 * value);
            }
            if local < LEAF_DIM - 1 {
                target.add(offset + stride, 0.25 * value);
            }
        }
        for side in [-1, 1] {
            let (from, to) = if side < 0 {
                (0, LEAF_DIM - 1)
            } else {
                (LEAF_DIM - 1, 0)
            };
            let spills: Vec<(usize, f32)> = (0..LEAF_VOXELS)
                .filter(|&offset| voxel_of([0; 3], offset)[axis] == from)
                .map(|offset| (offset, leaf.value(offset)))
                .filter(|&(_, value)| value != 0.0)
                .collect();
            if spills.is_empty() {
                continue;
            }
            let mut neighbour = origin;
            neighbour[axis] += side * LEAF_DIM;
            let target = blurred.leaf_mut(neighbour);
            let shift = (to - from) as isize * stride as isize;
            for (offset, value) in spills {
                target.add(offset.wrapping_add_signed(shift), 0.25 * value);
            }
        }
    }
    blurred
}

/// The six tetrahedra of a cube around its diagonal from corner 0 to corner
/// 7 (corner bits: 1 = +x, 2 = +y, 4 = +z), each positively oriented. Along
/// each, the corners only gain bits, so of any two corners one is a subset
/// of the other.
const TETRAHEDRA: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 3, 2, 7],
    [0, 2, 6, 7],
    [0, 6, 4, 7],
    [0, 4, 5, 7],
    [0, 5, 1, 7],
];

/// For each corner i of a tetrahedron, the other three in the order that
/// makes (i, j, k, l) an even permutation of (0, 1, 2, 3).
const EVEN_REST: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// Cube corners per axis in a block: a leaf's 8 voxels and the next one.
const BLOCK: usize = LEAF_DIM as usize + 1;

/// The surface (in voxel coordinates) where `density` crosses `iso`,
/// outward-facing; see the module doc.
pub fn iso_surface(density: &FloatGrid, iso: f32) -> TriangleMesh {
    let mut builder = SurfaceBuilder::default();
    for origin in cube_leaves(density) {
        let block = corner_block(density, origin);
        if block.iter().all(|&value| value <= iso) {
            continue;
        }
        for x in 0..LEAF_DIM as usize {
            for y in 0..LEAF_DIM as usize {
                for z in 0..LEAF_DIM as usize {
                    let corners: [f32; 8] = std::array::from_fn(|bits| {
                        block[block_index(x + (bits & 1), y + (bits >> 1 & 1), z + (bits >> 2))]
                    });
                    let inside = corners.iter().filter(|&&value| value > iso).count();
                    if inside == 0 || inside == 8 {
                        continue;
                    }
                    let cube = IVec3::from_array(origin) + IVec3::new(x as i32, y as i32, z as i32);
                    for tetrahedron in TETRAHEDRA {
                        builder.tetrahedron(cube, &corners, tetrahedron, iso);
                    }
                }
            }
        }
    }
    builder.mesh
}

/// The leaves whose cubes (from each voxel to its +x, +y, +z neighbours)
/// may touch a voxel of `density`: each leaf and the seven before it.
fn cube_leaves(density: &FloatGrid) -> BTreeSet<[i32; 3]> {
    let mut origins = BTreeSet::new();
    for origin in density.leaf_origins() {
        for bits in 0..8 {
            let shift = [bits & 1, bits >> 1 & 1, bits >> 2].map(|bit| bit * LEAF_DIM);
            origins.insert([0, 1, 2].map(|axis| origin[axis] - shift[axis]));
        }
    }
    origins
}

/// Index of corner (x, y, z) in a block.
fn block_index(x: usize, y: usize, z: usize) -> usize {
    (x * BLOCK + y) * BLOCK + z
}

/// The values of the 9³ voxels from `origin`: its leaf and one voxel into
/// the next leaves (0 where there are none).
fn corner_block(density: &FloatGrid, origin: [i32; 3]) -> Vec<f32> {
    let leaves: [Option<&firn_io::Leaf>; 8] = std::array::from_fn(|bits| {
        let shift = [bits & 1, bits >> 1 & 1, bits >> 2].map(|bit| bit as i32 * LEAF_DIM);
        density.leaf([0, 1, 2].map(|axis| origin[axis] + shift[axis]))
    });
    let mut block = vec![0.0; BLOCK * BLOCK * BLOCK];
    for x in 0..BLOCK {
        for y in 0..BLOCK {
            for z in 0..BLOCK {
                let far = [x, y, z].map(|c| usize::from(c == BLOCK - 1));
                let Some(leaf) = leaves[far[0] | far[1] << 1 | far[2] << 2] else {
                    continue;
                };
                let local = [x, y, z].map(|c| (c % LEAF_DIM as usize) as i32);
                block[block_index(x, y, z)] = leaf.value(firn_io::Leaf::offset(local));
            }
        }
    }
    block
}

/// A mesh being built, its vertices shared through the voxel edge they lie on.
#[derive(Default)]
struct SurfaceBuilder {
    mesh: TriangleMesh,
    /// Vertex index by edge: lower voxel and the edge's direction bits.
    vertex_of_edge: HashMap<(IVec3, usize), u32>,
}

impl SurfaceBuilder {
    /// Adds the surface inside tetrahedron `corner_ids` of the cube at
    /// `cube` with corner densities `corners`.
    fn tetrahedron(&mut self, cube: IVec3, corners: &[f32; 8], corner_ids: [usize; 4], iso: f32) {
        let inside: Vec<usize> = (0..4).filter(|&i| corners[corner_ids[i]] > iso).collect();
        let mut edge = |from: usize, to: usize| {
            self.edge_vertex(cube, corners, corner_ids[from], corner_ids[to], iso)
        };
        match inside[..] {
            [i] => {
                let [j, k, l] = EVEN_REST[i];
                let triangle = [edge(i, j), edge(i, k), edge(i, l)];
                self.mesh.triangles.push(triangle);
            }
            [a, b, c] => {
                let i = 6 - a - b - c;
                let [j, k, l] = EVEN_REST[i];
                let triangle = [edge(i, j), edge(i, l), edge(i, k)];
                self.mesh.triangles.push(triangle);
            }
            [i, j] => {
                let [k, l] = outside_pair(i, j);
                let quad = [edge(i, k), edge(i, l), edge(j, l), edge(j, k)];
                self.mesh.triangles.push([quad[0], quad[1], quad[2]]);
                self.mesh.triangles.push([quad[0], quad[2], quad[3]]);
            }
            _ => {}
        }
    }

    /// The vertex where the density crosses `iso` between cube corners `a`
    /// and `b` (one a bit-subset of the other), made on first use.
    fn edge_vertex(
        &mut self,
        cube: IVec3,
        corners: &[f32; 8],
        a: usize,
        b: usize,
        iso: f32,
    ) -> u32 {
        let (low, high) = if a & b == a { (a, b) } else { (b, a) };
        let low_voxel = cube + corner_offset(low);
        let direction = high ^ low;
        let vertices = &mut self.mesh.vertices;
        *self
            .vertex_of_edge
            .entry((low_voxel, direction))
            .or_insert_with(|| {
                let (from, to) = (corners[low], corners[high]);
                let t = (iso - from) / (to - from);
                let point = low_voxel.as_vec3() + corner_offset(direction).as_vec3() * t;
                vertices.push(point);
                (vertices.len() - 1) as u32
            })
    }
}

/// The voxel offset of cube corner `bits`.
fn corner_offset(bits: usize) -> IVec3 {
    IVec3::new(
        (bits & 1) as i32,
        (bits >> 1 & 1) as i32,
        (bits >> 2) as i32,
    )
}

/// The two corners other than `i < j`, ordered so that (i, j, k, l) is an
/// even permutation of (0, 1, 2, 3).
fn outside_pair(i: usize, j: usize) -> [usize; 2] {
    let rest: Vec<usize> = (0..4).filter(|&c| c != i && c != j).collect();
    let order = [i, j, rest[0], rest[1]];
    let inversions = (0..4)
        .flat_map(|p| (p + 1..4).map(move |q| (p, q)))
        .filter(|&(p, q)| order[p] > order[q])
        .count();
    if inversions % 2 == 0 {
        [rest[0], rest[1]]
    } else {
        [rest[1], rest[0]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether every edge of `mesh` is used by exactly two triangles, once
    /// in each direction.
    fn is_closed(mesh: &TriangleMesh) -> bool {
        let diagnostics = firn_mesh::MeshDiagnostics::of(mesh);
        diagnostics.boundary_edges
            + diagnostics.non_manifold_edges
            + diagnostics.inconsistently_oriented_edges
            == 0
    }

    #[test]
    fn the_tetrahedra_are_positive_and_fill_the_cube() {
        let mut volume = 0;
        for [a, b, c, d] in TETRAHEDRA {
            let [p, q, r, s] = [a, b, c, d].map(corner_offset);
            let det = (q - p).dot((r - p).cross(s - p));
            assert_eq!(det, 1, "tetrahedron {a} {b} {c} {d}");
            volume += det;
        }
        assert_eq!(volume, 6);
    }

    #[test]
    fn even_orders_are_even() {
        for (i, rest) in EVEN_REST.iter().enumerate() {
            let [j, k, l] = *rest;
            let order = [i, j, k, l];
            let inversions = (0..4)
                .flat_map(|p| (p + 1..4).map(move |q| (p, q)))
                .filter(|&(p, q)| order[p] > order[q])
                .count();
            assert_eq!(inversions % 2, 0, "{order:?}");
        }
    }

    #[test]
    fn a_lumpy_density_gives_a_closed_outward_surface() {
        let mut grid = FloatGrid::new("density", GridClass::FogVolume, 1.0, [0.0; 3], 0.0);
        // A pseudo-random field with features of every size, across leaves.
        let mut state = 12345u32;
        for i in -3..12 {
            for j in -2..10 {
                for k in 0..9 {
                    state = state.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                    let value = (state >> 16) as f32 / 65_536.0;
                    let origin = FloatGrid::leaf_origin([i, j, k]);
                    let local = [i - origin[0], j - origin[1], k - origin[2]];
                    grid.leaf_mut([i, j, k])
                        .add(firn_io::Leaf::offset(local), value);
                }
            }
        }
        let mesh = iso_surface(&grid, 0.5);
        assert!(mesh.triangles.len() > 1000);
        assert!(
            is_closed(&mesh),
            "{:?}",
            firn_mesh::MeshDiagnostics::of(&mesh)
        );
        assert!(mesh.signed_volume() > 0.0);
    }

    #[test]
    fn blurring_keeps_the_mass() {
        let mut grid = FloatGrid::new("density", GridClass::FogVolume, 1.0, [0.0; 3], 0.0);
        grid.leaf_mut([0; 3])
            .add(firn_io::Leaf::offset([7, 0, 3]), 8.0);
        let blurred = blur_along(&blur_along(&grid, 0), 2);
        assert_eq!(blurred.value([8, 0, 3]), 2.0 * 0.5);
        assert_eq!(blurred.value([7, 0, 3]), 4.0 * 0.5);
        assert_eq!(blurred.value([6, 0, 4]), 2.0 * 0.25);
        let total: f32 = blurred
            .leaves()
            .flat_map(|(_, leaf)| (0..LEAF_VOXELS).map(move |offset| leaf.value(offset)))
            .sum();
        assert_eq!(total, 8.0);
    }
}
