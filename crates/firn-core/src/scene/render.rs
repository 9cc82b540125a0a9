//! How a scene is pictured: the camera and the render settings.
//!
//! Plain data like the rest of the model; the renderer (`firn-render`) turns
//! it into images.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// The camera: a fixed view, an automatic framing, a turntable orbit or a
/// keyed path with eased sweeps between views.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Eye position; `None` frames the domain automatically.
    pub position: Option<Vec3>,
    /// Point looked at; `None` looks at the centre of the domain.
    pub look_at: Option<Vec3>,
    /// Vertical field of view in degrees.
    pub fov_degrees: f32,
    /// Turntable: the eye circles the vertical axis through `look_at`.
    pub orbit: Option<Orbit>,
    /// Keyed views; between two keys the camera sweeps with ease-in/ease-out
    /// (seed 002, section 2.4). Empty: the fixed view above.
    pub path: Vec<CameraKey>,
}

impl Default for Camera {
    fn default() -> Camera {
        Camera {
            position: None,
            look_at: None,
            fov_degrees: 40.0,
            orbit: None,
            path: Vec::new(),
        }
    }
}

/// A turntable orbit around the vertical axis through the look-at point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Orbit {
    /// Rotation speed in degrees per simulated second (positive: counter-clockwise seen from above).
    pub degrees_per_second: f32,
}

/// One view on a camera path.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraKey {
    /// Simulated time at which the camera is exactly here.
    pub time: f64,
    /// Eye position.
    pub position: Vec3,
    /// Point looked at.
    pub look_at: Vec3,
}

/// How particles, colliders and the container are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RenderStyle {
    /// Depth-tested sphere-shaded sprites with a colour ramp (the thesis' look, section 5.7).
    Points,
    /// Particle mass deposited on a density grid and ray-marched with single
    /// scattering (the thesis' future work, chapter 7).
    Volume,
    /// Camera-facing soft round sprites with additive blending (seed 002).
    Billboards,
    /// Ribbons through each particle's recent positions, fading with age (seed 002).
    Trails,
    /// The snow's reconstructed surface (the `mesh` format's triangles),
    /// shaded like the colliders.
    Surface,
}

/// The particle quantity mapped onto the colour ramp.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ColorBy {
    /// Current density m_p / V_p.
    Density,
    /// Plastic volume change J_P (below 1: compacted).
    PlasticJ,
    /// Speed |v_p|.
    Speed,
    /// |x|, |y|, |z| over the domain as red, green, blue (seed 002).
    Position,
    /// One colour for all particles.
    Uniform,
}

/// Pictures made while a scene runs (and by `firn render` afterwards).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderSettings {
    /// Render a picture per frame during `firn run`.
    pub enabled: bool,
    /// Styles to render; each gets its own image sequence and animation.
    pub styles: Vec<RenderStyle>,
    /// Image width and height in pixels.
    pub size: [u32; 2],
    /// Quantity on the colour ramp.
    pub color_by: ColorBy,
    /// Draw a labelled legend of the colour ramp.
    pub legend: bool,
    /// Particle sprite radius in metres; `None`: half the particle spacing.
    pub point_radius: Option<f32>,
    /// Positions kept per particle for trails.
    pub trail_length: u32,
    /// Smooth trails with a uniform cubic B-spline (seed 002's future work).
    pub smooth_trails: bool,
}

impl Default for RenderSettings {
    fn default() -> RenderSettings {
        RenderSettings {
            enabled: true,
            styles: vec![RenderStyle::Points],
            size: [960, 540],
            color_by: ColorBy::Density,
            legend: false,
            point_radius: None,
            trail_length: 16,
            smooth_trails: true,
        }
    }
}

impl Camera {
    /// Eye position and look-at point at time `t`, given the automatic
    /// framing used where the scene leaves them open.
    pub fn view_at(&self, t: f64, automatic: (Vec3, Vec3)) -> (Vec3, Vec3) {
        if let Some(view) = self.path_view_at(t) {
            return view;
        }
        let look_at = self.look_at.unwrap_or(automatic.1);
        let position = self.position.unwrap_or(automatic.0);
        match self.orbit {
            Some(orbit) => {
                let angle = (orbit.degrees_per_second as f64 * t).to_radians() as f32;
                let offset = glam::Quat::from_rotation_y(angle) * (position - look_at);
                (look_at + offset, look_at)
            }
            None => (position, look_at),
        }
    }

    /// The eased view along the keyed path, if there is one.
    fn path_view_at(&self, t: f64) -> Option<(Vec3, Vec3)> {
        let (first, last) = (self.path.first()?, self.path.last()?);
        if t <= first.time {
            return Some((first.position, first.look_at));
        }
        if t >= last.time {
            return Some((last.position, last.look_at));
        }
        let next = self.path.partition_point(|key| key.time <= t);
        let (a, b) = (self.path[next - 1], self.path[next]);
        let s = ease_in_out(((t - a.time) / (b.time - a.time)) as f32);
        Some((a.position.lerp(b.position, s), a.look_at.lerp(b.look_at, s)))
    }
}

/// Smoothstep ease-in/ease-out: zero slope at both ends of a sweep.
pub fn ease_in_out(s: f32) -> f32 {
    let s = s.clamp(0.0, 1.0);
    s * s * (3.0 - 2.0 * s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(time: f64, x: f32) -> CameraKey {
        CameraKey {
            time,
            position: Vec3::new(x, 1.0, 5.0),
            look_at: Vec3::ZERO,
        }
    }

    #[test]
    fn path_eases_in_and_out_between_keys() {
        let camera = Camera {
            path: vec![key(0.0, 0.0), key(1.0, 10.0)],
            ..Camera::default()
        };
        let auto = (Vec3::ONE, Vec3::ZERO);
        let x = |t: f64| camera.view_at(t, auto).0.x;
        assert_eq!(x(-1.0), 0.0);
        assert_eq!(x(0.5), 5.0);
        assert_eq!(x(2.0), 10.0);
        // Slow near the keys, fast in the middle.
        assert!(x(0.1) < 1.0 && x(0.9) > 9.0);
        assert!(x(0.55) - x(0.45) > 1.4);
    }

    #[test]
    fn orbit_keeps_distance_and_height() {
        let camera = Camera {
            position: Some(Vec3::new(0.0, 2.0, 4.0)),
            look_at: Some(Vec3::ZERO),
            orbit: Some(Orbit {
                degrees_per_second: 90.0,
            }),
            ..Camera::default()
        };
        let (eye, _) = camera.view_at(1.0, (Vec3::ONE, Vec3::ZERO));
        assert!((eye - Vec3::new(4.0, 2.0, 0.0)).length() < 1e-5, "{eye}");
    }
}
