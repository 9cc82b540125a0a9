//! Two-way coupling with rigid bodies (`shaders/snow/coupling.wgsl`), the
//! GPU's side of `firn_mpm::coupling`: rapier stays on the CPU, in the same
//! [`RigidBodies`] the CPU backend steps, and the GPU's grid update meets
//! the bodies.
//!
//! A run with bodies takes one substep per submission. Before each, the
//! host writes every body placed where rapier has it (pose, velocity, spin,
//! centre of mass; its shape and contact were packed once, a mesh's field
//! among the colliders' fields) and the bodies' fastest material speed,
//! which bounds the Δt that `begin_step` takes as on the CPU. The grid
//! update meets the bodies after the colliders: each workgroup (one block
//! of the grid) first marks in workgroup memory, a bit per body, the bodies
//! whose reach meets its block, as the CPU's blocks do, and each node then
//! meets those in body order and adds its exchange Δp = m (v' − v) and its
//! moment (x − c) × Δp into the body's six 64-bit fixed-point sums
//! (`firn_mpm::coupling::FIXED_SCALE` units per N s, as on the CPU) with
//! integer atomics, so the sums do not depend on the order the nodes run in
//! and a run gives the same bits every time. After the substep the host
//! reads the sums back with the step state, in one read, and
//! [`RigidBodies::advance`] gives each body the opposite and steps rapier by
//! the substep's Δt.

use firn_core::Scene;
use firn_core::scene::Collider;
use firn_mpm::coupling::{ImpulseSum, PlacedBody, RigidBodies};

use super::layout::{GpuCollider, GpuColliderPose, GpuPlacedBody};
use crate::buffers::zeroed_storage_buffer;
use crate::context::GpuContext;

/// 32-bit words of one body's sums in `body_sums`: the snow's momentum
/// gain x, y, z, then its moment x, y, z, each a low and a high word
/// (`BODY_SUM_WORDS` in `coupling.wgsl`).
pub const SUM_WORDS: usize = 12;

/// Bytes a rigid body takes on the GPU: its `PlacedBody` and its sums.
pub const BYTES_PER_BODY: u64 = (size_of::<GpuPlacedBody>() + 4 * SUM_WORDS) as u64;

/// The bodies' buffers: 16-byte stand-ins in a scene without bodies.
pub struct BodyBuffers {
    /// One `PlacedBody` per body, written before every substep.
    pub placed: wgpu::Buffer,
    /// [`SUM_WORDS`] words per body, cleared before every substep.
    pub sums: wgpu::Buffer,
    /// Number of bodies.
    pub count: usize,
}

impl BodyBuffers {
    /// Zeroed buffers for `count` bodies.
    pub fn new(context: &GpuContext, count: usize) -> BodyBuffers {
        let bytes = |per_body: usize| (count * per_body) as u64;
        BodyBuffers {
            placed: zeroed_storage_buffer(
                context,
                "placed rigid bodies",
                bytes(size_of::<GpuPlacedBody>()),
            ),
            sums: zeroed_storage_buffer(context, "rigid body sums", bytes(4 * SUM_WORDS)),
            count,
        }
    }

    /// Zeroes the sums, before a substep.
    pub fn clear(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.sums, 0, None);
    }
}

/// The scene's rigid bodies on the CPU and what the GPU needs to meet them.
pub struct Coupling {
    rigid: RigidBodies,
    /// Each body's shape and contact as a collider, packed once.
    shapes: Vec<GpuCollider>,
}

impl Coupling {
    /// The bodies of `rigid`, whose shapes `shapes` packs in body order
    /// ([`body_colliders`], packed with the colliders).
    pub fn new(rigid: RigidBodies, shapes: Vec<GpuCollider>) -> Coupling {
        Coupling { rigid, shapes }
    }

    /// The bodies on the CPU: rapier's world.
    pub fn rigid(&self) -> &RigidBodies {
        &self.rigid
    }

    /// Writes every body placed where it is now into `buffers`, for the
    /// next substep.
    pub fn place(&self, context: &GpuContext, buffers: &BodyBuffers) {
        let contacts = self.rigid.contacts();
        let placed: Vec<GpuPlacedBody> = contacts
            .bodies()
            .iter()
            .zip(&self.shapes)
            .map(|(body, shape)| placed_body(body, shape))
            .collect();
        context
            .queue
            .write_buffer(&buffers.placed, 0, bytemuck::cast_slice(&placed));
    }

    /// The fastest any body's material moves, m/s (the next Δt follows it).
    pub fn max_speed(&self) -> f32 {
        self.rigid.max_speed()
    }

    /// Gives each body the opposite of what the snow gained in a substep
    /// of length `dt` (`words` as read back from `body_sums`) and steps
    /// them and the moving `colliders`, placed at `time_end`, by it.
    pub fn advance(&mut self, words: &[u32], dt: f32, colliders: &[Collider], time_end: f64) {
        self.rigid
            .advance(&impulse_sums(words), dt, colliders, time_end);
    }
}

/// The scene's rigid bodies as static colliders of their shapes and
/// contacts, to pack with the colliders (a mesh body's field then goes
/// among the colliders' fields).
pub fn body_colliders(scene: &Scene) -> Vec<Collider> {
    scene
        .rigid_bodies
        .iter()
        .map(|body| Collider::new(body.geometry.clone()).contact(body.contact))
        .collect()
}

/// A body as the kernels read it: its packed `shape` placed as `body` is.
fn placed_body(body: &PlacedBody, shape: &GpuCollider) -> GpuPlacedBody {
    let collider = &body.collider;
    let spin = collider
        .spin
        .expect("a rigid body is always placed with its spin");
    GpuPlacedBody {
        collider: *shape,
        pose: GpuColliderPose {
            position: spin.center.extend(1.0).into(),
            velocity: collider.velocity.extend(0.0).into(),
            rotation: spin.rotation.to_array(),
            angular_velocity: spin.angular_velocity.extend(0.0).into(),
        },
        center_of_mass: body.center_of_mass.extend(body.reach).into(),
    }
}

/// The bodies' sums from the words of `body_sums`, in body order.
pub fn impulse_sums(words: &[u32]) -> Vec<ImpulseSum> {
    let value = |pair: &[u32]| ((u64::from(pair[1]) << 32) | u64::from(pair[0])) as i64;
    words
        .chunks_exact(SUM_WORDS)
        .map(|body| {
            let sum = |first: usize| {
                std::array::from_fn(|axis| value(&body[first + 2 * axis..first + 2 * axis + 2]))
            };
            ImpulseSum {
                linear: sum(0),
                angular: sum(6),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use firn_mpm::coupling::FIXED_SCALE as SCALE;

    /// Two's complement words of round(`value` · 2^32), as the kernel
    /// writes them.
    fn words_of(value: f64) -> [u32; 2] {
        let integer = (value * SCALE).round() as i64 as u64;
        [integer as u32, (integer >> 32) as u32]
    }

    #[test]
    fn the_kernels_mask_has_a_bit_for_every_body_a_scene_may_have() {
        let most = firn_core::scene::format::MAX_RIGID_BODIES;
        let line = format!("const MAX_RIGID_BODIES: u32 = {most}u;");
        assert!(crate::shaders::SNOW_STEP.source().contains(&line));
    }

    #[test]
    fn sums_are_read_back_as_signed_sixty_four_bit_fixed_point() {
        let values = [1.5, -2.25, 1e-9, -3e4, 0.0, -1e-9];
        let words: Vec<u32> = values.iter().flat_map(|&v| words_of(v)).collect();
        let sums = impulse_sums(&words);
        assert_eq!(sums.len(), 1);
        let momentum = sums[0].snow_momentum();
        assert_eq!(
            momentum.to_array(),
            [1.5, -2.25, (1e-9 * SCALE).round() / SCALE]
        );
        assert_eq!(sums[0].angular[0], (-3e4 * SCALE) as i64);
        assert_eq!(sums[0].angular[2], -((1e-9 * SCALE).round() as i64));
    }
}
