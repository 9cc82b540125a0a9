//! What a running flow lets its callers read: its scene and field, its
//! particles and trails, its snapshot and its memory.

use firn_core::Scene;
use firn_core::scene::FlowSettings;
use glam::Vec3;

use super::{FlowSimulation, position_color};
use crate::field::FlowField;
use crate::particles::FlowParticles;
use crate::snapshot::FlowSnapshot;
use crate::trails::Trails;

impl FlowSimulation {
    /// Everything needed to continue this run bit for bit.
    pub fn snapshot(&self) -> FlowSnapshot {
        self.view().snapshot()
    }

    /// The scene being simulated.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The flow settings of the scene.
    pub fn settings(&self) -> &FlowSettings {
        &self.settings
    }

    /// The velocity field (for probing, tests and a future GPU port).
    pub fn field(&self) -> &FlowField {
        &self.field
    }

    /// All particle arrays.
    pub fn particles(&self) -> &FlowParticles {
        &self.particles
    }

    /// Number of particles born so far (all alive: a particle whose life ends
    /// is born again at once).
    pub fn len(&self) -> usize {
        self.particles.len()
    }

    /// Whether no particle is born yet.
    pub fn is_empty(&self) -> bool {
        self.particles.is_empty()
    }

    /// Particle positions, m.
    pub fn positions(&self) -> &[Vec3] {
        &self.particles.positions
    }

    /// Particle velocities of the last substep, m/s.
    pub fn velocities(&self) -> &[Vec3] {
        &self.particles.velocities
    }

    /// Seconds since each particle's current life began.
    pub fn ages(&self) -> &[f32] {
        &self.particles.ages
    }

    /// Length of each particle's current life, s (infinite: forever).
    pub fn lifetimes(&self) -> &[f32] {
        &self.particles.lifetimes
    }

    /// Lives each particle lived before its current one.
    pub fn generations(&self) -> &[u32] {
        &self.particles.generations
    }

    /// Particle ids: a particle's id is its index, stable for the whole run
    /// (particles are appended as they are born and never reordered).
    pub fn ids(&self) -> std::ops::Range<u32> {
        0..self.particles.len() as u32
    }

    /// Particles born so far by each emitter (a checkpoint keeps them).
    pub fn births(&self) -> &[u64] {
        &self.births
    }

    /// The trails, if kept.
    pub fn trails(&self) -> Option<&Trails> {
        self.trails.as_ref()
    }

    /// The seed's colouring (§2.3): |x|, |y|, |z| about the centre of the
    /// domain, each divided by the half extent, as red, green, blue in [0, 1].
    pub fn colors_by_position(&self) -> Vec<[f32; 3]> {
        let domain = &self.scene.domain;
        self.particles
            .positions
            .iter()
            .map(|x| position_color(domain.min, domain.max, *x))
            .collect()
    }

    /// The bytes [`FlowSimulation::memory_bytes`] reports once every
    /// particle slot of `scene`'s emitters is alive, known before anything
    /// is allocated: the particles and, when the scene draws trails, their
    /// rings of `trail_length` positions.
    pub fn estimate_memory_bytes(scene: &Scene) -> u64 {
        let slots = scene.estimate().particles;
        let trails = &firn_core::scene::RenderStyle::Trails;
        let trail_bytes = if scene.render.styles.contains(trails) {
            u64::from(scene.render.trail_length) * size_of::<Vec3>() as u64 + 8
        } else {
            0
        };
        slots.saturating_mul(FlowParticles::bytes_per_particle() as u64 + trail_bytes)
    }

    /// Bytes held by the particles and trails.
    pub fn memory_bytes(&self) -> usize {
        let trails = self.trails.as_ref().map_or(0, |trails| {
            trails.particle_count() * (trails.capacity() * size_of::<Vec3>() + 8)
        });
        self.particles.len() * FlowParticles::bytes_per_particle() + trails
    }
}
