//! The data the host hands the flow kernels, `#[repr(C)]` mirrors of the
//! structs in `shaders/flow/layout.wgsl`, formed from a scene with the same
//! f64 arithmetic as `firn_flow::FlowField` so the GPU sees the CPU's bits.

use bytemuck::{Pod, Zeroable};
use firn_core::Scene;
use firn_core::scene::{FlowCurl, FlowEmitter, FlowEmitterShape, FlowIntegrator, FlowSettings};
use glam::{DVec3, Vec3};

/// The field's constants and the run's (WGSL `FieldConstants`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct FieldConstants {
    direction: [f32; 4],
    domain_min: [f32; 4],
    domain_max: [f32; 4],
    inv_length: f32,
    turbulence: f32,
    turbulence_gradient: f32,
    background: f32,
    half_background: f32,
    speed: f32,
    difference_step: f32,
    inv_two_steps: f32,
    finite_difference: u32,
    integrator: u32,
    obstacle_count: u32,
    emitter_count: u32,
    random_key: [u32; 2],
    padding: [u32; 2],
}

impl FieldConstants {
    /// The constants of seed eq. 1-4 for `scene`, rounded from f64 to f32 as
    /// `FlowField::prepare` rounds them.
    pub(crate) fn new(scene: &Scene, settings: &FlowSettings) -> FieldConstants {
        let gamma = f64::from(settings.noise_share);
        let turbulence = gamma * f64::from(settings.noise_strength);
        let inv_length = 1.0 / f64::from(settings.length_scale);
        let background = (1.0 - gamma) * f64::from(settings.background_strength);
        let (finite_difference, step) = match settings.curl {
            FlowCurl::Analytic => (0, 1.0),
            FlowCurl::FiniteDifference { step } => (1, f64::from(step)),
        };
        let key = firn_flow::random::seed_key(settings.seed);
        FieldConstants {
            direction: vec4(settings.background_direction, 0.0),
            domain_min: vec4(scene.domain.min, 0.0),
            domain_max: vec4(scene.domain.max, 0.0),
            inv_length: inv_length as f32,
            turbulence: turbulence as f32,
            turbulence_gradient: (turbulence * inv_length) as f32,
            background: background as f32,
            half_background: (0.5 * background) as f32,
            speed: settings.speed_scale,
            difference_step: step as f32,
            inv_two_steps: (0.5 / step) as f32,
            finite_difference,
            integrator: match settings.integrator {
                FlowIntegrator::Rk2 => 0,
                FlowIntegrator::Rk4 => 1,
            },
            obstacle_count: settings.obstacles.len() as u32,
            emitter_count: settings.emitters.len() as u32,
            random_key: [key as u32, (key >> 32) as u32],
            padding: [0; 2],
        }
    }
}

/// A sphere obstacle (WGSL `Obstacle`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct ObstacleData {
    sphere: [f32; 4],
    inv_influence: f32,
    padding: [f32; 3],
}

/// The obstacles of the flow, in scene order.
pub(crate) fn obstacles(settings: &FlowSettings) -> Vec<ObstacleData> {
    settings
        .obstacles
        .iter()
        .map(|obstacle| ObstacleData {
            sphere: vec4(obstacle.center, obstacle.radius),
            inv_influence: (1.0 / f64::from(obstacle.influence)) as f32,
            padding: [0.0; 3],
        })
        .collect()
}

/// An emitter (WGSL `Emitter`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct EmitterData {
    center: [f32; 4],
    size: [f32; 4],
    tangent: [f32; 4],
    bitangent: [f32; 4],
    velocity: [f32; 4],
    shape: u32,
    has_lifetime: u32,
    lifetime: f32,
    lifetime_spread: f32,
}

impl EmitterData {
    fn new(emitter: &FlowEmitter) -> EmitterData {
        let mut data = EmitterData {
            center: vec4(emitter.shape.center(), 0.0),
            size: [0.0; 4],
            tangent: [0.0; 4],
            bitangent: [0.0; 4],
            velocity: vec4(emitter.velocity, emitter.velocity_decay),
            shape: 0,
            has_lifetime: u32::from(emitter.lifetime.is_some()),
            lifetime: emitter.lifetime.unwrap_or(f32::INFINITY),
            lifetime_spread: emitter.lifetime_spread,
        };
        match emitter.shape {
            FlowEmitterShape::Box { size, .. } => data.size = vec4(size, 0.0),
            FlowEmitterShape::Sphere { radius, .. } => {
                data.shape = 1;
                data.center[3] = radius;
            }
            FlowEmitterShape::Disc { radius, normal, .. } => {
                // The same in-plane axes as `firn_flow::emitters::birth_position`.
                let (tangent, bitangent) = normal.any_orthonormal_pair();
                data.shape = 2;
                data.center[3] = radius;
                data.tangent = vec4(tangent, 0.0);
                data.bitangent = vec4(bitangent, 0.0);
            }
        }
        data
    }
}

/// The emitters of the flow, in scene order.
pub(crate) fn emitters(settings: &FlowSettings) -> Vec<EmitterData> {
    settings.emitters.iter().map(EmitterData::new).collect()
}

/// One substep's parameters (WGSL `SubstepParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct SubstepParams {
    /// Noise offsets of each component at the start, middle and end.
    pub offsets: [[f32; 4]; 9],
    /// Δt.
    pub dt: f32,
    /// Δt / 2.
    pub half_dt: f32,
    /// Particles alive at the start of the substep.
    pub count: u32,
    /// First particle a rate emitter adds in the substep.
    pub newborn_first: u32,
    /// Particles alive at the end of the substep.
    pub newborn_end: u32,
    /// Ring slot the trails record into.
    pub trail_head: u32,
    /// Positions kept per trail.
    pub trail_capacity: u32,
    padding: u32,
}

impl SubstepParams {
    /// The substep from `t0` to `t1` with `count` particles at its start
    /// and none born.
    pub(crate) fn new(domains: &NoiseDomains, t0: f64, t1: f64, count: u32) -> SubstepParams {
        let dt = (t1 - t0) as f32;
        let mut offsets = [[0.0; 4]; 9];
        for (stage, t) in [t0, 0.5 * (t0 + t1), t1].into_iter().enumerate() {
            offsets[3 * stage..3 * stage + 3].copy_from_slice(&domains.offsets_at(t));
        }
        SubstepParams {
            offsets,
            dt,
            half_dt: 0.5 * dt,
            count,
            newborn_first: count,
            newborn_end: count,
            trail_head: 0,
            trail_capacity: 0,
            padding: 0,
        }
    }
}

/// Where each component's noise domain sits over time, in noise cells: the
/// offsets ε_c / L and drifts w_c of seed eq. 1, drawn exactly as
/// `firn_flow::FlowField::new` draws them.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct NoiseDomains {
    offsets: [DVec3; 3],
    drift: [DVec3; 3],
}

impl NoiseDomains {
    /// The domains of a flow's settings.
    pub(crate) fn new(settings: &FlowSettings) -> NoiseDomains {
        let (offsets, drift) = firn_flow::field::noise_domains(settings);
        NoiseDomains { offsets, drift }
    }

    /// w_c of each component, noise cells per second, rounded.
    pub(crate) fn drift(&self) -> [[f32; 4]; 3] {
        std::array::from_fn(|c| vec4(self.drift[c].as_vec3(), 0.0))
    }

    /// ε_c / L + t w_c for each component, formed in f64 (long runs keep
    /// their precision) and then rounded.
    pub(crate) fn offsets_at(&self, t: f64) -> [[f32; 4]; 3] {
        std::array::from_fn(|c| {
            let offset = (self.offsets[c] + self.drift[c] * t).as_vec3();
            vec4(offset, 0.0)
        })
    }
}

fn vec4(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}
