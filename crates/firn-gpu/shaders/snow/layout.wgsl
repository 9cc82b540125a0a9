// The structs and constants every snow kernel shares, mirrored by the
// #[repr(C)] structs of src/snow/layout.rs, and the helpers for indexing
// particles and nodes. The bindings are declared by the table in
// src/snow/bindings.rs; the grid is sparse (nodes.wgsl), one buffer per
// 32-bit word plane (low and high word of each 64-bit fixed-point sum), so
// no single buffer grows past the adapter's storage-binding limit as fast as
// a packed layout would.

const TRANSFER_APIC: u32 = 0u;
const TRANSFER_PIC_FLIP: u32 = 1u;
const NO_PARTICLE: u32 = 0xffffffffu;

struct Params {
    // xyz: world position of node (0, 0, 0); w: cell size h.
    origin: vec4<f32>,
    // xyz: nodes per axis; w: particle count.
    dims: vec4<u32>,
    // xyz: gravity; w: FLIP share alpha.
    gravity: vec4<f32>,
    // xyz: lowest allowed particle position; w: simulated time at the frame start.
    lower: vec4<f32>,
    // xyz: highest allowed particle position; w: seconds from the frame start to its end.
    upper: vec4<f32>,
    // x: CFL number; y: largest dt; z: fixed dt (0: adaptive); w: the
    // fastest material speed of the rigid bodies, which bounds dt too
    // (coupling.wgsl; 0 without bodies).
    stepping: vec4<f32>,
    // x: mass scale; y: momentum scale (fixed-point units per kg, per kg m/s).
    scales: vec4<f32>,
    // x: transfer scheme; y: the adapter's workgroups per dispatch
    // dimension; z: 1 with the semi-implicit integrator (implicit.wgsl);
    // w: the grid's capacity in blocks (nodes.wgsl).
    flags: vec4<u32>,
    // The semi-implicit solve: x: beta; y: tolerance; z: iteration limit.
    implicit: vec4<f32>,
}

// What the substeps of a frame share, written by the GPU and read back by
// the host once per batch of substeps.
struct StepState {
    // Dt of the current substep.
    dt: f32,
    // Seconds from the frame start to the end of the current substep.
    elapsed: f32,
    // 1 while substeps run; 0 once the frame is done or something went wrong.
    running: u32,
    // Substeps taken in this frame.
    steps: u32,
    // Largest |v_p|^2 and squared wave speed of the last gather, as f32 bits.
    max_speed_bits: atomic<u32>,
    max_wave_bits: atomic<u32>,
    // Lowest index of a particle that became non-finite, or that left the domain.
    non_finite: atomic<u32>,
    left_domain: atomic<u32>,
    // Bit q set: grid quantity q overflowed its fixed-point range.
    overflow: atomic<u32>,
    // The maxima the current substep's dt came from.
    speed_squared: f32,
    wave_speed_squared: f32,
    // 1 when begin_step stopped the batch to wait for the fields of a
    // deforming collider's next mesh frames (deforming.wgsl), which the
    // host uploads before it resumes; 2 when the grid's blocks did not fit
    // its capacity (blocks.wgsl), which the host then grows.
    waiting: u32,
    // Blocks the grid allocated for the current substep (blocks.wgsl).
    grid_blocks: u32,
}

// A rigid body as the grid update meets it in one substep (coupling.wgsl,
// as firn_mpm::coupling::PlacedBody): its shape and contact as a collider,
// placed where rapier has it at the substep's start, turned (pose.position.w
// = 1), moving at v + omega x (x - c).
struct PlacedBody {
    collider: Collider,
    pose: ColliderPose,
    // xyz: the centre of mass, about which the moments are summed; w: how
    // far the body reaches from its reference point.
    center_of_mass: vec4<f32>,
}

struct PlasticState {
    plastic_j: f32,
    material: u32,
}

// The linear invocation index of a dispatch split over two dimensions.
fn linear_index(group: vec3<u32>, groups: vec3<u32>, local: u32) -> u32 {
    return (group.y * groups.x + group.x) * 64u + local;
}

fn grid_coordinate(position: vec3<f32>) -> vec3<f32> {
    return (position - params.origin.xyz) / params.origin.w;
}

fn simulated_time() -> f32 {
    return params.lower.w + state.elapsed;
}

// The particle a scatter or gather invocation works on, if any.
fn particle_index(group: vec3<u32>, groups: vec3<u32>, local: u32) -> u32 {
    let p = linear_index(group, groups, local);
    if p >= params.dims.w || state.running == 0u {
        return NO_PARTICLE;
    }
    return p;
}

// The snow particle a scatter, binning or gather invocation works on, if
// any: drift and escaped particles (spindrift.wgsl's phases) are skipped.
fn snow_particle_index(group: vec3<u32>, groups: vec3<u32>, local: u32) -> u32 {
    let p = particle_index(group, groups, local);
    if p == NO_PARTICLE || (plastic[p].material >> 16u) != PHASE_SNOW {
        return NO_PARTICLE;
    }
    return p;
}
