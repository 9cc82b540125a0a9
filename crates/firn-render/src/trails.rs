//! Style `trails` (seed 002, section 2.3): each particle's recent positions
//! drawn as a ribbon facing the camera that fades with age, added onto the
//! picture. Optionally the ribbon follows a uniform cubic B-spline through
//! the positions instead of the raw polyline (the seed's named future work).

use glam::Vec3;

use crate::camera::CameraView;
use crate::film::Film;
use crate::ramp::Coloring;
use crate::wireframe::{ScreenSegment, project_segment};

/// Curve points per B-spline span when smoothing.
const SAMPLES_PER_SPAN: usize = 4;

/// Recent positions of every particle, oldest first.
#[derive(Clone, Copy, Debug)]
pub struct Trails<'a> {
    /// `capacity` slots per particle; particle p's trail is
    /// `points[p * capacity..][..lengths[p]]`.
    pub points: &'a [Vec3],
    /// Slots per particle.
    pub capacity: usize,
    /// Valid positions per particle.
    pub lengths: &'a [u32],
}

impl<'a> Trails<'a> {
    /// Particle `p`'s positions, oldest first.
    pub fn of(&self, p: usize) -> &'a [Vec3] {
        &self.points[p * self.capacity..][..self.lengths[p] as usize]
    }
}

/// How the ribbons look.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RibbonLook {
    /// Ribbon width in samples.
    pub width: f32,
    /// Colour scale at the newest end.
    pub intensity: f32,
    /// Follow a uniform cubic B-spline through the positions.
    pub smooth: bool,
}

/// A ribbon piece on screen with the age-faded colour at both ends.
#[derive(Clone, Copy)]
struct RibbonPiece {
    segment: ScreenSegment,
    color_a: Vec3,
    color_b: Vec3,
}

/// Adds every particle's trail onto the film.
pub fn draw_trails(
    film: &mut Film,
    camera: &CameraView,
    trails: &Trails<'_>,
    coloring: &Coloring<'_>,
    look: &RibbonLook,
) {
    let pieces = ribbon_pieces(camera, trails, coloring, look);
    let half = 0.5 * look.width;
    let bins = film.bin_discs(pieces.iter().map(|piece| {
        let segment = piece.segment;
        let center = 0.5 * (segment.a + segment.b);
        (center, 0.5 * (segment.b - segment.a).length() + half + 1.0)
    }));
    film.par_bands(|band_index, band| {
        let rows = band.rows();
        for &index in &bins[band_index] {
            let piece = pieces[index as usize];
            let segment = piece.segment;
            let top = (segment.a.y.min(segment.b.y) - half).floor();
            let bottom = (segment.a.y.max(segment.b.y) + half).ceil();
            let y_start = top.max(rows.start as f32) as u32;
            let y_end = bottom.min(rows.end as f32).max(0.0) as u32;
            for y in y_start..y_end {
                let center_y = y as f32 + 0.5;
                let (x_start, x_end) = segment.columns_near(center_y, half, band.width);
                for x in x_start..x_end {
                    let pixel = glam::Vec2::new(x as f32 + 0.5, center_y);
                    let (distance_squared, s) = segment.closest(pixel);
                    let edge = 1.0 - distance_squared / (half * half);
                    let index = band.index(x, y);
                    let depth = segment.depth_a + (segment.depth_b - segment.depth_a) * s;
                    if edge <= 0.0 || depth >= band.depth[index] {
                        continue;
                    }
                    band.color[index] += piece.color_a.lerp(piece.color_b, s) * edge;
                }
            }
        }
    });
}

/// Projected, coloured pieces of all ribbons, in particle order.
fn ribbon_pieces(
    camera: &CameraView,
    trails: &Trails<'_>,
    coloring: &Coloring<'_>,
    look: &RibbonLook,
) -> Vec<RibbonPiece> {
    let mut pieces = Vec::new();
    for particle in 0..trails.lengths.len() {
        let raw = trails.of(particle);
        let Some(&newest) = raw.last() else {
            continue;
        };
        let curve = if look.smooth {
            smooth_curve(raw)
        } else {
            raw.to_vec()
        };
        let color = coloring.color(particle, newest) * look.intensity;
        let spans = curve.len().saturating_sub(1).max(1) as f32;
        for (i, pair) in curve.windows(2).enumerate() {
            let Some(segment) = project_segment(camera, pair[0], pair[1]) else {
                continue;
            };
            // Older parts fade out: the fade grows with the square of the age fraction.
            let fade = |t: f32| t * t;
            pieces.push(RibbonPiece {
                segment,
                color_a: color * fade(i as f32 / spans),
                color_b: color * fade((i + 1) as f32 / spans),
            });
        }
    }
    pieces
}

/// Points along the uniform cubic B-spline whose control points are
/// `points`, with the end points repeated so the curve starts and ends at
/// them.
pub fn smooth_curve(points: &[Vec3]) -> Vec<Vec3> {
    if points.len() < 3 {
        return points.to_vec();
    }
    let (first, last) = (points[0], points[points.len() - 1]);
    let controls: Vec<Vec3> = [first, first]
        .into_iter()
        .chain(points.iter().copied())
        .chain([last, last])
        .collect();
    let mut curve = Vec::with_capacity(controls.len() * SAMPLES_PER_SPAN);
    for window in controls.windows(4) {
        for step in 0..SAMPLES_PER_SPAN {
            let t = step as f32 / SAMPLES_PER_SPAN as f32;
            curve.push(cubic_bspline(window, t));
        }
    }
    curve.push(last);
    curve
}

/// The uniform cubic B-spline span of four control points at t in [0, 1].
fn cubic_bspline(p: &[Vec3], t: f32) -> Vec3 {
    let t2 = t * t;
    let t3 = t2 * t;
    let b0 = (1.0 - t).powi(3) / 6.0;
    let b1 = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
    let b2 = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
    let b3 = t3 / 6.0;
    p[0] * b0 + p[1] * b1 + p[2] * b2 + p[3] * b3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smoothing_keeps_the_ends_and_a_straight_line_straight() {
        let line: Vec<Vec3> = (0..6).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
        let curve = smooth_curve(&line);
        assert_eq!(curve.first(), line.first());
        assert_eq!(curve.last(), line.last());
        assert!(curve.iter().all(|p| p.y == 0.0 && p.z == 0.0));
        assert!(curve.windows(2).all(|w| w[1].x >= w[0].x));
    }

    #[test]
    fn smoothing_rounds_a_corner() {
        let corner = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)];
        let curve = smooth_curve(&corner);
        // The curve cuts the corner: no sample reaches (1, 0).
        assert!(curve.iter().all(|p| (*p - Vec3::X).length() > 0.1));
    }

    #[test]
    fn bspline_weights_sum_to_one() {
        let p = [Vec3::ONE; 4];
        for t in [0.0, 0.3, 0.7, 1.0] {
            assert!((cubic_bspline(&p, t) - Vec3::ONE).length() < 1e-6);
        }
    }
}
