//! Deforming mesh colliders in the contact: each mesh frame's narrow-band
//! field is built when the run first needs it and kept while the run is
//! between that frame and the next.
//!
//! Between mesh frames k and k + 1, a fraction s of the way, the collider's
//! signed distance and its gradient are (1 − s) φ_k + s φ_{k+1} (each field
//! trilinear in its samples), and its velocity at a point is the velocity
//! of the closest surface point of each frame's mesh, blended the same
//! way: each vertex moves at (x_{k+1} − x_k) times the sequence's frame
//! rate, and a surface point at the barycentric mix of its triangle's
//! vertices. So a boot that presses down and drags back pushes the snow
//! with the motion of the part of the sole that touches it.

use std::sync::Arc;

use firn_core::scene::{MeshSequenceCollider, SequenceInterval};
use firn_mesh::NarrowBandField;
use glam::Vec3;

/// A deforming collider's surface at one instant.
#[derive(Clone, Debug)]
pub struct DeformingSurface {
    /// The field of the mesh frame before.
    from: Arc<NarrowBandField>,
    /// The field of the mesh frame after (the same one outside the
    /// sequence).
    to: Arc<NarrowBandField>,
    /// How far from `from` to `to`.
    fraction: f32,
    /// Every vertex's velocity over the interval.
    vertex_velocities: Arc<[Vec3]>,
    /// The mean vertex velocity: the velocity deep inside, away from the band.
    mean_velocity: Vec3,
}

impl DeformingSurface {
    /// Signed distance at `point` (negative inside), the same bits as
    /// [`DeformingSurface::sample`]'s.
    #[inline]
    pub fn distance(&self, point: Vec3) -> f32 {
        let (a, b) = (self.from.distance(point), self.to.distance(point));
        a + (b - a) * self.fraction
    }

    /// Signed distance (negative inside), outward unit normal and the
    /// surface's velocity at `point`.
    #[inline]
    pub fn sample(&self, point: Vec3) -> (f32, Vec3, Vec3) {
        let velocities = &self.vertex_velocities;
        let a = self.from.sample(point, velocities, self.mean_velocity);
        let b = self.to.sample(point, velocities, self.mean_velocity);
        let s = self.fraction;
        let distance = a.distance + (b.distance - a.distance) * s;
        let gradient = a.gradient.lerp(b.gradient, s);
        let velocity = a.value.lerp(b.value, s);
        (
            distance,
            gradient.try_normalize().unwrap_or(Vec3::Y),
            velocity,
        )
    }
}

/// The fields one deforming collider has built, by mesh frame, and the
/// vertex velocities of its current interval.
#[derive(Clone, Debug, Default)]
pub struct SequenceCache {
    fields: Vec<(usize, Arc<NarrowBandField>)>,
    velocities: Option<IntervalVelocities>,
}

/// The vertex velocities of the interval between two mesh frames, and
/// their mean.
#[derive(Clone, Debug)]
struct IntervalVelocities {
    frames: (usize, usize),
    vertices: Arc<[Vec3]>,
    mean: Vec3,
}

impl SequenceCache {
    /// The surface of `sequence` at `time`, building the fields of the
    /// mesh frames around it that are not built yet and dropping the rest.
    pub fn surface_at(&mut self, sequence: &MeshSequenceCollider, time: f64) -> DeformingSurface {
        let interval = sequence.interval_at(time);
        self.fields
            .retain(|(index, _)| *index == interval.from || *index == interval.to);
        let from = self.field(sequence, interval.from);
        let to = self.field(sequence, interval.to);
        let (vertex_velocities, mean_velocity) = self.velocities(sequence, interval);
        DeformingSurface {
            from,
            to,
            fraction: interval.fraction,
            vertex_velocities,
            mean_velocity,
        }
    }

    fn field(&mut self, sequence: &MeshSequenceCollider, index: usize) -> Arc<NarrowBandField> {
        if let Some((_, field)) = self.fields.iter().find(|(built, _)| *built == index) {
            return field.clone();
        }
        let field = Arc::new(sequence.field_of(index));
        self.fields.push((index, field.clone()));
        field
    }

    fn velocities(
        &mut self,
        sequence: &MeshSequenceCollider,
        interval: SequenceInterval,
    ) -> (Arc<[Vec3]>, Vec3) {
        let key = (interval.from, interval.to);
        match &self.velocities {
            Some(built) if built.frames == key => (built.vertices.clone(), built.mean),
            _ => {
                let vertices: Arc<[Vec3]> = sequence.vertex_velocities(interval).into();
                let sum: Vec3 = vertices.iter().sum();
                let mean = sum / vertices.len().max(1) as f32;
                self.velocities = Some(IntervalVelocities {
                    frames: key,
                    vertices: vertices.clone(),
                    mean,
                });
                (vertices, mean)
            }
        }
    }
}
