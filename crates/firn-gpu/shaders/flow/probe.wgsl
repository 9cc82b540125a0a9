// Single library functions run on arrays, for the parity tests against
// firn_flow (firn_gpu::flow::FlowProbe): noise and gradient, the field
// velocity at the substep's start stage, and births. The inputs and
// outputs are group 1 (ProbeBindings in src/flow/bindings.rs).

fn probe_point(i: u32) -> vec3<f32> {
    return bitcast<vec3<f32>>(probe_request(i));
}

fn probe_request(i: u32) -> vec3<u32> {
    return vec3<u32>(probe_input[3u * i], probe_input[3u * i + 1u], probe_input[3u * i + 2u]);
}

fn probe_count() -> u32 {
    return arrayLength(&probe_input) / 3u;
}

// Input: points (as f32 bits); output: value, gradient (4 numbers per point).
@compute @workgroup_size(64)
fn probe_noise(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    let i = invocation_index(group, groups, local);
    if i >= probe_count() {
        return;
    }
    let noise = simplex3(probe_point(i));
    probe_output[4u * i] = noise.value;
    probe_output[4u * i + 1u] = noise.gradient.x;
    probe_output[4u * i + 2u] = noise.gradient.y;
    probe_output[4u * i + 3u] = noise.gradient.z;
}

// Input: points; output: the velocity at the start stage (3 per point).
@compute @workgroup_size(64)
fn probe_velocity(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    let i = invocation_index(group, groups, local);
    if i >= probe_count() {
        return;
    }
    let v = field_velocity(probe_point(i), STAGE_START);
    probe_output[3u * i] = v.x;
    probe_output[3u * i + 1u] = v.y;
    probe_output[3u * i + 2u] = v.z;
}

// Input: (emitter, particle id, generation); output: the birth
// position and lifetime (4 per request).
@compute @workgroup_size(64)
fn probe_birth(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    let i = invocation_index(group, groups, local);
    if i >= probe_count() {
        return;
    }
    let request = probe_request(i);
    let e = emitters[request.x];
    let x = birth_position(e, request.y, request.z);
    let lifetime = birth_lifetime(e, request.y, request.z);
    probe_output[4u * i] = x.x;
    probe_output[4u * i + 1u] = x.y;
    probe_output[4u * i + 2u] = x.z;
    probe_output[4u * i + 3u] = lifetime;
}
