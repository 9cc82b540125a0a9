//! A snow frame as OpenVDB volumes: the `density` of the snow in kg/m³ and,
//! optionally, its `surface` as a narrow-band level set.
//!
//! - `density`: each particle's mass spread over the 3³ voxels around it with
//!   quadratic B-spline weights (the kernel of the volume renderer's deposit
//!   and of the solver's P2G), divided by the voxel volume. The weights sum
//!   to 1, so the voxels hold the particles' mass exactly: Σ ρ·voxel³ = Σ m.
//! - `surface`: where `density` crosses half the snow's rest density. The
//!   crossings on voxel edges (linearly interpolated) give surface points;
//!   each voxel within [`HALF_WIDTH_VOXELS`] of one holds its distance to the
//!   nearest, negative inside. Deeper inside the blocks are −background tiles.
//!
//! Voxel (i, j, k) is the box `min + [i, i+1]·voxel` of the domain, so with
//! the default voxel size the voxels are the solver's grid cells.

use std::ops::Range;

use firn_core::math::bspline::quadratic_weights;
use firn_io::vdb::{LEAF_DIM, voxel_of};
use firn_io::{FloatGrid, GridClass, Leaf};
use glam::{IVec3, Vec3};

/// Half width of the surface's narrow band, in voxels (OpenVDB's default).
pub const HALF_WIDTH_VOXELS: f32 = 3.0;

/// The surface is where the density crosses this share of the rest density.
pub const SURFACE_DENSITY_SHARE: f32 = 0.5;

/// The volumes of particles at `positions` with `masses` on voxels of edge
/// `voxel` that tile space from `min`: the `density` grid, and the `surface`
/// level set of snow of `rest_density` if `level_set`.
pub fn snow_volumes(
    positions: &[Vec3],
    masses: &[f32],
    min: Vec3,
    voxel: f32,
    level_set: Option<f32>,
) -> Vec<FloatGrid> {
    let density = density_grid(positions, masses, min, voxel);
    match level_set {
        Some(rest_density) => {
            let surface = surface_level_set(&density, SURFACE_DENSITY_SHARE * rest_density);
            vec![density, surface]
        }
        None => vec![density],
    }
}

/// `value` as the shortest decimal that reads back as it, in double
/// precision: a voxel size of 0.025 in the scene is 0.025 in the file, not
/// 0.025000000372529.
fn decimal(value: f32) -> f64 {
    value.to_string().parse().unwrap_or(f64::from(value))
}

/// The `density` grid (kg/m³) of particles deposited on voxels of edge
/// `voxel` that tile space from `min`.
pub fn density_grid(positions: &[Vec3], masses: &[f32], min: Vec3, voxel: f32) -> FloatGrid {
    let centre = min + Vec3::splat(0.5 * voxel);
    let voxel_size = decimal(voxel);
    let origin = min.to_array().map(|c| decimal(c) + 0.5 * voxel_size);
    let mut grid = FloatGrid::new("density", GridClass::FogVolume, voxel_size, origin, 0.0);
    let inverse_volume = 1.0 / (voxel * voxel * voxel);
    for (&position, &mass) in positions.iter().zip(masses) {
        let weights = quadratic_weights((position - centre) / voxel);
        let amount = mass * inverse_volume;
        for (leaf_origin, ranges) in leaf_blocks(weights.base, 3) {
            let leaf = grid.leaf_mut(leaf_origin);
            for_each_voxel(&ranges, |ijk| {
                let [i, j, k] = (ijk - weights.base).to_array().map(|c| c as usize);
                leaf.add(
                    local_offset(leaf_origin, ijk),
                    amount * weights.weight(i, j, k),
                );
            });
        }
    }
    grid
}

/// The narrow-band level set `surface` of the snow in `density`, whose
/// surface is where the density crosses `iso`.
pub fn surface_level_set(density: &FloatGrid, iso: f32) -> FloatGrid {
    let voxel = density.voxel_size as f32;
    let mut distances = FloatGrid::new(
        "distance",
        GridClass::FogVolume,
        density.voxel_size,
        density.origin,
        HALF_WIDTH_VOXELS,
    );
    for point in surface_points(density, iso) {
        spread_distance(&mut distances, point);
    }
    let background = HALF_WIDTH_VOXELS * voxel;
    let mut surface = FloatGrid::new(
        "surface",
        GridClass::LevelSet,
        density.voxel_size,
        density.origin,
        background,
    );
    for (origin, band) in distances.leaves() {
        let mut leaf = Leaf::filled(background);
        for offset in 0..firn_io::vdb::LEAF_VOXELS {
            let inside = density_at(density, origin, offset) > iso;
            let distance = band.value(offset).min(HALF_WIDTH_VOXELS) * voxel;
            let value = if inside { -distance } else { distance };
            leaf.set(offset, value, distance < background);
        }
        *surface.leaf_mut(origin) = leaf;
    }
    fill_inside(&mut surface, density, iso);
    surface
}

/// The points (in voxel units) where the density crosses `iso` on the edges
/// between an inside voxel and its six neighbours.
fn surface_points(density: &FloatGrid, iso: f32) -> Vec<Vec3> {
    let mut points = Vec::new();
    for (origin, leaf) in density.leaves() {
        for offset in 0..firn_io::vdb::LEAF_VOXELS {
            let inside = leaf.value(offset);
            if inside <= iso {
                continue;
            }
            let ijk = IVec3::from_array(voxel_of(origin, offset));
            for step in [
                IVec3::X,
                IVec3::NEG_X,
                IVec3::Y,
                IVec3::NEG_Y,
                IVec3::Z,
                IVec3::NEG_Z,
            ] {
                let outside = density.value((ijk + step).to_array());
                if outside <= iso {
                    let t = (inside - iso) / (inside - outside);
                    points.push(ijk.as_vec3() + step.as_vec3() * t);
                }
            }
        }
    }
    points
}

/// Lowers the distance of the voxels within the band around `point` to
/// their distance from it (in voxels).
fn spread_distance(distances: &mut FloatGrid, point: Vec3) {
    let reach = HALF_WIDTH_VOXELS.ceil() as i32;
    let nearest = point.round().as_ivec3();
    for (leaf_origin, ranges) in leaf_blocks(nearest - IVec3::splat(reach), 2 * reach + 1) {
        let leaf = distances.leaf_mut(leaf_origin);
        for_each_voxel(&ranges, |ijk| {
            let offset = local_offset(leaf_origin, ijk);
            let distance = ijk.as_vec3().distance(point);
            if distance < leaf.value(offset) {
                leaf.set(offset, distance, false);
            }
        });
    }
}

/// Makes the density's leaves that lie wholly inside, beyond the band, tiles
/// of −background.
fn fill_inside(surface: &mut FloatGrid, density: &FloatGrid, iso: f32) {
    let inside_value = -surface.background;
    for (origin, leaf) in density.leaves() {
        let wholly_inside = (0..firn_io::vdb::LEAF_VOXELS).all(|offset| leaf.value(offset) > iso);
        if wholly_inside && surface.leaf(origin).is_none() {
            surface.set_tile(origin, inside_value);
        }
    }
}

/// The density of voxel `offset` of the leaf at `origin` (0 where none).
fn density_at(density: &FloatGrid, origin: [i32; 3], offset: usize) -> f32 {
    density.leaf(origin).map_or(0.0, |leaf| leaf.value(offset))
}

/// The offset in the leaf at `leaf_origin` of voxel `ijk`.
fn local_offset(leaf_origin: [i32; 3], ijk: IVec3) -> usize {
    Leaf::offset((ijk - IVec3::from_array(leaf_origin)).to_array())
}

/// Calls `visit` with each voxel of the box `ranges`.
fn for_each_voxel(ranges: &[Range<i32>; 3], mut visit: impl FnMut(IVec3)) {
    for i in ranges[0].clone() {
        for j in ranges[1].clone() {
            for k in ranges[2].clone() {
                visit(IVec3::new(i, j, k));
            }
        }
    }
}

/// The cube of `width` voxels from `low`, cut along leaf boundaries: each
/// piece's leaf origin and voxel ranges, so a leaf is looked up once per
/// piece rather than once per voxel.
fn leaf_blocks(low: IVec3, width: i32) -> Vec<([i32; 3], [Range<i32>; 3])> {
    let [xs, ys, zs] = low.to_array().map(|start| axis_pieces(start, width));
    let mut blocks = Vec::with_capacity(xs.len() * ys.len() * zs.len());
    for x in &xs {
        for y in &ys {
            for z in &zs {
                let origin = [x.start, y.start, z.start].map(|c| c & !(LEAF_DIM - 1));
                blocks.push((origin, [x.clone(), y.clone(), z.clone()]));
            }
        }
    }
    blocks
}

/// `start..start + width` cut where a leaf ends.
fn axis_pieces(start: i32, width: i32) -> Vec<Range<i32>> {
    let end = start + width;
    let mut pieces = Vec::with_capacity(2);
    let mut from = start;
    while from < end {
        let leaf_end = (from & !(LEAF_DIM - 1)) + LEAF_DIM;
        let to = leaf_end.min(end);
        pieces.push(from..to);
        from = to;
    }
    pieces
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Particles of `spacing` filling a ball, each of mass ρ·spacing³.
    fn ball(center: Vec3, radius: f32, spacing: f32, rho: f32) -> (Vec<Vec3>, Vec<f32>) {
        let n = (radius / spacing).ceil() as i32;
        let positions: Vec<Vec3> = (-n..=n)
            .flat_map(|i| (-n..=n).flat_map(move |j| (-n..=n).map(move |k| IVec3::new(i, j, k))))
            .map(|ijk| center + ijk.as_vec3() * spacing)
            .filter(|p| p.distance(center) <= radius)
            .collect();
        let masses = vec![rho * spacing.powi(3); positions.len()];
        (positions, masses)
    }

    #[test]
    fn pieces_split_at_leaf_boundaries() {
        assert_eq!(axis_pieces(6, 3), vec![6..8, 8..9]);
        assert_eq!(axis_pieces(-2, 3), vec![-2..0, 0..1]);
        assert_eq!(axis_pieces(0, 8), vec![0..8]);
        assert_eq!(leaf_blocks(IVec3::new(7, 0, -1), 2).len(), 4);
    }

    #[test]
    fn the_density_holds_the_particles_mass() {
        let (positions, masses) = ball(Vec3::new(0.53, 0.41, 0.6), 0.2, 0.01, 400.0);
        let voxel = 0.02;
        let grid = density_grid(&positions, &masses, Vec3::ZERO, voxel);
        let deposited: f64 = grid
            .leaves()
            .flat_map(|(_, leaf)| (0..512).map(move |offset| f64::from(leaf.value(offset))))
            .sum::<f64>()
            * f64::from(voxel).powi(3);
        let total: f64 = masses.iter().map(|&m| f64::from(m)).sum();
        assert!(
            (deposited / total - 1.0).abs() < 1e-4,
            "{deposited} vs {total}"
        );
        let centre = ((Vec3::new(0.53, 0.41, 0.6) / voxel) - 0.5)
            .round()
            .as_ivec3();
        let rho = grid.value(centre.to_array());
        assert!((rho - 400.0).abs() < 4.0, "density inside {rho}");
    }

    #[test]
    fn the_surface_is_a_signed_distance_near_the_ball() {
        let center = Vec3::new(0.5, 0.5, 0.5);
        let (positions, masses) = ball(center, 0.2, 0.01, 400.0);
        let voxel = 0.02;
        let density = density_grid(&positions, &masses, Vec3::ZERO, voxel);
        let surface = surface_level_set(&density, 200.0);
        let index = |p: Vec3| ((p / voxel) - 0.5).round().as_ivec3().to_array();
        assert_eq!(surface.value(index(center)), -surface.background);
        assert_eq!(
            surface.value(index(center + Vec3::X * 0.4)),
            surface.background
        );
        let just_inside = surface.value(index(center + Vec3::X * 0.17));
        assert!(
            just_inside < 0.0 && just_inside > -surface.background,
            "{just_inside}"
        );
        let at_surface = surface.value(index(center + Vec3::Y * 0.2));
        assert!(at_surface.abs() < voxel, "{at_surface}");
    }
}
