//! The bindings of the flow programs, named in one place: each line gives a
//! binding's number, name, access and WGSL type, and its doc becomes the
//! comment above the generated declaration ([`crate::bindings`]). The
//! structs are in `shaders/flow/layout.wgsl`, mirrored in `layout.rs`.
//!
//! Group 0 (the field) is seen by every flow kernel; the step binds the
//! particles as group 1 and the trails as group 2, the probes their inputs
//! and outputs as group 1.

use crate::bindings::bind_group;

bind_group! {
    /// Group 0: what every flow kernel reads.
    pub struct FieldBindings("flow field", group 0) {
        /// The field's constants (seed eq. 1-4) and the run's.
        0 => field_constants: Uniform "FieldConstants",
        /// The sphere obstacles (seed eq. 2-3).
        1 => obstacles: Read "array<Obstacle>",
        /// The emitters: regions, lifetimes, birth velocities.
        2 => emitters: Read "array<Emitter>",
        /// The substep's noise offsets, Δt and particle ranges.
        3 => substep: Uniform "SubstepParams",
    }
}

bind_group! {
    /// Group 1 of the step: the particle arrays.
    pub struct ParticleBindings("flow particles", group 1) {
        /// x, y, z per particle.
        0 => positions: ReadWrite "array<f32>",
        /// x, y, z per particle.
        1 => velocities: ReadWrite "array<f32>",
        /// Seconds since birth.
        2 => ages: ReadWrite "array<f32>",
        /// Length of the current life.
        3 => lifetimes: ReadWrite "array<f32>",
        /// Lives before the current one.
        4 => generations: ReadWrite "array<u32>",
        /// The emitter each particle belongs to.
        5 => emitter_of: Read "array<u32>",
    }
}

bind_group! {
    /// Group 2 of the step: every particle's trail ring.
    pub struct TrailBindings("flow trails", group 2) {
        /// Rings, particle-major, x, y, z per point.
        0 => trail_points: ReadWrite "array<f32>",
        /// Valid points per ring.
        1 => trail_lengths: ReadWrite "array<u32>",
        /// Generation of each particle when its trail last recorded.
        2 => trail_generations: ReadWrite "array<u32>",
    }
}

bind_group! {
    /// Group 1 of the probes: their inputs and outputs.
    pub struct ProbeBindings("flow probe", group 1) {
        /// Three words per item: a point's f32 bits, or (emitter, particle
        /// id, generation).
        0 => probe_input: Read "array<u32>",
        /// The numbers each probe writes per item.
        1 => probe_output: ReadWrite "array<f32>",
    }
}
