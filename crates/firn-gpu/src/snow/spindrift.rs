//! Spindrift on the GPU (`[wind.spindrift]`, `shaders/snow/spindrift.wgsl`),
//! the same model as `firn_mpm::spindrift` (equations S1 to S3 of
//! `firn_core::scene::wind`), which is its reference.
//!
//! The particles stay in one buffer and each has a phase, kept in the high
//! 16 bits of its material word: snow, drift, or escaped (and, within a
//! substep, lifted). The scatter, the binning and the gather skip every
//! particle that is not snow; after the gather, `detach_snow` lifts loose
//! surface snow (S1, S2, with the CPU's hashed draw) and `carry_drift`
//! moves the drift through the wind's field with its integrator plus the
//! fall speed (S3), lands it (resting, or settling back into snow) or lets
//! it escape. No particle is moved between buffers and no mass word is
//! written, so the mass of the scene is conserved bit for bit. On readback
//! ([`split_phases`]) the buffer is split by phase into the CPU's snow,
//! drift and escaped tally.

use bytemuck::{Pod, Zeroable};
use firn_core::Scene;
use firn_mpm::{Drift, Escaped, Particles};
use glam::{Mat3, Vec3};

use super::program::{Kernel, StepProgram};
use crate::buffers::uniform_buffer;
use crate::context::GpuContext;

/// A particle of the snow body (`PHASE_SNOW`).
pub const PHASE_SNOW: u32 = 0;
/// A drift particle carried by the air (`PHASE_DRIFT`).
pub const PHASE_DRIFT: u32 = 1;
/// Drift that left the domain (`PHASE_ESCAPED`).
pub const PHASE_ESCAPED: u32 = 2;
/// Bits of the material word that hold the material index.
const MATERIAL_BITS: u32 = 0xffff;

/// The material word of a particle of `material` in `phase`.
pub fn material_word(material: u16, phase: u32) -> u32 {
    u32::from(material) | phase << 16
}

/// `SpindriftParams` of `spindrift.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct SpindriftParams {
    domain_min: [f32; 4],
    domain_max: [f32; 4],
    fall: [f32; 4],
    flags: [u32; 4],
    first_substep: [u32; 4],
}

impl SpindriftParams {
    /// The parameters of `scene`'s spindrift (zeroes without) for a frame
    /// whose first substep has index `first_substep`.
    pub fn of(scene: &Scene, first_substep: u64) -> SpindriftParams {
        let Some(settings) = scene.wind.as_ref().and_then(|wind| wind.spindrift) else {
            return SpindriftParams::zeroed();
        };
        let domain = &scene.domain;
        let gravity = scene.solver.gravity;
        let fall = gravity.normalize_or_zero() * settings.fall_speed;
        SpindriftParams {
            domain_min: domain.min.extend(settings.threshold_speed).into(),
            domain_max: domain.max.extend(settings.loose_density).into(),
            fall: fall.extend(settings.rate).into(),
            flags: [
                1,
                u32::from(settings.settle),
                scene.colliders.len() as u32,
                0,
            ],
            first_substep: [first_substep as u32, (first_substep >> 32) as u32, 0, 0],
        }
    }
}

/// The uniform buffer of the spindrift parameters.
pub fn params_buffer(context: &GpuContext, scene: &Scene) -> wgpu::Buffer {
    uniform_buffer(context, "spindrift", &SpindriftParams::of(scene, 0))
}

/// The two spindrift kernels, recorded after the gather where the scene has
/// spindrift.
pub struct SpindriftStage {
    detach: Kernel,
    carry: Kernel,
    enabled: bool,
}

impl SpindriftStage {
    /// `detach_snow` and `carry_drift`, recorded when `enabled`.
    pub fn new(program: &StepProgram, enabled: bool) -> SpindriftStage {
        SpindriftStage {
            detach: program.kernel("detach_snow"),
            carry: program.kernel("carry_drift"),
            enabled,
        }
    }

    /// Records the kernels from now on when `enabled`.
    pub fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }

    /// Records detachment, then the drift's step, one invocation per
    /// particle.
    pub fn record(&self, pass: &mut wgpu::ComputePass, groups: (u32, u32, u32)) {
        if !self.enabled {
            return;
        }
        self.detach.dispatch(pass, groups);
        self.carry.dispatch(pass, groups);
    }
}

/// The particles of a run on the GPU, read back: every array in buffer
/// order, the material word with its phase.
pub struct ReadBack {
    /// Positions.
    pub position: Vec<Vec3>,
    /// Velocities.
    pub velocity: Vec<Vec3>,
    /// Masses.
    pub mass: Vec<f32>,
    /// V_p⁰ of snow, the volume at detachment of drift.
    pub volume: Vec<f32>,
    /// F_E.
    pub elastic: Vec<Mat3>,
    /// C_p or ∇v_p.
    pub affine: Vec<Mat3>,
    /// V_p⁰ τ_p.
    pub stress: Vec<Mat3>,
    /// J_P.
    pub plastic_j: Vec<f32>,
    /// Material index and phase ([`material_word`]).
    pub material_word: Vec<u32>,
}

/// Splits the particles by phase, each in buffer order, into the snow,
/// the drift and the drift that escaped (added to `escaped_before`, what
/// had escaped when the run came to the GPU).
pub fn split_phases(all: ReadBack, escaped_before: Escaped) -> (Particles, Drift, Escaped) {
    let mut snow = Particles::default();
    let mut drift = Drift::default();
    let mut escaped = escaped_before;
    for p in 0..all.position.len() {
        let material = (all.material_word[p] & MATERIAL_BITS) as u16;
        match all.material_word[p] >> 16 {
            PHASE_DRIFT => {
                drift.position.push(all.position[p]);
                drift.velocity.push(all.velocity[p]);
                drift.mass.push(all.mass[p]);
                drift.volume.push(all.volume[p]);
                drift.material.push(material);
            }
            PHASE_ESCAPED => {
                escaped.count += 1;
                escaped.mass += f64::from(all.mass[p]);
            }
            _ => {
                snow.position.push(all.position[p]);
                snow.velocity.push(all.velocity[p]);
                snow.mass.push(all.mass[p]);
                snow.volume0.push(all.volume[p]);
                snow.elastic.push(all.elastic[p]);
                snow.velocity_gradient.push(all.affine[p]);
                snow.stress.push(all.stress[p]);
                snow.plastic_j.push(all.plastic_j[p]);
                snow.material.push(material);
            }
        }
    }
    (snow, drift, escaped)
}

/// The snow followed by the drift, as one set of particle arrays to upload,
/// with each particle's material word ([`material_word`]): drift rests
/// undeformed, its volume at detachment where snow keeps V_p⁰.
pub fn joined(snow: &Particles, drift: &Drift) -> (Particles, Vec<u32>) {
    let mut all = snow.clone();
    let mut words: Vec<u32> = snow
        .material
        .iter()
        .map(|&m| material_word(m, PHASE_SNOW))
        .collect();
    for p in 0..drift.len() {
        all.push_undeformed(
            drift.position[p],
            drift.velocity[p],
            drift.mass[p],
            drift.volume[p],
            drift.material[p],
        );
        words.push(material_word(drift.material[p], PHASE_DRIFT));
    }
    (all, words)
}
