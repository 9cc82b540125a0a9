//! Style `billboards` (seed 002, section 2.3): every particle a
//! camera-facing soft round sprite, added onto the picture (additive
//! blending), so dense regions glow. Opaque surfaces of the stage hide
//! sprites behind them; sprites do not hide each other.
//!
//! Like the points, sprites are binned by band and added in particle order,
//! so the sums, and the picture, do not depend on the thread count.

use glam::{Vec2, Vec3};

use crate::camera::CameraView;
use crate::film::{Film, disc_samples};
use crate::ramp::Coloring;

/// Smallest sprite radius in samples.
const MIN_RADIUS_SAMPLES: f32 = 1.0;

/// A sprite on the film.
#[derive(Clone, Copy)]
struct Splat {
    center: Vec2,
    radius: f32,
    depth: f32,
    color: Vec3,
}

/// Adds every particle as a soft sprite of `radius` metres whose centre adds
/// `intensity` times its colour.
pub fn draw_billboards(
    film: &mut Film,
    camera: &CameraView,
    positions: &[Vec3],
    coloring: &Coloring<'_>,
    radius: f32,
    intensity: f32,
) {
    let splats: Vec<Splat> = positions
        .iter()
        .enumerate()
        .filter_map(|(index, &position)| {
            let projected = camera.project(position)?;
            Some(Splat {
                center: projected.pixel,
                radius: (radius * projected.scale).max(MIN_RADIUS_SAMPLES),
                depth: projected.depth,
                color: coloring.color(index, position) * intensity,
            })
        })
        .collect();
    let bins = film.bin_discs(splats.iter().map(|splat| (splat.center, splat.radius)));
    film.par_bands(|band_index, band| {
        for &index in &bins[band_index] {
            let splat = splats[index as usize];
            for sample in disc_samples(splat.center, splat.radius, band.rows(), band.width) {
                let index = band.index(sample.x, sample.y);
                if splat.depth >= band.depth[index] {
                    continue;
                }
                let falloff = (1.0 - sample.r2) * (1.0 - sample.r2);
                band.color[index] += splat.color * falloff;
            }
        }
    });
}
