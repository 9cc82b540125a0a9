//! What a scene will cost, known from its description alone: how many
//! lattice points its bodies are filled from and about how many particles
//! they get, how long its first substep is and so how many substeps a
//! frame takes, how many frames it writes, and how many particles a flow's
//! emitters keep. Nothing is sampled or allocated, so a scene of any size
//! is estimated at once; the scene checks refuse what is past the limits
//! (`docs/scene-format.md`, "Limits") and the front doors compare the
//! memory that follows with the machine's.

use super::flow::SceneKind;
use super::model::{Body, Integrator, Scene, Shape, TimeStep};
use super::sampling::{lattice_points, particle_spacing};

/// Bytes the CPU snow solver holds per particle: its attributes, the space
/// to reorder them and the binning's entries (`firn_mpm`'s estimate uses
/// the same sizes, and a test there holds them equal).
pub const CPU_BYTES_PER_PARTICLE: u64 = 212;

/// What a scene will cost, before anything runs.
#[derive(Clone, Debug, PartialEq)]
pub struct WorkEstimate {
    /// One estimate per snow body, in scene order (none for a flow).
    pub bodies: Vec<BodyEstimate>,
    /// Particles at the start: the bodies' estimates summed, or the
    /// particle slots a flow's emitters keep.
    pub particles: u64,
    /// Lattice points the bodies are filled from, summed (each is tested
    /// once at the start); 0 for a flow.
    pub lattice_points: u64,
    /// Output frames after frame 0.
    pub frames: u64,
    /// The first substep of a snow scene; `None` for a flow, whose frames
    /// take a fixed `flow.substeps`.
    pub first_step: Option<FirstStep>,
}

/// What filling one body takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyEstimate {
    /// Lattice points covering its bounding box: the candidates tested.
    pub lattice_points: u64,
    /// Particles it gets, about: its volume over the volume a particle
    /// stands for, at most its lattice points.
    pub particles: u64,
}

/// The first substep of a snow scene, as the solver will take it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstStep {
    /// Its Δt in seconds.
    pub dt: f32,
    /// The fastest body's speed, m/s.
    pub speed: f32,
    /// The fastest elastic (P-)wave of the bodies' materials, m/s; 0 with
    /// the semi-implicit integrator, whose step it does not limit.
    pub wave_speed: f32,
    /// Substeps a frame takes at this Δt.
    pub substeps_per_frame: f64,
}

impl Scene {
    /// What this scene will cost (see [`WorkEstimate`]); sampling nothing.
    pub fn estimate(&self) -> WorkEstimate {
        let frames = u64::from(self.time.frame_count());
        if let SceneKind::Flow(settings) = &self.kind {
            let particles = settings.emitters.iter().fold(0u64, |sum, emitter| {
                sum.saturating_add(emitter.slots(self.time.duration))
            });
            return WorkEstimate {
                bodies: Vec::new(),
                particles,
                lattice_points: 0,
                frames,
                first_step: None,
            };
        }
        let bodies: Vec<BodyEstimate> = self
            .bodies
            .iter()
            .map(|body| body_estimate(body, self.domain.cell_size))
            .collect();
        WorkEstimate {
            particles: bodies
                .iter()
                .fold(0, |sum, body| sum.saturating_add(body.particles)),
            lattice_points: bodies
                .iter()
                .fold(0, |sum, body| sum.saturating_add(body.lattice_points)),
            bodies,
            frames,
            first_step: Some(self.first_step()),
        }
    }

    /// The first substep: Δt as `firn_mpm::Simulation::next_dt` takes it
    /// at time 0, from the fastest body and the stiffest material of a body
    /// (no particle has hardened yet).
    pub fn first_step(&self) -> FirstStep {
        let speed = self
            .bodies
            .iter()
            .map(|body| body.velocity.length_squared())
            .fold(0.0, f32::max)
            .sqrt();
        let wave_speed = match self.solver.integrator {
            Integrator::Explicit => self
                .bodies
                .iter()
                .filter_map(|body| self.materials.get(body.material))
                .map(|material| {
                    let (mu, lambda) = material.lame();
                    (lambda + 2.0 * mu) / material.density
                })
                .fold(0.0, f32::max)
                .sqrt(),
            Integrator::SemiImplicit(_) => 0.0,
        };
        let dt = match self.time.step {
            TimeStep::Fixed { dt } => dt,
            TimeStep::Adaptive { cfl, max_dt } => {
                let fastest = speed + wave_speed;
                if fastest > 0.0 {
                    (cfl * self.domain.cell_size / fastest).min(max_dt)
                } else {
                    max_dt
                }
            }
        };
        FirstStep {
            dt,
            speed,
            wave_speed,
            substeps_per_frame: 1.0 / (self.time.fps * f64::from(dt)),
        }
    }
}

/// The lattice points and particles of one body.
pub(crate) fn body_estimate(body: &Body, cell_size: f32) -> BodyEstimate {
    let lattice_points = lattice_points(body, cell_size);
    let spacing = f64::from(particle_spacing(cell_size, body.particles_per_cell));
    let particles = (shape_volume(&body.shape) / spacing.powi(3)).round();
    let particles = if particles.is_finite() && particles >= 0.0 {
        (particles.min(u64::MAX as f64) as u64).min(lattice_points)
    } else {
        lattice_points
    };
    BodyEstimate {
        lattice_points,
        particles,
    }
}

/// The volume of a body's shape, m³.
fn shape_volume(shape: &Shape) -> f64 {
    use std::f64::consts::PI;
    match *shape {
        Shape::Sphere { radius, .. } => 4.0 / 3.0 * PI * f64::from(radius).powi(3),
        Shape::Box { size, .. } => size.as_dvec3().element_product(),
        Shape::Cylinder { radius, height, .. } => {
            PI * f64::from(radius).powi(2) * f64::from(height)
        }
        Shape::Mesh(ref mesh) => mesh.volume,
    }
}

/// A size in bytes for messages: `12.5 TiB`, `310 MiB`, `512 bytes`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bytes(pub u64);

impl std::fmt::Display for Bytes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
        if self.0 < 1024 {
            return write!(f, "{} bytes", self.0);
        }
        let mut value = self.0 as f64 / 1024.0;
        let mut unit = 0;
        while value >= 1024.0 && unit + 1 < UNITS.len() {
            value /= 1024.0;
            unit += 1;
        }
        let digits = if value < 10.0 {
            2
        } else if value < 100.0 {
            1
        } else {
            0
        };
        write!(f, "{value:.digits$} {}", UNITS[unit])
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::scene::{Body, Scene};

    #[test]
    fn a_box_gets_its_lattice_and_a_sphere_about_its_volume() {
        let scene = Scene::builder("estimate")
            .unit_box(0.05)
            .body(Body::cuboid(Vec3::splat(0.5), Vec3::splat(0.2)))
            .body(Body::sphere(Vec3::splat(0.5), 0.2))
            .build_unchecked();
        let estimate = scene.estimate();
        // 0.2 m at 0.025 m spacing (8 particles per cell): 8 points per axis.
        assert_eq!(estimate.bodies[0].lattice_points, 512);
        assert_eq!(estimate.bodies[0].particles, 512);
        assert_eq!(estimate.bodies[1].lattice_points, 16 * 16 * 16);
        let sphere = 4.0 / 3.0 * std::f64::consts::PI * 0.008 / 0.025f64.powi(3);
        assert_eq!(estimate.bodies[1].particles, sphere.round() as u64);
        assert_eq!(estimate.particles, 512 + sphere.round() as u64);
        assert_eq!(estimate.frames, 30);
    }

    #[test]
    fn sizes_read_in_binary_units() {
        use super::Bytes;
        assert_eq!(Bytes(512).to_string(), "512 bytes");
        assert_eq!(Bytes(3 << 20).to_string(), "3.00 MiB");
        assert_eq!(Bytes(25 << 30).to_string(), "25.0 GiB");
        assert_eq!(Bytes(12_800_000_000_000).to_string(), "11.6 TiB");
    }
}
