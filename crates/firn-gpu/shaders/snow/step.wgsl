// The explicit MPM substep (thesis section 3.4), as firn_mpm::Simulation::step:
// begin_step, then scatter, update_grid and gather, with the grid word
// planes cleared by the host between substeps.

// Seconds within which a frame counts as reached (the CPU's 1e-9 s).
const FRAME_END_TOLERANCE: f32 = 1.0e-9;

fn simulated_time() -> f32 {
    return params.lower.w + state.elapsed;
}

// Dt = CFL h / (max |v_p| + max c_p), capped, or the fixed dt; the
// maxima come from the last gather (as firn_mpm::Simulation::next_dt).
fn next_dt(speed_squared: f32, wave_speed_squared: f32) -> f32 {
    if params.stepping.z > 0.0 {
        return params.stepping.z;
    }
    let speed = sqrt(speed_squared) + sqrt(wave_speed_squared);
    if speed > 0.0 {
        return min(params.stepping.x * params.origin.w / speed, params.stepping.y);
    }
    return params.stepping.y;
}

// One invocation: stops the frame when it is done or a particle is in
// trouble, else chooses dt, clipped to the frame's end, and resets the
// maxima for this substep's gather.
@compute @workgroup_size(1)
fn begin_step() {
    if state.running == 0u {
        return;
    }
    let trouble = atomicLoad(&state.non_finite) != NO_PARTICLE
        || atomicLoad(&state.left_domain) != NO_PARTICLE
        || atomicLoad(&state.overflow) != 0u;
    let remaining = params.upper.w - state.elapsed;
    if trouble || remaining <= FRAME_END_TOLERANCE {
        state.running = 0u;
        return;
    }
    let speed_squared = bitcast<f32>(atomicLoad(&state.max_speed_bits));
    let wave_speed_squared = bitcast<f32>(atomicLoad(&state.max_wave_bits));
    let dt = min(next_dt(speed_squared, wave_speed_squared), remaining);
    state.dt = dt;
    state.speed_squared = speed_squared;
    state.wave_speed_squared = wave_speed_squared;
    if dt >= remaining {
        state.elapsed = params.upper.w;
    } else {
        state.elapsed = state.elapsed + dt;
    }
    state.steps = state.steps + 1u;
    atomicStore(&state.max_speed_bits, 0u);
    atomicStore(&state.max_wave_bits, 0u);
}

// The particle a scatter or gather invocation works on, if any.
fn particle_index(group: vec3<u32>, groups: vec3<u32>, local: u32) -> u32 {
    let p = linear_index(group, groups, local);
    if p >= params.dims.w || state.running == 0u {
        return NO_PARTICLE;
    }
    return p;
}

fn inside_grid(node: vec3<i32>) -> bool {
    return all(node >= vec3<i32>(0)) && all(node < vec3<i32>(params.dims.xyz));
}

// The momentum an APIC particle gives its stencil: node (i, j, k) gets
// w (at_base + affine (i, j, k)), with affine = (m C_p - dt (4/h^2) V_p^0 tau_p) h
// mapping a node offset in cells to momentum.
struct ApicMomentum {
    at_base: vec3<f32>,
    affine: mat3x3<f32>,
}

fn apic_momentum(p: u32, offset: vec3<f32>) -> ApicMomentum {
    let h = params.origin.w;
    let mass = position_mass[p].w;
    let affine_momentum = (affine[p] * mass - stress[p] * (state.dt * 4.0 / (h * h))) * h;
    return ApicMomentum(velocity_volume[p].xyz * mass - affine_momentum * offset, affine_momentum);
}

// dt times the PIC/FLIP force on a node is this matrix times grad w (per
// cell): -dt V_p^0 tau_p / h (eq. 31-33).
fn impulse_stress(p: u32) -> mat3x3<f32> {
    return stress[p] * (-state.dt / params.origin.w);
}

// Steps 1 and 3 for APIC (MLS-MPM form): node i gets
// w_ip (m_p v_p + (m_p C_p - dt (4/h^2) V_p^0 tau_p)(x_i - x_p)) and w_ip m_p.
@compute @workgroup_size(64)
fn scatter_apic(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                @builtin(local_invocation_index) local: u32) {
    let p = particle_index(group, groups, local);
    if p == NO_PARTICLE {
        return;
    }
    let mass = position_mass[p].w;
    let weights = quadratic_weights(grid_coordinate(position_mass[p].xyz));
    let momentum_map = apic_momentum(p, weights.offset);
    let mass_scale = params.scales.x;
    let momentum_scale = params.scales.y;
    for (var i = 0; i < 3; i++) {
        for (var j = 0; j < 3; j++) {
            for (var k = 0; k < 3; k++) {
                let cell = weights.base + vec3<i32>(i, j, k);
                if !inside_grid(cell) {
                    continue;
                }
                let w = weights.values[i].x * weights.values[j].y * weights.values[k].z;
                let momentum = (momentum_map.at_base + momentum_map.affine * vec3<f32>(f32(i), f32(j), f32(k))) * w;
                let node = node_index(cell);
                add_to_grid(QUANTITY_MASS, node, mass * w * mass_scale);
                add_to_grid(QUANTITY_MOMENTUM_X, node, momentum.x * momentum_scale);
                add_to_grid(QUANTITY_MOMENTUM_Y, node, momentum.y * momentum_scale);
                add_to_grid(QUANTITY_MOMENTUM_Z, node, momentum.z * momentum_scale);
            }
        }
    }
}

// Steps 1 and 3 for PIC/FLIP: mass, momentum and the force impulse
// dt f_i = -dt sum_p V_p^0 tau_p grad w_ip (eq. 31-33).
@compute @workgroup_size(64)
fn scatter_pic_flip(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                    @builtin(local_invocation_index) local: u32) {
    let p = particle_index(group, groups, local);
    if p == NO_PARTICLE {
        return;
    }
    let mass = position_mass[p].w;
    let momentum = velocity_volume[p].xyz * mass;
    let impulse_map = impulse_stress(p);
    let weights = cubic_weights(grid_coordinate(position_mass[p].xyz));
    let mass_scale = params.scales.x;
    let momentum_scale = params.scales.y;
    for (var i = 0; i < 4; i++) {
        for (var j = 0; j < 4; j++) {
            for (var k = 0; k < 4; k++) {
                let cell = weights.base + vec3<i32>(i, j, k);
                if !inside_grid(cell) {
                    continue;
                }
                let w = weights.values[i].x * weights.values[j].y * weights.values[k].z;
                let gradient = weight_gradient(weights.values[i], weights.values[j], weights.values[k],
                                               weights.slopes[i], weights.slopes[j], weights.slopes[k]);
                let impulse = impulse_map * gradient;
                let node = node_index(cell);
                add_to_grid(QUANTITY_MASS, node, mass * w * mass_scale);
                add_to_grid(QUANTITY_MOMENTUM_X, node, momentum.x * w * momentum_scale);
                add_to_grid(QUANTITY_MOMENTUM_Y, node, momentum.y * w * momentum_scale);
                add_to_grid(QUANTITY_MOMENTUM_Z, node, momentum.z * w * momentum_scale);
                add_to_grid(QUANTITY_FORCE_X, node, impulse.x * momentum_scale);
                add_to_grid(QUANTITY_FORCE_Y, node, impulse.y * momentum_scale);
                add_to_grid(QUANTITY_FORCE_Z, node, impulse.z * momentum_scale);
            }
        }
    }
}

fn momentum_at(node: u32) -> vec3<f32> {
    return vec3<f32>(
        from_fixed(atomicLoad(&px_hi[node]), atomicLoad(&px_lo[node])),
        from_fixed(atomicLoad(&py_hi[node]), atomicLoad(&py_lo[node])),
        from_fixed(atomicLoad(&pz_hi[node]), atomicLoad(&pz_lo[node])),
    );
}

fn impulse_at(node: u32) -> vec3<f32> {
    return vec3<f32>(
        from_fixed(atomicLoad(&fx_hi[node]), atomicLoad(&fx_lo[node])),
        from_fixed(atomicLoad(&fy_hi[node]), atomicLoad(&fy_lo[node])),
        from_fixed(atomicLoad(&fz_hi[node]), atomicLoad(&fz_lo[node])),
    );
}

// Stores v_i in the low word planes and v_i^{n+1} in the high ones.
fn store_node_velocities(node: u32, velocity: vec3<f32>, velocity_new: vec3<f32>) {
    atomicStore(&px_lo[node], bitcast<u32>(velocity.x));
    atomicStore(&py_lo[node], bitcast<u32>(velocity.y));
    atomicStore(&pz_lo[node], bitcast<u32>(velocity.z));
    atomicStore(&px_hi[node], bitcast<u32>(velocity_new.x));
    atomicStore(&py_hi[node], bitcast<u32>(velocity_new.y));
    atomicStore(&pz_hi[node], bitcast<u32>(velocity_new.z));
}

// Steps 4 and 5: v_i = p_i / m_i, v_i* = v_i + dt (f_i / m_i + g), then the
// grid collisions at the end of the substep, on every node with mass.
@compute @workgroup_size(64)
fn update_grid(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
               @builtin(local_invocation_index) local: u32) {
    let node = linear_index(group, groups, local);
    let dims = params.dims.xyz;
    if node >= dims.x * dims.y * dims.z || state.running == 0u {
        return;
    }
    let mass = from_fixed(atomicLoad(&mass_hi[node]), atomicLoad(&mass_lo[node])) / params.scales.x;
    if mass <= 0.0 {
        store_node_velocities(node, vec3<f32>(0.0), vec3<f32>(0.0));
        return;
    }
    let inverse_mass = 1.0 / mass;
    let velocity = momentum_at(node) / params.scales.y * inverse_mass;
    var change = params.gravity.xyz * state.dt;
    if params.flags.x == TRANSFER_PIC_FLIP {
        change += impulse_at(node) / params.scales.y * inverse_mass;
    }
    let cell = vec3<u32>(node / (dims.y * dims.z), node / dims.z % dims.y, node % dims.z);
    let position = params.origin.xyz + vec3<f32>(cell) * params.origin.w;
    let velocity_new = collide_all(position, velocity + change, simulated_time());
    store_node_velocities(node, velocity, velocity_new);
}

fn node_velocity_new(node: u32) -> vec3<f32> {
    return vec3<f32>(bitcast<f32>(atomicLoad(&px_hi[node])), bitcast<f32>(atomicLoad(&py_hi[node])),
                     bitcast<f32>(atomicLoad(&pz_hi[node])));
}

fn node_velocity(node: u32) -> vec3<f32> {
    return vec3<f32>(bitcast<f32>(atomicLoad(&px_lo[node])), bitcast<f32>(atomicLoad(&py_lo[node])),
                     bitcast<f32>(atomicLoad(&pz_lo[node])));
}

// What the grid gives one particle: its new velocity and grad v_p.
struct Interpolated {
    velocity: vec3<f32>,
    gradient: mat3x3<f32>,
}

// APIC: v_p = sum w v_i, C_p = (4/h^2) sum w v_i (x_i - x_p)^T = grad v_p.
fn interpolate_apic(p: u32) -> Interpolated {
    let weights = quadratic_weights(grid_coordinate(position_mass[p].xyz));
    var velocity = vec3<f32>(0.0);
    var moment = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var i = 0; i < 3; i++) {
        for (var j = 0; j < 3; j++) {
            for (var k = 0; k < 3; k++) {
                let cell = weights.base + vec3<i32>(i, j, k);
                if !inside_grid(cell) {
                    continue;
                }
                let w = weights.values[i].x * weights.values[j].y * weights.values[k].z;
                let weighted = node_velocity_new(node_index(cell)) * w;
                let offset = vec3<f32>(f32(i), f32(j), f32(k)) - weights.offset;
                velocity += weighted;
                moment += mat3x3<f32>(weighted * offset.x, weighted * offset.y, weighted * offset.z);
            }
        }
    }
    return Interpolated(velocity, moment * (4.0 / params.origin.w));
}

// PIC/FLIP: v_p = (1 - alpha) sum w v_i^{n+1} + alpha (v_p + sum w (v_i^{n+1} - v_i)),
// grad v_p = sum v_i^{n+1} (grad w_ip)^T.
fn interpolate_pic_flip(p: u32) -> Interpolated {
    let weights = cubic_weights(grid_coordinate(position_mass[p].xyz));
    let inverse_h = 1.0 / params.origin.w;
    var pic = vec3<f32>(0.0);
    var change = vec3<f32>(0.0);
    var gradient = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var i = 0; i < 4; i++) {
        for (var j = 0; j < 4; j++) {
            for (var k = 0; k < 4; k++) {
                let cell = weights.base + vec3<i32>(i, j, k);
                if !inside_grid(cell) {
                    continue;
                }
                let node = node_index(cell);
                let w = weights.values[i].x * weights.values[j].y * weights.values[k].z;
                let grad_w = weight_gradient(weights.values[i], weights.values[j], weights.values[k],
                                             weights.slopes[i], weights.slopes[j], weights.slopes[k]) * inverse_h;
                let velocity_new = node_velocity_new(node);
                pic += velocity_new * w;
                change += (velocity_new - node_velocity(node)) * w;
                gradient += mat3x3<f32>(velocity_new * grad_w.x, velocity_new * grad_w.y, velocity_new * grad_w.z);
            }
        }
    }
    let flip = params.gravity.w;
    return Interpolated(pic * (1.0 - flip) + (velocity_volume[p].xyz + change) * flip, gradient);
}

fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn finite3(v: vec3<f32>) -> bool {
    return finite(v.x) && finite(v.y) && finite(v.z);
}

// Largest |v_p|^2 and squared wave speed of this workgroup, as f32 bits.
var<workgroup> group_max_speed: atomic<u32>;
var<workgroup> group_max_wave: atomic<u32>;

// Steps 7 to 10 for one particle: F_E update, plasticity and stress,
// particle collisions at the predicted position, advection, and the checks.
fn update_particle(p: u32, grid: Interpolated) {
    let dt = state.dt;
    let plastic_state = plastic[p];
    let material = materials[plastic_state.material];
    let identity = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    let trial = (identity + grid.gradient * dt) * elastic[p];
    let updated = elastic_update(trial, plastic_state.plastic_j, velocity_volume[p].w, material);
    elastic[p] = updated.elastic;
    plastic[p] = PlasticState(updated.plastic_j, plastic_state.material);
    stress[p] = updated.stress;
    affine[p] = grid.gradient;

    let position = position_mass[p].xyz;
    let velocity = collide_all(position + grid.velocity * dt, grid.velocity, simulated_time());
    let moved = position + velocity * dt;
    position_mass[p] = vec4<f32>(moved, position_mass[p].w);
    velocity_volume[p] = vec4<f32>(velocity, velocity_volume[p].w);

    let wave_speed_squared = material.wave_speed_squared * updated.hardening_factor;
    let is_finite = finite3(moved) && finite3(velocity) && finite3(updated.elastic[0])
        && finite3(updated.elastic[1]) && finite3(updated.elastic[2]) && finite(wave_speed_squared);
    let inside = all(moved >= params.lower.xyz) && all(moved <= params.upper.xyz);
    if !is_finite {
        atomicMin(&state.non_finite, p);
    } else if !inside {
        atomicMin(&state.left_domain, p);
    } else {
        atomicMax(&group_max_speed, bitcast<u32>(dot(velocity, velocity)));
        atomicMax(&group_max_wave, bitcast<u32>(wave_speed_squared));
    }
}

fn publish_maxima(local: u32) {
    workgroupBarrier();
    if local == 0u {
        atomicMax(&state.max_speed_bits, atomicLoad(&group_max_speed));
        atomicMax(&state.max_wave_bits, atomicLoad(&group_max_wave));
    }
}

// Steps 7-10 for APIC.
@compute @workgroup_size(64)
fn gather_apic(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
               @builtin(local_invocation_index) local: u32) {
    let p = particle_index(group, groups, local);
    if p != NO_PARTICLE {
        update_particle(p, interpolate_apic(p));
    }
    publish_maxima(local);
}

// Steps 7-10 for PIC/FLIP.
@compute @workgroup_size(64)
fn gather_pic_flip(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                   @builtin(local_invocation_index) local: u32) {
    let p = particle_index(group, groups, local);
    if p != NO_PARTICLE {
        update_particle(p, interpolate_pic_flip(p));
    }
    publish_maxima(local);
}
