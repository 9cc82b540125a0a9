//! The viewer's camera: orbit, pan and zoom about a target point, with
//! mouse and keyboard, frame-all, and the scene's own camera (its keyed
//! path with ease-in/ease-out sweeps, or its orbit) as an option.

use firn_core::Scene;
use firn_render::camera::automatic_framing;
use glam::{Mat4, Vec3, Vec4};

use crate::draw::ViewSetup;

/// Radians of orbit per pixel dragged.
const ORBIT_RADIANS_PER_PIXEL: f32 = 0.006;
/// Radians of orbit per second a key is held.
const ORBIT_RADIANS_PER_SECOND: f32 = 1.2;
/// Distance factor per zoom step (a wheel notch or a key press).
const ZOOM_PER_STEP: f32 = 0.9;
/// Pitch stays this far from straight up or down, where yaw degenerates.
const PITCH_LIMIT: f32 = 1.54;
/// The near clipping plane as a fraction of the distance to the target.
const NEAR_PER_DISTANCE: f32 = 0.01;
/// The far clipping plane as a multiple of the distance to the target.
const FAR_PER_DISTANCE: f32 = 50.0;

/// A camera circling a target point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// The point looked at and orbited.
    pub target: Vec3,
    /// Distance from the target to the eye.
    pub distance: f32,
    /// Angle about the vertical axis, radians (0: looking along −z).
    pub yaw: f32,
    /// Angle above the horizontal, radians.
    pub pitch: f32,
    /// Vertical field of view in degrees.
    pub fov_degrees: f32,
}

impl OrbitCamera {
    /// A camera at `eye` looking at `target`.
    pub fn looking(eye: Vec3, target: Vec3, fov_degrees: f32) -> OrbitCamera {
        let offset = eye - target;
        let distance = offset.length().max(1e-6);
        OrbitCamera {
            target,
            distance,
            yaw: offset.x.atan2(offset.z),
            pitch: (offset.y / distance).clamp(-1.0, 1.0).asin(),
            fov_degrees,
        }
    }

    /// The scene's camera at time `t` for a view of aspect `aspect` (its
    /// keyed path, orbit or fixed eye; automatic framing where it is silent).
    pub fn of_scene(scene: &Scene, t: f64, aspect: f32) -> OrbitCamera {
        let camera = &scene.camera;
        let domain = &scene.domain;
        let automatic = automatic_framing(domain.min, domain.max, camera.fov_degrees, aspect);
        let (eye, target) = camera.view_at(t, automatic);
        OrbitCamera::looking(eye, target, camera.fov_degrees)
    }

    /// Looks at the whole box from `min` to `max` from the current direction.
    pub fn frame_all(&mut self, min: Vec3, max: Vec3, aspect: f32) {
        let (eye, target) = automatic_framing(min, max, self.fov_degrees, aspect);
        self.target = target;
        self.distance = (eye - target).length();
    }

    /// The eye position.
    pub fn eye(&self) -> Vec3 {
        let (sin_yaw, cos_yaw) = self.yaw.sin_cos();
        let (sin_pitch, cos_pitch) = self.pitch.sin_cos();
        self.target + self.distance * Vec3::new(sin_yaw * cos_pitch, sin_pitch, cos_yaw * cos_pitch)
    }

    /// Orbits by a mouse drag of (`dx`, `dy`) pixels.
    pub fn orbit_by_pixels(&mut self, dx: f32, dy: f32) {
        self.orbit(-dx * ORBIT_RADIANS_PER_PIXEL, dy * ORBIT_RADIANS_PER_PIXEL);
    }

    /// Orbits while keys are held: `yaw_keys` and `pitch_keys` are −1, 0 or
    /// +1, for `seconds` of holding.
    pub fn orbit_by_keys(&mut self, yaw_keys: f32, pitch_keys: f32, seconds: f32) {
        let angle = ORBIT_RADIANS_PER_SECOND * seconds;
        self.orbit(yaw_keys * angle, pitch_keys * angle);
    }

    /// Turns about the target by `yaw` and `pitch` radians.
    fn orbit(&mut self, yaw: f32, pitch: f32) {
        self.yaw += yaw;
        self.pitch = (self.pitch + pitch).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// Moves the target (and the eye with it) so that what was under the
    /// mouse stays under it after a drag of (`dx`, `dy`) pixels in a view
    /// `height` pixels tall.
    pub fn pan_by_pixels(&mut self, dx: f32, dy: f32, height: f32) {
        let metres_per_pixel =
            2.0 * self.distance * (0.5 * self.fov_degrees.to_radians()).tan() / height.max(1.0);
        let forward = (self.target - self.eye()).normalize();
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        let up = right.cross(forward);
        self.target += metres_per_pixel * (-dx * right + dy * up);
    }

    /// Moves towards the target by `steps` zoom steps (negative: away).
    pub fn zoom(&mut self, steps: f32) {
        self.distance *= ZOOM_PER_STEP.powf(steps);
    }

    /// What the renderer needs for a target of `size` pixels whose left
    /// `covered` pixels are hidden (by the panel): the picture is framed and
    /// centred on the visible rest, and the sky still fills the whole target.
    pub fn view_setup(&self, size: [u32; 2], covered: u32) -> ViewSetup {
        let width = size[0].max(1) as f32;
        let covered = (covered as f32).min(width - 1.0);
        let visible = width - covered;
        let aspect = visible / size[1].max(1) as f32;
        let fov_y_radians = self.fov_degrees.to_radians();
        let eye = self.eye();
        // wgpu's clip space is DirectX's: depth 0..1, y up.
        let projection = glam::camera::rh::proj::directx::perspective(
            fov_y_radians,
            aspect,
            NEAR_PER_DISTANCE * self.distance,
            FAR_PER_DISTANCE * self.distance,
        );
        // Squeeze clip-space x into the visible part: x' = s x + t w.
        let (scale, shift) = (visible / width, covered / width);
        let onto_visible = Mat4::from_cols(
            Vec4::new(scale, 0.0, 0.0, 0.0),
            Vec4::Y,
            Vec4::Z,
            Vec4::new(shift, 0.0, 0.0, 1.0),
        );
        let view = glam::camera::rh::view::look_at_mat4(eye, self.target, Vec3::Y);
        ViewSetup {
            view_projection: onto_visible * projection * view,
            eye,
            fov_y_radians,
            size,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-4
    }

    #[test]
    fn looking_reproduces_the_eye() {
        let eye = Vec3::new(1.0, 2.0, 3.0);
        let camera = OrbitCamera::looking(eye, Vec3::new(0.5, 0.2, -0.1), 40.0);
        assert!(close(camera.eye(), eye), "{}", camera.eye());
    }

    #[test]
    fn orbit_keeps_distance_and_target() {
        let mut camera = OrbitCamera::looking(Vec3::new(0.0, 1.0, 4.0), Vec3::ZERO, 40.0);
        let before = camera.eye();
        camera.orbit_by_pixels(120.0, -40.0);
        assert!(!close(camera.eye(), before));
        assert!((camera.eye().length() - before.length()).abs() < 1e-4);
    }

    #[test]
    fn pitch_stops_short_of_the_pole() {
        let mut camera = OrbitCamera::looking(Vec3::new(0.0, 1.0, 4.0), Vec3::ZERO, 40.0);
        camera.orbit_by_keys(0.0, 1.0, 100.0);
        assert!(camera.pitch <= PITCH_LIMIT);
        assert!(camera.view_setup([100, 100], 0).view_projection.is_finite());
    }

    #[test]
    fn the_target_projects_to_the_centre_and_panning_moves_it_with_the_mouse() {
        let mut camera = OrbitCamera::looking(Vec3::new(2.0, 1.0, 4.0), Vec3::ZERO, 40.0);
        let clip = camera
            .view_setup([200, 100], 0)
            .view_projection
            .project_point3(Vec3::ZERO);
        assert!(clip.x.abs() < 1e-5 && clip.y.abs() < 1e-5);
        // Dragging right by 50 pixels moves the old target 50 pixels right:
        // half the half-width of a 200-pixel view is NDC x = 0.5.
        camera.pan_by_pixels(50.0, 0.0, 100.0);
        let moved = camera
            .view_setup([200, 100], 0)
            .view_projection
            .project_point3(Vec3::ZERO);
        assert!((moved.x - 0.5).abs() < 1e-3, "{moved}");
    }

    #[test]
    fn the_picture_is_centred_beside_the_panel() {
        let camera = OrbitCamera::looking(Vec3::new(2.0, 1.0, 4.0), Vec3::ZERO, 40.0);
        // A 100-pixel panel on a 400-pixel target: the visible centre is at
        // pixel 250, NDC x = 0.25.
        let matrix = camera.view_setup([400, 100], 100).view_projection;
        let target = matrix.project_point3(Vec3::ZERO);
        assert!((target.x - 0.25).abs() < 1e-5, "{target}");
        // The visible part has the aspect of 300x100, not 400x100.
        let alone = camera.view_setup([300, 100], 0).view_projection;
        let point = Vec3::new(0.3, 0.2, 0.1);
        let (beside, own) = (matrix.project_point3(point), alone.project_point3(point));
        assert!((beside.x - (0.25 + 0.75 * own.x)).abs() < 1e-5);
        assert!((beside.y - own.y).abs() < 1e-5);
    }

    #[test]
    fn zoom_in_and_out_are_inverse() {
        let mut camera = OrbitCamera::looking(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 40.0);
        camera.zoom(3.0);
        assert!(camera.distance < 5.0);
        camera.zoom(-3.0);
        assert!((camera.distance - 5.0).abs() < 1e-4);
    }

    #[test]
    fn frame_all_shows_every_corner() {
        let mut camera = OrbitCamera::looking(Vec3::new(30.0, 0.0, 0.0), Vec3::splat(9.0), 40.0);
        let (min, max) = (Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0));
        camera.frame_all(min, max, 2.0);
        let matrix = camera.view_setup([200, 100], 0).view_projection;
        for corner in 0..8 {
            let p = Vec3::select(
                glam::BVec3::new(corner & 1 == 0, corner & 2 == 0, corner & 4 == 0),
                min,
                max,
            );
            let ndc = matrix.project_point3(p);
            assert!(ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0, "{p} at {ndc}");
        }
    }
}
