// Particle to grid, the scatter (thesis §3.4 steps 1 and 3, as
// firn_mpm::p2g): mass and momentum onto the grid, and the elastic force
// f_i = -sum_p V_p^0 tau_p grad w_ip (eq. 31-33), for both transfer schemes
// (step 2, the volumes V_p^0, runs once on the CPU before the particles come
// to the GPU, firn_mpm::Snapshot::initial):
//
// - PIC/FLIP with cubic B-splines: mass, momentum and the force impulse
//   dt f_i are summed apart (scatter_pic_flip);
// - APIC with quadratic B-splines, in the MLS-MPM form: the sums
//   w_ip (m_p v_p + (m_p C_p - dt (4/h^2) V_p^0 tau_p)(x_i - x_p)), the force
//   impulse inside the momentum (scatter_apic).
//
// Every sum is a 64-bit fixed-point integer (fixed_point.wgsl), so the order
// the GPU runs particles in does not change a bit. Two scatters give the same
// sums: the atomic one (scatter_apic, scatter_pic_flip) adds each particle's
// stencil straight into the grid; the binned one (scatter_binned_*) takes up
// to 64 particles of one block, sorted by binning.wgsl, and sums their
// contributions in workgroup memory over the 7^3 nodes a block's particles
// reach, before adding the sums to the grid with one 64-bit atomic add per
// node and quantity. That is the GPU form of the CPU's per-block local
// scatter: far fewer global atomics, and neighbouring invocations share
// nodes in fast memory.

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
    let p = snow_particle_index(group, groups, local);
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
    let p = snow_particle_index(group, groups, local);
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

// The binned scatter's workgroup sums: 7^3 nodes around one block.
const LOCAL_REACH: u32 = 7u;
const LOCAL_NODES: u32 = 343u;
// 343 nodes x 7 quantities (PIC/FLIP) x 2 words.
const MAX_LOCAL_WORDS: u32 = 4802u;

var<workgroup> local_sums: array<atomic<u32>, MAX_LOCAL_WORDS>;
var<workgroup> chunk_header: vec3<u32>;

// The first node of the 7^3 the particles of the block in `slot` reach:
// one before the block.
fn block_first_node(slot: u32) -> vec3<i32> {
    let coord = block_coord(atomicLoad(&bins[3u * slot + 2u]));
    return vec3<i32>(coord) * BLOCK_CELLS - vec3<i32>(1);
}

// Adds scaled into the workgroup's sum of quantity at local node n.
fn add_local(quantities: u32, quantity: u32, n: u32, scaled: f32) {
    let words = to_fixed(scaled);
    let i = (n * quantities + quantity) * 2u;
    let c = carry(atomicAdd(&local_sums[i], words.y), words.y);
    add_high(atomicAdd(&local_sums[i + 1u], words.x + c), words.x + c, quantity);
}

fn local_node(first: vec3<i32>, cell: vec3<i32>) -> u32 {
    let offset = vec3<u32>(cell - first);
    return (offset.x * LOCAL_REACH + offset.y) * LOCAL_REACH + offset.z;
}

// scatter_apic's sums for particle p, into the workgroup's nodes.
fn scatter_local_apic(p: u32, first: vec3<i32>) {
    let mass = position_mass[p].w;
    let weights = quadratic_weights(grid_coordinate(position_mass[p].xyz));
    let momentum_map = apic_momentum(p, weights.offset);
    for (var i = 0; i < 3; i++) {
        for (var j = 0; j < 3; j++) {
            for (var k = 0; k < 3; k++) {
                let w = weights.values[i].x * weights.values[j].y * weights.values[k].z;
                let momentum = (momentum_map.at_base + momentum_map.affine * vec3<f32>(f32(i), f32(j), f32(k))) * w;
                let n = local_node(first, weights.base + vec3<i32>(i, j, k));
                add_local(4u, QUANTITY_MASS, n, mass * w * params.scales.x);
                add_local(4u, QUANTITY_MOMENTUM_X, n, momentum.x * params.scales.y);
                add_local(4u, QUANTITY_MOMENTUM_Y, n, momentum.y * params.scales.y);
                add_local(4u, QUANTITY_MOMENTUM_Z, n, momentum.z * params.scales.y);
            }
        }
    }
}

// scatter_pic_flip's sums for particle p, into the workgroup's nodes.
fn scatter_local_pic_flip(p: u32, first: vec3<i32>) {
    let mass = position_mass[p].w;
    let momentum = velocity_volume[p].xyz * mass;
    let impulse_map = impulse_stress(p);
    let weights = cubic_weights(grid_coordinate(position_mass[p].xyz));
    for (var i = 0; i < 4; i++) {
        for (var j = 0; j < 4; j++) {
            for (var k = 0; k < 4; k++) {
                let w = weights.values[i].x * weights.values[j].y * weights.values[k].z;
                let gradient = weight_gradient(weights.values[i], weights.values[j], weights.values[k],
                                               weights.slopes[i], weights.slopes[j], weights.slopes[k]);
                let impulse = impulse_map * gradient;
                let n = local_node(first, weights.base + vec3<i32>(i, j, k));
                add_local(7u, QUANTITY_MASS, n, mass * w * params.scales.x);
                add_local(7u, QUANTITY_MOMENTUM_X, n, momentum.x * w * params.scales.y);
                add_local(7u, QUANTITY_MOMENTUM_Y, n, momentum.y * w * params.scales.y);
                add_local(7u, QUANTITY_MOMENTUM_Z, n, momentum.z * w * params.scales.y);
                add_local(7u, QUANTITY_FORCE_X, n, impulse.x * params.scales.y);
                add_local(7u, QUANTITY_FORCE_Y, n, impulse.y * params.scales.y);
                add_local(7u, QUANTITY_FORCE_Z, n, impulse.z * params.scales.y);
            }
        }
    }
}

// The work item of this workgroup: (the block's grid slot, first sorted
// slot, particles), with zero particles past the last item. Uniform across
// the workgroup.
fn load_chunk(group: vec3<u32>, groups: vec3<u32>, local: u32) -> vec3<u32> {
    if local == 0u {
        let item = group.y * groups.x + group.x;
        chunk_header = vec3<u32>(0u);
        if item < work[3] {
            let slot = work[WORK_HEADER + 2u * item];
            let first = work[WORK_HEADER + 2u * item + 1u];
            let end = atomicLoad(&bins[3u * slot + 1u]) + atomicLoad(&bins[3u * slot]);
            chunk_header = vec3<u32>(slot, first, min(CHUNK, end - first));
        }
    }
    return workgroupUniformLoad(&chunk_header);
}

// Adds the workgroup's non-zero sums into the grid (their nodes are in the
// particles' stencils, so in allocated blocks).
fn flush_local(first: vec3<i32>, quantities: u32, local: u32) {
    workgroupBarrier();
    for (var n = local; n < LOCAL_NODES; n += 64u) {
        let cell = first + vec3<i32>(vec3<u32>(n / (LOCAL_REACH * LOCAL_REACH), n / LOCAL_REACH % LOCAL_REACH, n % LOCAL_REACH));
        if !inside_grid(cell) {
            continue;
        }
        let node = node_index(cell);
        for (var q = 0u; q < quantities; q++) {
            let i = (n * quantities + q) * 2u;
            let low = atomicLoad(&local_sums[i]);
            let high = atomicLoad(&local_sums[i + 1u]);
            if (low | high) != 0u {
                add_words_to_grid(q, node, vec2<u32>(high, low));
            }
        }
    }
}

// Steps 1 and 3 for APIC, one block's chunk of particles per workgroup.
@compute @workgroup_size(64)
fn scatter_binned_apic(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                       @builtin(local_invocation_index) local: u32) {
    let chunk = load_chunk(group, groups, local);
    if chunk.z == 0u {
        return;
    }
    let first = block_first_node(chunk.x);
    if local < chunk.z {
        scatter_local_apic(particle_bins[3u * (chunk.y + local) + 2u], first);
    }
    flush_local(first, 4u, local);
}

// Steps 1 and 3 for PIC/FLIP, one block's chunk of particles per workgroup.
@compute @workgroup_size(64)
fn scatter_binned_pic_flip(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                           @builtin(local_invocation_index) local: u32) {
    let chunk = load_chunk(group, groups, local);
    if chunk.z == 0u {
        return;
    }
    let first = block_first_node(chunk.x);
    if local < chunk.z {
        scatter_local_pic_flip(particle_bins[3u * (chunk.y + local) + 2u], first);
    }
    flush_local(first, 7u, local);
}
