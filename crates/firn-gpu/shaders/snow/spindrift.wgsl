// Spindrift ([wind.spindrift]; firn_mpm::spindrift, equations S1 to S3 of
// firn_core::scene::wind) at the end of a substep, after the gather and
// while the grid still holds the substep's node masses. The particles stay
// in one buffer; each has a phase (the high 16 bits of its
// PlasticState.material word): snow, drift, escaped, or lifted (snow that
// detached this substep). The scatter, the grid and the gather see snow
// only (snow_particle_index in layout.wgsl).
//
// - detach_snow: a snow particle lifts (phase lifted) where S1 and S2 hold,
//   with the CPU's draw: a hash of the wind's seed, the substep index and
//   the bits of the particle's position (flow/random.wgsl's mixer), so the
//   same particle in the same state draws the same number on both backends;
// - carry_drift: drift moves one step of the wind's integrator through the
//   field plus the fall speed (S3) and lands (into a collider or through a
//   floor: it rests at its point before the step, and with settle becomes
//   undeformed snow at rest there) or leaves the domain (escaped); lifted
//   particles become drift, to be carried from the next substep on, as the
//   CPU carries before it detaches.
//
// A particle's mass word is never written here, so the mass of the scene
// is conserved bit for bit.

const PHASE_SNOW: u32 = 0u;
const PHASE_DRIFT: u32 = 1u;
const PHASE_ESCAPED: u32 = 2u;
const PHASE_LIFTED: u32 = 3u;
const MATERIAL_BITS: u32 = 0xffffu;

// The share of a node's own mass a neighbour must hold to shelter it fully
// (firn_mpm::spindrift::SHELTERING_SHARE).
const SHELTERING_SHARE: f32 = 0.5;

// What the spindrift kernels need beside the wind's field.
struct SpindriftParams {
    // xyz: the domain's lower corner; w: u_t, m/s.
    domain_min: vec4<f32>,
    // xyz: the domain's upper corner; w: rho_loose, kg/m^3.
    domain_max: vec4<f32>,
    // xyz: the fall velocity w_s g_hat, m/s; w: the rate r, 1/s.
    fall: vec4<f32>,
    // x: 1 with spindrift; y: 1 where landed drift settles into snow;
    // z: the scene's colliders (the first ones of `colliders`); w: unused.
    flags: vec4<u32>,
    // xy: the index of the frame's first substep, low and high word.
    first_substep: vec4<u32>,
}

fn phase_of(p: u32) -> u32 {
    return plastic[p].material >> 16u;
}

fn set_phase(p: u32, phase: u32) {
    let material = plastic[p].material & MATERIAL_BITS;
    plastic[p].material = material | (phase << 16u);
}

// The particle a spindrift invocation works on, if any: none once the frame
// is done or the gather found a particle in trouble (the CPU blows no
// spindrift after a failed gather).
fn spindrift_particle(group: vec3<u32>, groups: vec3<u32>, local: u32) -> u32 {
    let trouble = atomicLoad(&state.non_finite) != NO_PARTICLE || atomicLoad(&state.left_domain) != NO_PARTICLE;
    if trouble || spindrift.flags.x == 0u {
        return NO_PARTICLE;
    }
    return particle_index(group, groups, local);
}

// The index of the current substep since the run began, as a u64
// (vec2<u32>(low, high)).
fn substep_index() -> vec2<u32> {
    let low = spindrift.first_substep.x + (state.steps - 1u);
    let carry = select(0u, 1u, low < spindrift.first_substep.x);
    return vec2<u32>(low, spindrift.first_substep.y + carry);
}

// xi_p of S2 (firn_mpm::spindrift::draw): firn_flow::random::unit with the
// wind's seed, the id x_bits | y_bits << 32, the substep index as the
// generation and z_bits as the stream.
fn spindrift_draw(position: vec3<f32>) -> f32 {
    let id = vec2<u32>(bitcast<u32>(position.x), bitcast<u32>(position.y));
    var h = mix64(field_constants.random_key ^ wrapping_mul64(id, RANDOM_ID));
    h = mix64(h ^ wrapping_mul64(substep_index(), RANDOM_GENERATION));
    h = mix64(h ^ wrapping_mul64(vec2<u32>(bitcast<u32>(position.z), 0u), RANDOM_STREAM));
    return f32(h.y >> 8u) * (1.0 / 16777216.0);
}

// e_p of S1 at the node nearest `position`: the larger of its exposures to
// the relative wind and from above, against half the node's own mass.
fn surface_exposure(position: vec3<f32>, relative: vec3<f32>) -> f32 {
    let cell = vec3<i32>(round(grid_coordinate(position)));
    let own = node_mass_at(cell);
    if !(own > 0.0) {
        return 0.0;
    }
    let sheltering = SHELTERING_SHARE * own;
    let windward = exposure_against(cell, relative, sheltering);
    let from_above = exposure_against(cell, params.gravity.xyz, sheltering);
    return max(windward, from_above);
}

// Whether snow particle p lifts this substep (S1, S2).
fn lifts(p: u32) -> bool {
    let dt = state.dt;
    let rate = spindrift.fall.w;
    let most_likely = 1.0 - exp(-rate * dt);
    if !(most_likely > 0.0) {
        return false;
    }
    let position = position_mass[p].xyz;
    let draw = spindrift_draw(position);
    let material = materials[plastic[p].material & MATERIAL_BITS];
    let j = determinant(elastic[p]) * plastic[p].plastic_j;
    if draw >= most_likely || material.density / j >= spindrift.domain_max.w {
        return false;
    }
    let relative = field_velocity(position, STAGE_END) - velocity_volume[p].xyz;
    if length(relative) <= spindrift.domain_min.w {
        return false;
    }
    let exposure = surface_exposure(position, relative);
    return exposure > 0.0 && draw < 1.0 - exp(-rate * exposure * dt);
}

// S1 and S2 for the snow particles: those that lift become drift (at the
// end of the substep) with the volume V_p^0 J_p they will settle with.
@compute @workgroup_size(64)
fn detach_snow(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
               @builtin(local_invocation_index) local: u32) {
    let p = spindrift_particle(group, groups, local);
    if p == NO_PARTICLE || phase_of(p) != PHASE_SNOW || !lifts(p) {
        return;
    }
    let mass = position_mass[p].w;
    let j = determinant(elastic[p]) * plastic[p].plastic_j;
    let density = mass / (j * velocity_volume[p].w);
    velocity_volume[p].w = mass / density;
    set_phase(p, PHASE_LIFTED);
}

// Whether a step to `to` went into one of the scene's colliders (placed at
// the end of the substep) or through a floor.
fn landed(to: vec3<f32>) -> bool {
    let gravity = params.gravity.xyz;
    let through_floor = (gravity < vec3<f32>(0.0) & to < spindrift.domain_min.xyz)
        | (gravity > vec3<f32>(0.0) & to > spindrift.domain_max.xyz);
    if any(through_floor) {
        return true;
    }
    for (var c = 0u; c < spindrift.flags.z; c++) {
        if placed_surface(colliders[c], posed(c), to).distance <= 0.0 {
            return true;
        }
    }
    return false;
}

// Drift that landed becomes snow at rest, undeformed, where it was before
// the step; its V_p^0 is the volume it lifted with.
fn settle(p: u32, at: vec3<f32>) {
    let zero = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    position_mass[p] = vec4<f32>(at, position_mass[p].w);
    velocity_volume[p] = vec4<f32>(vec3<f32>(0.0), velocity_volume[p].w);
    elastic[p] = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    affine[p] = zero;
    stress[p] = zero;
    plastic[p].plastic_j = 1.0;
    set_phase(p, PHASE_SNOW);
}

// S3 for the drift particles: carried, landed or escaped; lifted snow
// becomes drift.
@compute @workgroup_size(64)
fn carry_drift(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
               @builtin(local_invocation_index) local: u32) {
    let p = spindrift_particle(group, groups, local);
    if p == NO_PARTICLE {
        return;
    }
    let phase = phase_of(p);
    if phase == PHASE_LIFTED {
        set_phase(p, PHASE_DRIFT);
        return;
    }
    if phase != PHASE_DRIFT {
        return;
    }
    let dt = state.dt;
    let before = position_mass[p].xyz;
    let air = integrated_velocity(before, state.dt, 0.5 * state.dt);
    let fall = spindrift.fall.xyz;
    let moved = (before + dt * air) + fall * dt;
    if landed(moved) {
        if spindrift.flags.y != 0u {
            settle(p, before);
        } else {
            velocity_volume[p] = vec4<f32>(vec3<f32>(0.0), velocity_volume[p].w);
        }
        return;
    }
    let inside = all(moved >= spindrift.domain_min.xyz) && all(moved <= spindrift.domain_max.xyz);
    position_mass[p] = vec4<f32>(moved, position_mass[p].w);
    velocity_volume[p] = vec4<f32>(air + fall, velocity_volume[p].w);
    if !inside {
        set_phase(p, PHASE_ESCAPED);
    }
}
