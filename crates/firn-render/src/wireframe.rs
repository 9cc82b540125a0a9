//! The container drawn as a wireframe box (thesis section 5.7): its twelve
//! edges as depth-tested lines of constant width on screen.

use glam::{Vec2, Vec3};

use crate::camera::CameraView;
use crate::film::Film;

/// Colour of the container's edges (linear RGB).
pub const EDGE_COLOR: Vec3 = Vec3::new(0.55, 0.58, 0.64);

/// A line segment on screen with depth at both ends.
#[derive(Clone, Copy)]
pub(crate) struct ScreenSegment {
    pub(crate) a: Vec2,
    pub(crate) b: Vec2,
    pub(crate) depth_a: f32,
    pub(crate) depth_b: f32,
}

/// Draws the edges of the box from `min` to `max`, `width` samples wide.
pub fn draw_box(film: &mut Film, camera: &CameraView, min: Vec3, max: Vec3, width: f32) {
    let segments: Vec<ScreenSegment> = box_edges(min, max)
        .into_iter()
        .filter_map(|(a, b)| project_segment(camera, a, b))
        .collect();
    let half = 0.5 * width;
    film.par_bands(|_, mut band| {
        let rows = band.rows();
        for segment in &segments {
            let (top, bottom) = (
                segment.a.y.min(segment.b.y) - half,
                segment.a.y.max(segment.b.y) + half,
            );
            let y_start = top.floor().max(rows.start as f32) as u32;
            let y_end = (bottom.ceil().min(rows.end as f32)).max(0.0) as u32;
            for y in y_start..y_end {
                let center_y = y as f32 + 0.5;
                let (x_start, x_end) = segment.columns_near(center_y, half, band.width);
                for x in x_start..x_end {
                    let pixel = Vec2::new(x as f32 + 0.5, center_y);
                    if let Some(depth) = segment.depth_within(pixel, half) {
                        // Pull lines slightly forward so they win against
                        // surfaces they lie on.
                        band.depth_write(x, y, depth * 0.999, EDGE_COLOR);
                    }
                }
            }
        }
    });
}

impl ScreenSegment {
    /// Columns of row `y` that can lie within `half` of the segment.
    pub(crate) fn columns_near(&self, y: f32, half: f32, width: u32) -> (u32, u32) {
        let direction = self.b - self.a;
        let (mut left, mut right) = (self.a.x.min(self.b.x), self.a.x.max(self.b.x));
        if direction.y.abs() > 1e-6 {
            // Limit to where the segment crosses rows y ± half (plus the width).
            let slope = direction.x / direction.y;
            let span = half * (1.0 + slope.abs());
            let at = self.a.x + (y - self.a.y) * slope;
            left = left.max(at - span);
            right = right.min(at + span);
        }
        let start = (left - half).floor().max(0.0) as u32;
        let end = ((right + half).ceil().max(0.0) as u32).min(width);
        (start, end)
    }

    /// Squared distance from `pixel` to the segment, and the parameter in
    /// [0, 1] of the nearest point.
    pub(crate) fn closest(&self, pixel: Vec2) -> (f32, f32) {
        let direction = self.b - self.a;
        let length_squared = direction.length_squared().max(1e-12);
        let s = ((pixel - self.a).dot(direction) / length_squared).clamp(0.0, 1.0);
        ((pixel - (self.a + direction * s)).length_squared(), s)
    }

    /// Depth of the segment at `pixel` if the pixel lies within `half` of it.
    fn depth_within(&self, pixel: Vec2, half: f32) -> Option<f32> {
        let (distance_squared, s) = self.closest(pixel);
        (distance_squared <= half * half)
            .then_some(self.depth_a + (self.depth_b - self.depth_a) * s)
    }
}

/// The twelve edges of an axis-aligned box.
fn box_edges(min: Vec3, max: Vec3) -> Vec<(Vec3, Vec3)> {
    let corner = |index: usize| {
        Vec3::new(
            if index & 1 == 0 { min.x } else { max.x },
            if index & 2 == 0 { min.y } else { max.y },
            if index & 4 == 0 { min.z } else { max.z },
        )
    };
    let mut edges = Vec::with_capacity(12);
    for index in 0..8 {
        for bit in [1, 2, 4] {
            if index & bit == 0 {
                edges.push((corner(index), corner(index | bit)));
            }
        }
    }
    edges
}

/// Projects a world segment, clipped against a near plane in front of the eye.
pub(crate) fn project_segment(camera: &CameraView, a: Vec3, b: Vec3) -> Option<ScreenSegment> {
    let near = 1e-3;
    let depth = |p: Vec3| (p - camera.eye).dot(camera.forward);
    let (mut a, mut b) = (a, b);
    let (da, db) = (depth(a), depth(b));
    if da < near && db < near {
        return None;
    }
    if da < near {
        a = a + (b - a) * ((near - da) / (db - da));
    } else if db < near {
        b = b + (a - b) * ((near - db) / (da - db));
    }
    let (pa, pb) = (camera.project(a)?, camera.project(b)?);
    Some(ScreenSegment {
        a: pa.pixel,
        b: pb.pixel,
        depth_a: pa.depth,
        depth_b: pb.depth,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_box_has_twelve_distinct_edges() {
        let edges = box_edges(Vec3::ZERO, Vec3::ONE);
        assert_eq!(edges.len(), 12);
        for (a, b) in edges {
            assert!(((a - b).length() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn edges_are_drawn_on_the_box_outline_only() {
        let camera = CameraView::look_at(Vec3::new(0.5, 0.5, 4.0), Vec3::splat(0.5), 30.0, 64, 64);
        let mut film = Film::new(64, 64);
        draw_box(&mut film, &camera, Vec3::ZERO, Vec3::ONE, 1.5);
        let corner = camera
            .project(Vec3::new(0.0, 0.0, 1.0))
            .expect("visible")
            .pixel;
        let at = |p: Vec2| film.depth[(p.y as u32 * 64 + p.x as u32) as usize];
        assert!(at(corner + Vec2::new(3.0, -0.2)).is_finite());
        assert!(at(Vec2::new(32.0, 32.0)).is_infinite());
    }
}
