// One substep of the flow (firn_flow::simulation, steps 1-5), a kernel per
// phase, recorded by src/flow/step.rs over the particles (group 1) and the
// trails (group 2) of src/flow/bindings.rs:
//
// - `advance`: RK2 or RK4 through the field, the birth velocity's
//   displacement, aging, rebirth of expired or escaped particles at their
//   emitter, and pushing particles out of spheres;
// - `settle_newborns`: the particles a rate emitter added (uploaded by the
//   host) pushed out of spheres, with their velocity at the substep's end;
// - `record_trails`: at a frame's end, every particle's position into its
//   trail ring (seed §2.3).

// How far outside a sphere a particle is put, relative to the radius.
const PUSH_OUT_MARGIN: f32 = 1e-5;

fn load_position(i: u32) -> vec3<f32> {
    return vec3<f32>(positions[3u * i], positions[3u * i + 1u], positions[3u * i + 2u]);
}

fn store_position(i: u32, x: vec3<f32>) {
    positions[3u * i] = x.x;
    positions[3u * i + 1u] = x.y;
    positions[3u * i + 2u] = x.z;
}

fn store_velocity(i: u32, v: vec3<f32>) {
    velocities[3u * i] = v.x;
    velocities[3u * i + 1u] = v.y;
    velocities[3u * i + 2u] = v.z;
}

// A point inside a sphere moved to just outside it, along the ray from its centre.
fn push_out(point: vec3<f32>) -> vec3<f32> {
    var x = point;
    for (var k = 0u; k < field_constants.obstacle_count; k++) {
        let center = obstacles[k].sphere.xyz;
        let radius = obstacles[k].sphere.w;
        let rel = x - center;
        let distance_squared = dot(rel, rel);
        if distance_squared < radius * radius {
            let distance = sqrt(distance_squared);
            var normal = vec3<f32>(0.0, 1.0, 0.0);
            if distance > 0.0 {
                normal = rel / distance;
            }
            x = center + normal * (radius * (1.0 + PUSH_OUT_MARGIN));
        }
    }
    return x;
}

fn inside_domain(x: vec3<f32>) -> bool {
    return all(x >= field_constants.domain_min.xyz) && all(x <= field_constants.domain_max.xyz);
}

// A new life for particle i at its emitter after it expired (at `age`) or
// left the domain; its age counts from when the last life ended.
fn rebirth(i: u32, outside: bool, age: f32) {
    let e = emitters[emitter_of[i]];
    let generation = generations[i] + 1u;
    let new_lifetime = birth_lifetime(e, i, generation);
    // Without a lifetime only leaving the domain ends a life.
    var new_age = 0.0;
    if e.has_lifetime != 0u {
        var overshoot = 0.0;
        if !outside {
            overshoot = age - lifetimes[i];
        }
        new_age = min(overshoot, new_lifetime);
    }
    let x = push_out(birth_position(e, i, generation));
    generations[i] = generation;
    lifetimes[i] = new_lifetime;
    ages[i] = new_age;
    store_position(i, x);
    store_velocity(i, field_velocity(x, STAGE_END) + kick_velocity(e, new_age));
}

@compute @workgroup_size(64)
fn advance(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    let i = invocation_index(group, groups, local);
    if i >= substep.count {
        return;
    }
    let e = emitters[emitter_of[i]];
    let dt = substep.dt;
    let flow = integrated_velocity(load_position(i), substep.dt, substep.half_dt);
    let age = ages[i];
    let moved = (load_position(i) + dt * flow) + kick(e, age, dt);
    let velocity = flow + kick_velocity(e, age + dt);
    let aged = age + dt;
    let outside = !inside_domain(moved);
    let expired = e.has_lifetime != 0u && aged >= lifetimes[i];
    if outside || expired {
        rebirth(i, outside, aged);
        return;
    }
    ages[i] = aged;
    store_position(i, push_out(moved));
    store_velocity(i, velocity);
}

@compute @workgroup_size(64)
fn settle_newborns(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    let i = substep.newborn_first + invocation_index(group, groups, local);
    if i >= substep.newborn_end {
        return;
    }
    let x = push_out(load_position(i));
    store_position(i, x);
    let e = emitters[emitter_of[i]];
    store_velocity(i, field_velocity(x, STAGE_END) + kick_velocity(e, ages[i]));
}

@compute @workgroup_size(64)
fn record_trails(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    let i = invocation_index(group, groups, local);
    if i >= substep.newborn_end {
        return;
    }
    var length = trail_lengths[i];
    if trail_generations[i] != generations[i] {
        trail_generations[i] = generations[i];
        length = 0u;
    }
    let slot = i * substep.trail_capacity + substep.trail_head;
    let x = load_position(i);
    trail_points[3u * slot] = x.x;
    trail_points[3u * slot + 1u] = x.y;
    trail_points[3u * slot + 2u] = x.z;
    trail_lengths[i] = min(length + 1u, substep.trail_capacity);
}
