//! Style `points`, the thesis' look (section 5.7): every particle a
//! depth-tested sprite shaded as a small sphere, coloured by the ramp.
//!
//! Sprites are binned by the film bands they touch; each band draws its
//! sprites in particle order, so the picture does not depend on the thread
//! count.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::camera::CameraView;
use crate::film::{Film, disc_samples};
use crate::ramp::Coloring;
use crate::stage::Light;

/// Smallest sprite radius in samples, so far particles do not vanish between samples.
const MIN_RADIUS_SAMPLES: f32 = 0.7;

/// A particle projected onto the film.
#[derive(Clone, Copy)]
struct Sprite {
    center: Vec2,
    radius: f32,
    depth: f32,
    world_radius: f32,
    albedo: Vec3,
}

/// Draws `positions` as shaded spheres of `radius` metres.
pub fn draw_points(
    film: &mut Film,
    camera: &CameraView,
    positions: &[Vec3],
    coloring: &Coloring<'_>,
    radius: f32,
    light: &Light,
) {
    let sprites = project_sprites(camera, positions, coloring, radius);
    let bins = film.bin_discs(sprites.iter().map(|sprite| {
        let center = if sprite.depth.is_finite() {
            sprite.center
        } else {
            Vec2::NAN
        };
        (center, sprite.radius)
    }));
    let (right, up, forward) = (camera.right, camera.up, camera.forward);
    let view = -forward;
    let half_vector = (light.direction + view).normalize();
    film.par_bands(|band_index, band| {
        for &index in &bins[band_index] {
            let sprite = sprites[index as usize];
            for sample in disc_samples(sprite.center, sprite.radius, band.rows(), band.width) {
                let nz = (1.0 - sample.r2).sqrt();
                let depth = sprite.depth - sprite.world_radius * nz;
                let index = band.index(sample.x, sample.y);
                // Most samples of a dense ball are hidden: test before shading.
                if depth >= band.depth[index] {
                    continue;
                }
                let normal = sample.dx * right - sample.dy * up - nz * forward;
                band.depth[index] = depth;
                band.color[index] = shade_sphere(sprite.albedo, normal, half_vector, light);
            }
        }
    });
}

/// Lambert plus a soft Blinn-Phong highlight, lit by the key light and the sky.
fn shade_sphere(albedo: Vec3, normal: Vec3, half_vector: Vec3, light: &Light) -> Vec3 {
    let diffuse = normal.dot(light.direction).max(0.0);
    // Wrap the ambient term with the normal so sprites read as round even in shade.
    let sky = 0.6 + 0.4 * normal.y;
    let specular = power_24(normal.dot(half_vector).max(0.0)) * 0.18;
    albedo * (light.ambient * sky * 1.6 + light.color * diffuse * 0.85) + light.color * specular
}

/// x²⁴ by squaring (the highlight's Blinn-Phong exponent), much cheaper than `powf`.
fn power_24(x: f32) -> f32 {
    let x2 = x * x;
    let x4 = x2 * x2;
    let x8 = x4 * x4;
    let x16 = x8 * x8;
    x16 * x8
}

/// Projects every particle that lies in front of the camera.
fn project_sprites(
    camera: &CameraView,
    positions: &[Vec3],
    coloring: &Coloring<'_>,
    radius: f32,
) -> Vec<Sprite> {
    positions
        .par_iter()
        .enumerate()
        .map(|(index, &position)| {
            let projected = camera.project(position);
            projected.map_or(
                Sprite {
                    center: Vec2::ZERO,
                    radius: 0.0,
                    depth: f32::INFINITY,
                    world_radius: 0.0,
                    albedo: Vec3::ZERO,
                },
                |projected| Sprite {
                    center: projected.pixel,
                    radius: (radius * projected.scale).max(MIN_RADIUS_SAMPLES),
                    depth: projected.depth,
                    world_radius: radius,
                    albedo: coloring.color(index, position),
                },
            )
        })
        .collect()
}
