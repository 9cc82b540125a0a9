//! A pinhole camera: projection of points to pixels and rays through pixels.

use glam::{Vec2, Vec3};

/// Eye, orientation and field of view, fixed for one picture.
///
/// Pixel coordinates have their origin at the top-left corner of the image,
/// x to the right, y down; pixel (i, j) covers [i, i+1) × [j, j+1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraView {
    /// Eye position.
    pub eye: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit vector to the right of the image.
    pub right: Vec3,
    /// Unit vector to the top of the image.
    pub up: Vec3,
    /// tan(fov / 2) of the vertical field of view.
    pub tan_half_fov: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

/// A point projected onto the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projected {
    /// Position in pixels (may lie outside the image).
    pub pixel: Vec2,
    /// Distance along the view direction (positive in front of the eye).
    pub depth: f32,
    /// Pixels per metre at this depth.
    pub scale: f32,
}

impl CameraView {
    /// A camera at `eye` looking at `look_at` with a vertical field of view of
    /// `fov_degrees`, rendering `width` × `height` pixels. World +y is up.
    pub fn look_at(eye: Vec3, look_at: Vec3, fov_degrees: f32, width: u32, height: u32) -> Self {
        let forward = (look_at - eye).normalize_or(Vec3::NEG_Z);
        let side = forward.cross(Vec3::Y);
        // Looking straight up or down: any horizontal right vector will do.
        let right = if side.length_squared() > 1e-10 {
            side.normalize()
        } else {
            Vec3::X
        };
        let up = right.cross(forward);
        CameraView {
            eye,
            forward,
            right,
            up,
            tan_half_fov: (0.5 * fov_degrees.to_radians()).tan(),
            width,
            height,
        }
    }

    /// The same view rendered at `factor` times the resolution (for supersampling).
    pub fn scaled(&self, factor: u32) -> Self {
        CameraView {
            width: self.width * factor,
            height: self.height * factor,
            ..*self
        }
    }

    /// Pixels per unit of the image plane at distance 1.
    fn focal_pixels(&self) -> f32 {
        0.5 * self.height as f32 / self.tan_half_fov
    }

    /// Projects `point`; `None` when it lies behind (or too close to) the eye.
    pub fn project(&self, point: Vec3) -> Option<Projected> {
        let offset = point - self.eye;
        let depth = offset.dot(self.forward);
        if depth <= 1e-6 {
            return None;
        }
        let scale = self.focal_pixels() / depth;
        let pixel = Vec2::new(
            0.5 * self.width as f32 + offset.dot(self.right) * scale,
            0.5 * self.height as f32 - offset.dot(self.up) * scale,
        );
        Some(Projected {
            pixel,
            depth,
            scale,
        })
    }

    /// Unit direction of the ray through the image point `pixel` (pixel centres
    /// are at half-integer coordinates).
    pub fn ray(&self, pixel: Vec2) -> Vec3 {
        let focal = self.focal_pixels();
        let x = (pixel.x - 0.5 * self.width as f32) / focal;
        let y = (0.5 * self.height as f32 - pixel.y) / focal;
        (self.forward + x * self.right + y * self.up).normalize()
    }
}

/// The automatic view of a box from `min` to `max`: from the front-right and
/// somewhat above, far enough back that the whole box fits a vertical field
/// of view of `fov_degrees` at aspect ratio `aspect` (width / height).
/// Returns (eye, look-at).
pub fn automatic_framing(min: Vec3, max: Vec3, fov_degrees: f32, aspect: f32) -> (Vec3, Vec3) {
    let center = 0.5 * (min + max);
    let radius = 0.5 * (max - min).length();
    let half_vertical = 0.5 * fov_degrees.to_radians();
    let half_horizontal = (half_vertical.tan() * aspect).atan();
    let half_angle = half_vertical.min(half_horizontal);
    let distance = radius / half_angle.sin() * 0.92;
    let direction = Vec3::new(0.55, 0.42, 1.0).normalize();
    (center + direction * distance, center)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_point_projects_to_the_image_centre() {
        let camera = CameraView::look_at(Vec3::new(1.0, 2.0, 5.0), Vec3::ZERO, 40.0, 200, 100);
        let projected = camera.project(Vec3::ZERO).expect("in front");
        assert!((projected.pixel - Vec2::new(100.0, 50.0)).length() < 1e-4);
        assert!((projected.depth - Vec3::new(1.0, 2.0, 5.0).length()).abs() < 1e-5);
    }

    #[test]
    fn rays_and_projection_are_inverse() {
        let camera = CameraView::look_at(Vec3::new(3.0, 1.0, 2.0), Vec3::ZERO, 55.0, 320, 240);
        for pixel in [
            Vec2::new(10.5, 20.5),
            Vec2::new(300.0, 7.0),
            Vec2::new(160.0, 120.0),
        ] {
            let point = camera.eye + camera.ray(pixel) * 2.5;
            let back = camera.project(point).expect("in front");
            assert!(
                (back.pixel - pixel).length() < 1e-3,
                "{pixel} -> {}",
                back.pixel
            );
        }
    }

    #[test]
    fn up_is_up_and_points_behind_are_dropped() {
        let camera = CameraView::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 40.0, 100, 100);
        let above = camera.project(Vec3::new(0.0, 1.0, 0.0)).expect("in front");
        assert!(above.pixel.y < 50.0);
        let right = camera.project(Vec3::new(1.0, 0.0, 0.0)).expect("in front");
        assert!(right.pixel.x > 50.0);
        assert!(camera.project(Vec3::new(0.0, 0.0, 6.0)).is_none());
    }

    #[test]
    fn automatic_framing_shows_every_corner() {
        let (min, max) = (Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0));
        let (eye, target) = automatic_framing(min, max, 40.0, 16.0 / 9.0);
        let camera = CameraView::look_at(eye, target, 40.0, 160, 90);
        for corner in 0..8 {
            let p = Vec3::new(
                if corner & 1 == 0 { min.x } else { max.x },
                if corner & 2 == 0 { min.y } else { max.y },
                if corner & 4 == 0 { min.z } else { max.z },
            );
            let pixel = camera.project(p).expect("in front").pixel;
            assert!(
                (0.0..=160.0).contains(&pixel.x) && (0.0..=90.0).contains(&pixel.y),
                "corner {p} at {pixel}"
            );
        }
    }
}
