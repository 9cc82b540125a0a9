// Grid to particle, the gather (thesis §3.4 steps 7 to 10, as
// firn_mpm::g2p): each particle reads its new velocity and grad v_p from the
// grid (step 8: the PIC/FLIP blend v_p = (1 - alpha) v_PIC + alpha v_FLIP
// with cubic B-splines, or APIC's v_p and C_p with quadratic ones), then its
// deformation update F_E = (I + dt grad v_p) F_E, plasticity and stress
// (step 7, eq. 34-43, the snow model of common/snow_model.wgsl), the particle
// collisions (step 9) and the advection x_p += dt v_p (step 10), with the
// checks and the maxima the next substep's Δt comes from (begin_step.wgsl),
// reduced per workgroup, then by atomics.

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
    let velocity = collide_all(position + grid.velocity * dt, grid.velocity);
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
    let p = snow_particle_index(group, groups, local);
    if p != NO_PARTICLE {
        update_particle(p, interpolate_apic(p));
    }
    publish_maxima(local);
}

// Steps 7-10 for PIC/FLIP.
@compute @workgroup_size(64)
fn gather_pic_flip(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                   @builtin(local_invocation_index) local: u32) {
    let p = snow_particle_index(group, groups, local);
    if p != NO_PARTICLE {
        update_particle(p, interpolate_pic_flip(p));
    }
    publish_maxima(local);
}
