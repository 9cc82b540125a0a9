//! Signed distances stored only near a mesh's surface: the field of one
//! frame of a deforming mesh collider, rebuilt for every mesh frame.
//!
//! The samples live in bricks of 4³, and a dense table over the mesh's box
//! says for each brick where its samples are, or that it lies wholly
//! outside or wholly inside. A brick has samples when it comes within the
//! band plus a cell's diagonal of a triangle, so every point
//! nearer to the surface than the band finds exact samples at the eight
//! corners of its cell; the other bricks are sorted into
//! outside and inside by a flood fill from the table's border through
//! bricks without samples (exact for a closed mesh, whose surface the
//! sampled bricks wall in; an open mesh leaks and counts as outside).
//!
//! Each sample keeps its distance to the closest triangle, signed by the
//! angle-weighted pseudo-normal of the closest feature (face, edge or
//! corner; Bærentzen and Aanæs 2005, exact for a closed, consistently
//! oriented mesh), and which triangle that is, so that any per-vertex
//! quantity (a vertex's velocity) can be read at the surface point nearest
//! a query: 8 bytes a sample. OpenVDB's mesh-to-volume
//! does the like in C++; no Rust crate builds such a band, so it is ours.

use std::collections::{HashMap, VecDeque};

use glam::{IVec3, UVec3, Vec3};
use rayon::prelude::*;

use crate::TriangleMesh;
use crate::bvh::Bvh;
use crate::geometry::closest_on_triangle;

/// Samples along each edge of a brick.
pub const BRICK_SIDE: u32 = 4;
/// Samples a brick stores.
pub const SAMPLES_PER_BRICK: usize = (BRICK_SIDE * BRICK_SIDE * BRICK_SIDE) as usize;

/// The table entry of a brick without samples outside the mesh.
pub const OUTSIDE_BRICK: u32 = u32::MAX;
/// The table entry of a brick without samples inside the mesh.
pub const INSIDE_BRICK: u32 = u32::MAX - 1;
const OUTSIDE: u32 = OUTSIDE_BRICK;
const INSIDE: u32 = INSIDE_BRICK;
/// A brick that will get samples, before the slots are numbered.
const BANDED: u32 = u32::MAX - 2;

/// One sample: the signed distance and the triangle of the mesh closest to
/// the sample's point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Sample {
    distance: f32,
    triangle: u32,
}

/// What a query finds: the signed distance (negative inside), its
/// gradient, and a per-vertex quantity read at the closest surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSample {
    /// Signed distance, trilinear in the samples; ± the band where the
    /// query is farther than the band from the surface.
    pub distance: f32,
    /// Gradient of the distance; far outside zero, far inside the
    /// direction from the mesh's centre to the query.
    pub gradient: Vec3,
    /// The per-vertex values at the samples' closest points, trilinear;
    /// the caller's far value away from the band.
    pub value: Vec3,
}

/// How big a band field is before it is built, to bound the work.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BandFootprint {
    /// Bricks in the table over the mesh's box.
    pub table_bricks: u64,
    /// Bricks with samples.
    pub sampled_bricks: u64,
}

impl BandFootprint {
    /// Samples the field stores.
    pub fn samples(&self) -> u64 {
        self.sampled_bricks * SAMPLES_PER_BRICK as u64
    }

    /// Bytes the field holds (the table and the samples).
    pub fn bytes(&self) -> u64 {
        self.table_bricks * 4 + self.samples() * std::mem::size_of::<Sample>() as u64
    }
}

/// The lattice of bricks over a mesh's box: brick `b` holds the samples
/// at `origin + (4 b + (0..4)³) · spacing`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Lattice {
    origin: Vec3,
    spacing: f32,
    bricks: UVec3,
}

/// A narrow-band signed distance field (see the module documentation).
#[derive(Clone, Debug)]
pub struct NarrowBandField {
    lattice: Lattice,
    band: f32,
    table: Vec<u32>,
    samples: Vec<Sample>,
    mesh: TriangleMesh,
    centre: Vec3,
}

impl NarrowBandField {
    /// How many bricks the table over `mesh` and its band holds and how
    /// many get samples, without computing any distance.
    ///
    /// Panics if `spacing` or `band` is not positive and finite.
    pub fn footprint(mesh: &TriangleMesh, spacing: f32, band: f32) -> BandFootprint {
        let lattice = Lattice::covering(mesh, spacing, band);
        let table = banded_table(mesh, &lattice, band);
        BandFootprint {
            table_bricks: table.len() as u64,
            sampled_bricks: table.iter().filter(|&&e| e == BANDED).count() as u64,
        }
    }

    /// Samples the band of `mesh` at `spacing`, exact within `band` of the
    /// surface, in parallel over bricks and deterministically (every sample
    /// is computed on its own).
    ///
    /// Panics if `spacing` or `band` is not positive and finite, or a
    /// triangle refers to a missing vertex.
    pub fn build(mesh: &TriangleMesh, spacing: f32, band: f32) -> NarrowBandField {
        let lattice = Lattice::covering(mesh, spacing, band);
        let mut table = banded_table(mesh, &lattice, band);
        let banded: Vec<usize> = (0..table.len()).filter(|&b| table[b] == BANDED).collect();
        for (slot, &brick) in banded.iter().enumerate() {
            table[brick] = slot as u32;
        }
        fill_unbanded(&mut table, lattice.bricks);
        let surface = Surface::new(mesh);
        let samples = banded
            .par_iter()
            .flat_map_iter(|&brick| surface.brick_samples(&lattice, lattice.brick_at(brick)))
            .collect();
        let (low, high) = mesh.bounds();
        NarrowBandField {
            lattice,
            band,
            table,
            samples,
            mesh: mesh.clone(),
            centre: 0.5 * (low + high),
        }
    }

    /// The distance within which samples are exact.
    pub fn band(&self) -> f32 {
        self.band
    }

    /// The lattice's first sample point: sample `(i, j, k)` of brick `b`
    /// lies at `origin + (4 b + (i, j, k)) · spacing`.
    pub fn origin(&self) -> Vec3 {
        self.lattice.origin
    }

    /// The distance between neighbouring samples.
    pub fn spacing(&self) -> f32 {
        self.lattice.spacing
    }

    /// Bricks of the table along each axis.
    pub fn bricks(&self) -> UVec3 {
        self.lattice.bricks
    }

    /// The table, one entry per brick (x fastest, then y, then z): the slot
    /// of the brick's samples, or [`OUTSIDE_BRICK`] or [`INSIDE_BRICK`] for
    /// a brick without samples.
    pub fn table(&self) -> &[u32] {
        &self.table
    }

    /// The samples, 64 per slot (x fastest within the brick): each its
    /// signed distance and the index of the triangle closest to its point.
    pub fn samples(&self) -> impl ExactSizeIterator<Item = (f32, u32)> + '_ {
        self.samples.iter().map(|s| (s.distance, s.triangle))
    }

    /// The centre of the mesh's box: deep inside, the gradient points away
    /// from it.
    pub fn centre(&self) -> Vec3 {
        self.centre
    }

    /// The mesh the field was built from.
    pub fn mesh(&self) -> &TriangleMesh {
        &self.mesh
    }

    /// The box the table covers, `(min, max)`; everything beyond is outside.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let size = (self.lattice.bricks * BRICK_SIDE).as_vec3() * self.lattice.spacing;
        (self.lattice.origin, self.lattice.origin + size)
    }

    /// Memory held by the field in bytes.
    pub fn byte_size(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.table.len() * 4
            + self.samples.len() * std::mem::size_of::<Sample>()
            + self.mesh.triangles.len() * 12
            + self.mesh.vertices.len() * 12
    }

    /// The distance, its gradient and `vertex_values` (one per vertex of
    /// the mesh the field was built from) read at the closest surface
    /// point, at `point`; away from the band the distance is ± the band and
    /// the value is `far_value`.
    pub fn sample(&self, point: Vec3, vertex_values: &[Vec3], far_value: Vec3) -> SurfaceSample {
        let (cell, t, corners) = match self.lookup(point) {
            Lookup::Far(entry) => return self.far(entry, point, far_value),
            Lookup::Near { cell, t, corners } => (cell, t, corners),
        };
        let mut distance = 0.0;
        let mut gradient = Vec3::ZERO;
        let mut value = Vec3::ZERO;
        for (corner, sample) in corners.into_iter().enumerate() {
            let offset = corner_offset(corner);
            let [wx, wy, wz] = corner_weights(offset, t);
            let slope = |axis: usize| if offset[axis] == 1 { 1.0 } else { -1.0 };
            let sample_point = self.lattice.point(cell + offset);
            distance += wx * wy * wz * sample.distance;
            gradient += sample.distance
                * Vec3::new(slope(0) * wy * wz, wx * slope(1) * wz, wx * wy * slope(2));
            value += wx * wy * wz * self.surface_value(sample, sample_point, vertex_values);
        }
        SurfaceSample {
            distance,
            gradient: gradient / self.lattice.spacing,
            value,
        }
    }

    /// The distance alone at `point`, the same bits as
    /// [`NarrowBandField::sample`]'s: a cheap first test for contact.
    pub fn distance(&self, point: Vec3) -> f32 {
        match self.lookup(point) {
            Lookup::Far(INSIDE) => -self.band,
            Lookup::Far(_) => self.band,
            Lookup::Near { t, corners, .. } => {
                let mut distance = 0.0;
                for (corner, sample) in corners.into_iter().enumerate() {
                    let [wx, wy, wz] = corner_weights(corner_offset(corner), t);
                    distance += wx * wy * wz * sample.distance;
                }
                distance
            }
        }
    }

    /// The cell around `point` and its eight samples, or the table entry of
    /// a brick without samples that one of its corners falls in.
    fn lookup(&self, point: Vec3) -> Lookup {
        let g = (point - self.lattice.origin) / self.lattice.spacing;
        let points = (self.lattice.bricks * BRICK_SIDE).as_vec3();
        if !(g.cmpge(Vec3::ZERO).all() && g.cmplt(points - Vec3::ONE).all()) {
            return Lookup::Far(OUTSIDE);
        }
        let cell = g.floor().as_uvec3();
        let mut corners = [Sample::default(); 8];
        for (corner, slot) in corners.iter_mut().enumerate() {
            let at = cell + corner_offset(corner);
            match self.sample_at(at) {
                Some(sample) => *slot = sample,
                None => {
                    let brick = at / BRICK_SIDE;
                    return Lookup::Far(self.table[self.lattice.index(brick)]);
                }
            }
        }
        let t = (g - cell.as_vec3()).clamp(Vec3::ZERO, Vec3::ONE);
        Lookup::Near { cell, t, corners }
    }

    /// The sample at lattice point `at`, if its brick has samples.
    fn sample_at(&self, at: UVec3) -> Option<Sample> {
        let brick = at / BRICK_SIDE;
        let slot = self.table[self.lattice.index(brick)];
        (slot < BANDED).then(|| {
            self.samples[slot as usize * SAMPLES_PER_BRICK + brick_index(at - brick * BRICK_SIDE)]
        })
    }

    /// What a query away from the band finds, in a brick whose table entry
    /// is `entry`.
    fn far(&self, entry: u32, point: Vec3, far_value: Vec3) -> SurfaceSample {
        if entry == INSIDE {
            SurfaceSample {
                distance: -self.band,
                gradient: (point - self.centre).normalize_or_zero(),
                value: far_value,
            }
        } else {
            SurfaceSample {
                distance: self.band,
                gradient: Vec3::ZERO,
                value: far_value,
            }
        }
    }

    /// A per-vertex quantity at the point of a sample's triangle closest to
    /// the sample's point.
    fn surface_value(&self, sample: Sample, sample_point: Vec3, vertex_values: &[Vec3]) -> Vec3 {
        let corners = self.mesh.triangles[sample.triangle as usize];
        let [a, b, c] = corners.map(|i| self.mesh.vertices[i as usize]);
        let [u, v, w] = closest_on_triangle(sample_point, a, b, c).weights;
        let [va, vb, vc] = corners.map(|i| vertex_values[i as usize]);
        va * u + vb * v + vc * w
    }
}

/// What a query finds in the table.
enum Lookup {
    /// A corner of the cell lies in a brick without samples, with this entry.
    Far(u32),
    /// The cell at `cell` with its eight samples, `t` of the way along its
    /// edges.
    Near {
        cell: UVec3,
        t: Vec3,
        corners: [Sample; 8],
    },
}

/// The trilinear weights of the cell corner at `offset`, `t` of the way.
fn corner_weights(offset: UVec3, t: Vec3) -> [f32; 3] {
    std::array::from_fn(|axis| {
        if offset[axis] == 1 {
            t[axis]
        } else {
            1.0 - t[axis]
        }
    })
}

/// The lattice offset of cell corner `corner` (bit 0: x, 1: y, 2: z).
fn corner_offset(corner: usize) -> UVec3 {
    UVec3::new(
        corner as u32 & 1,
        (corner as u32 >> 1) & 1,
        corner as u32 >> 2,
    )
}

impl Lattice {
    /// Bricks over the mesh's box grown by the band's reach, with at least
    /// one brick without samples on every side, anchored at whole bricks
    /// from the world's origin so that the frames of a sequence share
    /// samples' positions.
    fn covering(mesh: &TriangleMesh, spacing: f32, band: f32) -> Lattice {
        assert!(
            spacing.is_finite() && spacing > 0.0,
            "band spacing must be positive, got {spacing}"
        );
        assert!(
            band.is_finite() && band > 0.0,
            "band width must be positive, got {band}"
        );
        let brick = BRICK_SIDE as f32 * spacing;
        let reach = Vec3::splat(reach(spacing, band));
        let (low, high) = mesh.bounds();
        let first = ((low - reach) / brick).floor() - Vec3::ONE;
        let last = ((high + reach) / brick).floor() + Vec3::ONE;
        let bricks = (last - first + Vec3::ONE).max(Vec3::ONE);
        assert!(
            bricks.max_element() < 1.0e6,
            "band table too fine: {bricks} bricks; use a larger spacing"
        );
        Lattice {
            origin: first * brick,
            spacing,
            bricks: bricks.as_uvec3(),
        }
    }

    fn len(&self) -> usize {
        [self.bricks.y, self.bricks.z]
            .into_iter()
            .try_fold(self.bricks.x as usize, |n, d| n.checked_mul(d as usize))
            .expect("band table has too many bricks; use a larger spacing")
    }

    fn index(&self, brick: UVec3) -> usize {
        let (nx, ny) = (self.bricks.x as usize, self.bricks.y as usize);
        (brick.z as usize * ny + brick.y as usize) * nx + brick.x as usize
    }

    fn point(&self, at: UVec3) -> Vec3 {
        self.origin + at.as_vec3() * self.spacing
    }

    fn brick_at(&self, index: usize) -> UVec3 {
        let (nx, ny) = (self.bricks.x as usize, self.bricks.y as usize);
        UVec3::new(
            (index % nx) as u32,
            (index / nx % ny) as u32,
            (index / (nx * ny)) as u32,
        )
    }

    /// The bricks a box touches, clamped to the table.
    fn bricks_touching(&self, low: Vec3, high: Vec3) -> (UVec3, UVec3) {
        let brick = BRICK_SIDE as f32 * self.spacing;
        let last = self.bricks.as_ivec3() - IVec3::ONE;
        let to_brick = |p: Vec3| {
            ((p - self.origin) / brick)
                .floor()
                .as_ivec3()
                .clamp(IVec3::ZERO, last)
                .as_uvec3()
        };
        (to_brick(low), to_brick(high))
    }
}

/// A brick's sample at `local` (x fastest).
fn brick_index(local: UVec3) -> usize {
    let side = BRICK_SIDE as usize;
    (local.z as usize * side + local.y as usize) * side + local.x as usize
}

/// How far from a triangle's box samples are needed: the band, plus a
/// cell's diagonal so that a point within the band has all eight corners.
fn reach(spacing: f32, band: f32) -> f32 {
    band + spacing * 3f32.sqrt()
}

/// The table with every brick that holds a sample within the reach of a
/// triangle marked [`BANDED`], the rest [`OUTSIDE`].
fn banded_table(mesh: &TriangleMesh, lattice: &Lattice, band: f32) -> Vec<u32> {
    let mut table = vec![OUTSIDE; lattice.len()];
    let half_extent = 0.5 * (BRICK_SIDE - 1) as f32 * lattice.spacing;
    let brick_half_diagonal = Vec3::splat(half_extent);
    // A brick holds a sample within the reach of a triangle only if its
    // centre is within the reach plus its half-diagonal.
    let within = reach(lattice.spacing, band) + half_extent * 3f32.sqrt();
    let reach = Vec3::splat(reach(lattice.spacing, band));
    for triangle in &mesh.triangles {
        let corners = triangle.map(|i| mesh.vertices[i as usize]);
        let low = corners[0].min(corners[1]).min(corners[2]) - reach;
        let high = corners[0].max(corners[1]).max(corners[2]) + reach;
        let (first, last) = lattice.bricks_touching(low, high);
        for z in first.z..=last.z {
            for y in first.y..=last.y {
                for x in first.x..=last.x {
                    let brick = UVec3::new(x, y, z);
                    let centre = lattice.point(brick * BRICK_SIDE) + brick_half_diagonal;
                    let [a, b, c] = corners;
                    if closest_on_triangle(centre, a, b, c).point.distance(centre) <= within {
                        table[lattice.index(brick)] = BANDED;
                    }
                }
            }
        }
    }
    table
}

/// Marks every brick without samples that the table's border reaches
/// through other such bricks (six neighbours) [`OUTSIDE`], the rest
/// [`INSIDE`]; bricks with samples keep their slots.
fn fill_unbanded(table: &mut [u32], bricks: UVec3) {
    let lattice = Lattice {
        origin: Vec3::ZERO,
        spacing: 1.0,
        bricks,
    };
    let mut reached = vec![false; table.len()];
    let mut queue = VecDeque::new();
    for (index, entry) in table.iter().enumerate() {
        let brick = lattice.brick_at(index);
        let border = brick.cmpeq(UVec3::ZERO).any() || brick.cmpeq(bricks - UVec3::ONE).any();
        if border && *entry == OUTSIDE {
            reached[index] = true;
            queue.push_back(brick);
        }
    }
    while let Some(brick) = queue.pop_front() {
        for step in [
            IVec3::X,
            IVec3::NEG_X,
            IVec3::Y,
            IVec3::NEG_Y,
            IVec3::Z,
            IVec3::NEG_Z,
        ] {
            let next = brick.as_ivec3() + step;
            if next.cmplt(IVec3::ZERO).any() || next.cmpge(bricks.as_ivec3()).any() {
                continue;
            }
            let index = lattice.index(next.as_uvec3());
            if table[index] == OUTSIDE && !reached[index] {
                reached[index] = true;
                queue.push_back(next.as_uvec3());
            }
        }
    }
    for (entry, reached) in table.iter_mut().zip(reached) {
        if *entry == OUTSIDE && !reached {
            *entry = INSIDE;
        }
    }
}

/// A mesh ready for closest-point queries with signs: its tree and the
/// angle-weighted pseudo-normals of its faces, edges and corners.
struct Surface {
    bvh: Bvh,
    triangles: Vec<[u32; 3]>,
    face_normals: Vec<Vec3>,
    /// Per triangle, the pseudo-normal of the edge opposite each corner.
    edge_normals: Vec<[Vec3; 3]>,
    vertex_normals: Vec<Vec3>,
}

impl Surface {
    fn new(mesh: &TriangleMesh) -> Surface {
        let corners = |t: &[u32; 3]| t.map(|i| mesh.vertices[i as usize]);
        let face_normals: Vec<Vec3> = mesh
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = corners(t);
                (b - a).cross(c - a).normalize_or_zero()
            })
            .collect();
        let mut vertex_normals = vec![Vec3::ZERO; mesh.vertices.len()];
        let mut edges: HashMap<(u32, u32), Vec3> = HashMap::new();
        for (t, &normal) in mesh.triangles.iter().zip(&face_normals) {
            let points = corners(t);
            for corner in 0..3 {
                let (next, previous) = ((corner + 1) % 3, (corner + 2) % 3);
                let angle = (points[next] - points[corner])
                    .angle_between(points[previous] - points[corner]);
                if angle.is_finite() {
                    vertex_normals[t[corner] as usize] += angle * normal;
                }
                *edges.entry(edge_key(t[next], t[previous])).or_default() += normal;
            }
        }
        let edge_normals = mesh
            .triangles
            .iter()
            .map(|t| {
                std::array::from_fn(|corner| {
                    edges[&edge_key(t[(corner + 1) % 3], t[(corner + 2) % 3])]
                })
            })
            .collect();
        Surface {
            bvh: Bvh::new(mesh),
            triangles: mesh.triangles.clone(),
            face_normals,
            edge_normals,
            vertex_normals,
        }
    }

    /// The samples of one brick, x fastest.
    fn brick_samples(&self, lattice: &Lattice, brick: UVec3) -> Vec<Sample> {
        let mut hint = None;
        let side = BRICK_SIDE as usize;
        (0..SAMPLES_PER_BRICK)
            .map(|index| {
                let local = UVec3::new(
                    (index % side) as u32,
                    (index / side % side) as u32,
                    (index / (side * side)) as u32,
                );
                let p = lattice.point(brick * BRICK_SIDE + local);
                let sample = self.sample(p, hint);
                hint = Some(sample.1);
                sample.0
            })
            .collect()
    }

    /// The sample at `p` and the tree-order triangle it found (a hint for
    /// the next point).
    fn sample(&self, p: Vec3, hint: Option<u32>) -> (Sample, u32) {
        let Some((_, tree_triangle)) = self.bvh.closest(p, hint) else {
            return (Sample::default(), 0);
        };
        let [a, b, c] = self.bvh.triangles[tree_triangle as usize];
        let source = self.bvh.sources[tree_triangle as usize];
        let closest = closest_on_triangle(p, a, b, c);
        let normal = self.feature_normal(source, closest.weights);
        let offset = p - closest.point;
        let distance = offset.length();
        let signed = if offset.dot(normal) < 0.0 {
            -distance
        } else {
            distance
        };
        let sample = Sample {
            distance: signed,
            triangle: source,
        };
        (sample, tree_triangle)
    }

    /// The pseudo-normal of the feature of triangle `t` that barycentric
    /// `weights` lie on.
    fn feature_normal(&self, t: u32, weights: [f32; 3]) -> Vec3 {
        let t = t as usize;
        let zeros: Vec<usize> = (0..3).filter(|&i| weights[i] == 0.0).collect();
        match zeros.as_slice() {
            [] => self.face_normals[t],
            [opposite] => self.edge_normals[t][*opposite],
            _ => {
                let corner = (0..3).find(|&i| weights[i] != 0.0).unwrap_or(0);
                self.vertex_normals[self.triangles[t][corner] as usize]
            }
        }
    }
}

/// An undirected edge's key.
fn edge_key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}
