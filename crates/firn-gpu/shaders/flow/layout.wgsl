// The structs every flow kernel sees: the field's constants, the sphere
// obstacles, the emitters and the substep's parameters, which group 0 binds
// (declared by the table in src/flow/bindings.rs), mirrored by the
// `#[repr(C)]` structs of src/flow/layout.rs.

// Constants of the field (seed 002 eq. 1-4) and the run.
struct FieldConstants {
    // p, the background direction.
    direction: vec4<f32>,
    domain_min: vec4<f32>,
    domain_max: vec4<f32>,
    // 1 / L.
    inv_length: f32,
    // γ M.
    turbulence: f32,
    // γ M / L: scales a noise gradient to a gradient of ψ.
    turbulence_gradient: f32,
    // (1 − γ) M_f.
    background: f32,
    // ½ (1 − γ) M_f.
    half_background: f32,
    // s.
    speed: f32,
    // h of the central differences, and 1 / 2h.
    difference_step: f32,
    inv_two_steps: f32,
    // 1: central differences of ψ'; 0: the exact curl.
    finite_difference: u32,
    // 0: RK2 (midpoint); 1: RK4.
    integrator: u32,
    obstacle_count: u32,
    emitter_count: u32,
    // mix64(seed ^ 0x9E3779B97F4A7C15), the seed's part of every random draw.
    random_key: vec2<u32>,
    padding: vec2<u32>,
}

// A sphere obstacle (seed eq. 2-3).
struct Obstacle {
    // Centre and radius.
    sphere: vec4<f32>,
    // 1 / d0.
    inv_influence: f32,
    padding_0: f32,
    padding_1: f32,
    padding_2: f32,
}

// An emitter: its region, lifetime and birth velocity.
struct Emitter {
    // Centre; w: radius (sphere, disc).
    center: vec4<f32>,
    // Edge lengths (box).
    size: vec4<f32>,
    // Two unit vectors spanning the disc's plane.
    tangent: vec4<f32>,
    bitangent: vec4<f32>,
    // Birth velocity; w: the time over which it fades by e.
    velocity: vec4<f32>,
    // 0: box, 1: sphere, 2: disc.
    shape: u32,
    // 0: particles live forever.
    has_lifetime: u32,
    // Mean lifetime; +∞ without one.
    lifetime: f32,
    lifetime_spread: f32,
}

// One substep: the noise offsets of each component at its start, middle and
// end (ε_c / L + t w_c, formed in f64 on the host), Δt and the particle
// ranges it works on.
struct SubstepParams {
    // offsets[3 * stage + c], stage 0: start, 1: middle, 2: end.
    offsets: array<vec4<f32>, 9>,
    dt: f32,
    half_dt: f32,
    // Particles alive at the start of the substep.
    count: u32,
    // Particles a rate emitter adds at the end of it, [newborn_first,
    // newborn_end): newborn_end is the count at the end of the substep.
    newborn_first: u32,
    newborn_end: u32,
    // Ring slot the trails record into, and positions kept per trail.
    trail_head: u32,
    trail_capacity: u32,
    padding: u32,
}

const STAGE_START: u32 = 0u;
const STAGE_MIDDLE: u32 = 1u;
const STAGE_END: u32 = 2u;

// The linear index of an invocation of a dispatch split by
// firn_gpu::dispatch::workgroups (64 invocations per workgroup).
fn invocation_index(group: vec3<u32>, groups: vec3<u32>, local: u32) -> u32 {
    return (group.y * groups.x + group.x) * 64u + local;
}
