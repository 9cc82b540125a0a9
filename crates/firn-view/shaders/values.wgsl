// Colour values of a GPU simulation's particles, read from its own buffers
// into the renderer's value array: `speed` = |v|, `density` =
// m / (V0 det F_E J_P), `plastic_j` = J_P. Each entry point binds only what
// it reads.

// Where each quantity lies: (stride, offset) in 32-bit words, particle i's
// starting at word i * stride + offset.
struct Arrays {
    count: u32,
    _pad: u32,
    velocity: vec2<u32>,
    mass: vec2<u32>,
    volume0: vec2<u32>,
    elastic: vec2<u32>,
    plastic_j: vec2<u32>,
}

@group(0) @binding(0) var<uniform> arrays: Arrays;
@group(0) @binding(1) var<storage, read_write> values: array<f32>;
@group(0) @binding(2) var<storage, read> velocities: array<f32>;
@group(0) @binding(3) var<storage, read> masses: array<f32>;
@group(0) @binding(4) var<storage, read> volumes0: array<f32>;
@group(0) @binding(5) var<storage, read> elastic: array<f32>;
@group(0) @binding(6) var<storage, read> plastic_js: array<f32>;

const WORKGROUP_SIZE: u32 = 64u;

// The particle of this invocation over a 2D grid of workgroups (large
// counts exceed one dimension's limit).
fn particle_index(group: vec3<u32>, groups: vec3<u32>, local: u32) -> u32 {
    return (group.y * groups.x + group.x) * WORKGROUP_SIZE + local;
}

fn word(i: u32, quantity: vec2<u32>) -> u32 {
    return i * quantity.x + quantity.y;
}

fn plastic_j(i: u32) -> f32 {
    return plastic_js[word(i, arrays.plastic_j)];
}

// det F_E: three columns of x, y, z, each padded to four words.
fn elastic_determinant(i: u32) -> f32 {
    let base = word(i, arrays.elastic);
    let x = vec3<f32>(elastic[base], elastic[base + 1u], elastic[base + 2u]);
    let y = vec3<f32>(elastic[base + 4u], elastic[base + 5u], elastic[base + 6u]);
    let z = vec3<f32>(elastic[base + 8u], elastic[base + 9u], elastic[base + 10u]);
    return determinant(mat3x3<f32>(x, y, z));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn speed(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let i = particle_index(group, groups, local);
    if i >= arrays.count {
        return;
    }
    let base = word(i, arrays.velocity);
    values[i] = length(vec3<f32>(velocities[base], velocities[base + 1u], velocities[base + 2u]));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn density(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let i = particle_index(group, groups, local);
    if i >= arrays.count {
        return;
    }
    let volume = volumes0[word(i, arrays.volume0)] * elastic_determinant(i) * plastic_j(i);
    values[i] = masses[word(i, arrays.mass)] / volume;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn plastic_volume_change(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let i = particle_index(group, groups, local);
    if i >= arrays.count {
        return;
    }
    values[i] = plastic_j(i);
}
