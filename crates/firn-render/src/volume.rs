//! Style `volume`, the thesis' named future work (chapter 7): particle mass
//! deposited onto a density grid and ray-marched as a participating medium.
//!
//! - Extinction follows Beer-Lambert with σ_t = κ ρ, so packed snow (high
//!   density) is more opaque than powder.
//! - Single scattering of a directional key light, attenuated by the
//!   transmittance towards the light (self-shadowing), plus an ambient sky
//!   term; a high albedo gives the bright snow look. A second, softer
//!   transmittance lobe stands in for multiple scattering, which keeps thick
//!   snow from going grey inside.
//! - The snow shadows the ground and colliders through the same grid.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::camera::CameraView;
use crate::film::Film;
use crate::stage::{Light, slab_interval};

/// Largest number of voxels in a density grid; coarser voxels beyond it.
const MAX_VOXELS: usize = 1 << 24;
/// Ray-march step as a fraction of the voxel size.
const STEP_FRACTION: f32 = 0.5;
/// Transmittance below which a ray is treated as opaque.
const OPAQUE: f32 = 2e-3;

/// The optical properties of the snow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SnowLook {
    /// Extinction per unit density, κ in σ_t = κ ρ (m² per kg).
    pub extinction_per_density: f32,
    /// Single-scattering albedo (close to 1 for snow).
    pub albedo: Vec3,
    /// Weight of the soft multiple-scattering lobe of the light transmittance.
    pub multiple_scattering: f32,
}

impl SnowLook {
    /// Optical properties that give snow of `reference_density` a mean free
    /// path of `mean_free_path` metres.
    pub fn for_density(reference_density: f32, mean_free_path: f32) -> SnowLook {
        SnowLook {
            extinction_per_density: 1.0 / (reference_density * mean_free_path),
            albedo: Vec3::new(0.96, 0.975, 0.99),
            multiple_scattering: 0.35,
        }
    }
}

/// Mass density (kg/m³) on a regular grid of voxels.
#[derive(Clone, Debug)]
pub struct DensityGrid {
    /// Position of voxel (0, 0, 0)'s centre.
    pub origin: Vec3,
    /// Edge length of a voxel.
    pub voxel: f32,
    /// Voxels per axis.
    pub dims: [usize; 3],
    /// Density per voxel, x fastest.
    pub density: Vec<f32>,
}

impl DensityGrid {
    /// Deposits particle masses with quadratic B-spline weights onto voxels of
    /// edge `voxel` (enlarged if the particles' bounds would need more than
    /// [`MAX_VOXELS`]). Deterministic: particles are added in order.
    pub fn deposit(positions: &[Vec3], masses: &[f32], voxel: f32) -> DensityGrid {
        let (min, max) = bounds(positions);
        let mut voxel = voxel.max(1e-9);
        let count = |voxel: f32| {
            let extent = ((max - min) / voxel).ceil() + Vec3::splat(5.0);
            (extent.x * extent.y * extent.z) as usize
        };
        while count(voxel) > MAX_VOXELS {
            voxel *= 1.25;
        }
        let origin = min - Vec3::splat(2.0 * voxel);
        let extent = ((max - min) / voxel).ceil() + Vec3::splat(5.0);
        let dims = [extent.x as usize, extent.y as usize, extent.z as usize];
        let mut density = vec![0.0f32; dims[0] * dims[1] * dims[2]];
        let inverse_volume = 1.0 / (voxel * voxel * voxel);
        for (&position, &mass) in positions.iter().zip(masses) {
            let local = (position - origin) / voxel;
            let base = (local - Vec3::splat(0.5)).floor();
            let fraction = local - base;
            let (wx, wy, wz) = (
                quadratic_weights(fraction.x),
                quadratic_weights(fraction.y),
                quadratic_weights(fraction.z),
            );
            let [bx, by, bz] = [base.x as usize, base.y as usize, base.z as usize];
            for (k, wk) in wz.iter().enumerate() {
                for (j, wj) in wy.iter().enumerate() {
                    let row = ((bz + k) * dims[1] + by + j) * dims[0] + bx;
                    for (i, wi) in wx.iter().enumerate() {
                        density[row + i] += mass * wi * wj * wk * inverse_volume;
                    }
                }
            }
        }
        DensityGrid {
            origin,
            voxel,
            dims,
            density,
        }
    }

    /// Lower and upper corner of the region the grid covers.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let half = Vec3::splat(0.5 * self.voxel);
        let size = Vec3::new(
            self.dims[0] as f32,
            self.dims[1] as f32,
            self.dims[2] as f32,
        );
        (self.origin - half, self.origin - half + size * self.voxel)
    }

    /// Density at `point`, trilinearly interpolated (0 outside).
    pub fn sample(&self, point: Vec3) -> f32 {
        let local = (point - self.origin) / self.voxel;
        let base = local.floor();
        let f = local - base;
        let [dx, dy, dz] = self.dims;
        if base.x < 0.0 || base.y < 0.0 || base.z < 0.0 {
            return 0.0;
        }
        let (x, y, z) = (base.x as usize, base.y as usize, base.z as usize);
        if x + 1 >= dx || y + 1 >= dy || z + 1 >= dz {
            return 0.0;
        }
        let at = |i: usize, j: usize, k: usize| self.density[((z + k) * dy + y + j) * dx + x + i];
        let along_x = |j, k| at(0, j, k) + (at(1, j, k) - at(0, j, k)) * f.x;
        let along_y = |k| along_x(0, k) + (along_x(1, k) - along_x(0, k)) * f.y;
        along_y(0) + (along_y(1) - along_y(0)) * f.z
    }

    /// Optical depth ∫ κ ρ ds from `point` towards the light, to the grid's edge.
    pub fn optical_depth_to(&self, point: Vec3, direction: Vec3, look: &SnowLook) -> f32 {
        let (min, max) = self.bounds();
        let Some((near, far)) = slab_interval(point, direction, min, max) else {
            return 0.0;
        };
        let step = self.voxel * STEP_FRACTION * 2.0;
        let mut s = near.max(0.0) + 0.5 * step;
        let mut sum = 0.0;
        while s < far {
            sum += self.sample(point + direction * s);
            s += step;
        }
        sum * step * look.extinction_per_density
    }
}

/// Quadratic B-spline weights of the three voxels around a particle whose
/// position is `fraction` voxels past the first of them (in [0.5, 1.5)).
fn quadratic_weights(fraction: f32) -> [f32; 3] {
    let d0 = fraction;
    let d1 = fraction - 1.0;
    let d2 = fraction - 2.0;
    [
        0.5 * (1.5 - d0).powi(2),
        0.75 - d1 * d1,
        0.5 * (1.5 + d2).powi(2),
    ]
}

/// Axis-aligned bounds of the points (a unit box at the origin for none).
fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    if points.is_empty() {
        return (Vec3::ZERO, Vec3::ONE);
    }
    points.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(min, max), &p| (min.min(p), max.max(p)),
    )
}

/// Transmittance towards the light with the soft multiple-scattering lobe.
fn light_transmittance(optical_depth: f32, look: &SnowLook) -> f32 {
    let soft = look.multiple_scattering;
    (1.0 - soft) * (-optical_depth).exp() + soft * (-0.25 * optical_depth).exp()
}

/// Fraction of key light reaching `point` through the snow (for surfaces).
pub fn surface_shadow(grid: &DensityGrid, look: &SnowLook, light: &Light, point: Vec3) -> f32 {
    light_transmittance(grid.optical_depth_to(point, light.direction, look), look)
}

/// Light transmittance at every voxel centre of a grid half as fine as `grid`.
struct LightField {
    coarse: DensityGrid,
}

impl LightField {
    fn new(grid: &DensityGrid, look: &SnowLook, light: &Light) -> LightField {
        let voxel = grid.voxel * 2.0;
        let (min, max) = grid.bounds();
        let dims = ((max - min) / voxel).ceil() + Vec3::ONE;
        let dims = [dims.x as usize, dims.y as usize, dims.z as usize];
        let origin = min;
        let slice = dims[0] * dims[1];
        let mut values = vec![0.0f32; slice * dims[2]];
        values
            .par_chunks_mut(slice)
            .enumerate()
            .for_each(|(z, plane)| {
                for (index, value) in plane.iter_mut().enumerate() {
                    let (x, y) = (index % dims[0], index / dims[0]);
                    let point = origin + Vec3::new(x as f32, y as f32, z as f32) * voxel;
                    let depth = grid.optical_depth_to(point, light.direction, look);
                    *value = light_transmittance(depth, look);
                }
            });
        LightField {
            coarse: DensityGrid {
                origin,
                voxel,
                dims,
                density: values,
            },
        }
    }

    fn at(&self, point: Vec3) -> f32 {
        self.coarse.sample(point)
    }
}

/// Ray-marches the snow over what `film` already holds (the stage), which
/// bounds each ray by its depth.
pub fn draw_volume(
    film: &mut Film,
    camera: &CameraView,
    grid: &DensityGrid,
    look: &SnowLook,
    light: &Light,
) {
    let light_field = LightField::new(grid, look, light);
    let (min, max) = grid.bounds();
    let step = grid.voxel * STEP_FRACTION;
    let ambient = light.ambient * 1.35;
    film.par_bands(|_, band| {
        for y in band.rows() {
            for x in 0..band.width {
                let direction = camera.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                let Some((near, far)) = slab_interval(camera.eye, direction, min, max) else {
                    continue;
                };
                let index = band.index(x, y);
                let surface = band.depth[index] / direction.dot(camera.forward);
                let end = far.min(surface);
                // A per-pixel offset of the first sample hides banding, and is
                // the same on every run.
                let mut s = near.max(0.0) + step * jitter(x, y);
                let mut transmittance = 1.0f32;
                let mut radiance = Vec3::ZERO;
                let mut first_hit = f32::INFINITY;
                while s < end && transmittance > OPAQUE {
                    let point = camera.eye + direction * s;
                    let density = grid.sample(point);
                    if density > 0.0 {
                        let alpha = 1.0 - (-look.extinction_per_density * density * step).exp();
                        let lit = light.color * light_field.at(point) + ambient;
                        radiance += transmittance * alpha * look.albedo * lit;
                        transmittance *= 1.0 - alpha;
                        if transmittance < 0.5 && first_hit.is_infinite() {
                            first_hit = s;
                        }
                    }
                    s += step;
                }
                band.color[index] = radiance + transmittance * band.color[index];
                if first_hit.is_finite() {
                    band.depth[index] = first_hit * direction.dot(camera.forward);
                }
            }
        }
    });
}

/// A fixed pseudo-random offset in [0, 1) per pixel.
fn jitter(x: u32, y: u32) -> f32 {
    let mut h = x.wrapping_mul(0x9E37_79B1) ^ y.wrapping_mul(0x85EB_CA77);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deposit_conserves_mass() {
        let positions: Vec<Vec3> = (0..500)
            .map(|i| Vec3::new((i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32) * 0.013)
            .collect();
        let masses = vec![0.002; positions.len()];
        let grid = DensityGrid::deposit(&positions, &masses, 0.01);
        let total: f32 = grid.density.iter().sum::<f32>() * grid.voxel.powi(3);
        assert!((total - 1.0).abs() < 1e-4, "mass {total}");
    }

    #[test]
    fn uniform_particles_give_their_density() {
        let spacing = 0.01;
        let mut positions = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                for k in 0..20 {
                    positions.push(Vec3::new(i as f32, j as f32, k as f32) * spacing);
                }
            }
        }
        let rho = 400.0;
        let masses = vec![rho * spacing.powi(3); positions.len()];
        let grid = DensityGrid::deposit(&positions, &masses, spacing);
        let inside = grid.sample(Vec3::splat(0.1));
        assert!((inside - rho).abs() < 1.0, "density {inside}");
        assert_eq!(grid.sample(Vec3::splat(2.0)), 0.0);
    }

    #[test]
    fn quadratic_weights_sum_to_one() {
        for fraction in [0.5, 0.8, 1.0, 1.49] {
            let sum: f32 = quadratic_weights(fraction).iter().sum();
            assert!((sum - 1.0).abs() < 1e-6);
        }
    }
}
