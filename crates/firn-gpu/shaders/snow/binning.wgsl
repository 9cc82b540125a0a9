// The binned scatter: particles are sorted by grid block (4^3 cells) every
// substep with a counting sort, then each workgroup takes up to 64
// particles of one block and sums their contributions in workgroup memory
// over the 7^3 nodes a block's particles reach, before adding the sums to
// the grid with one 64-bit atomic add per node and quantity. That is the
// GPU form of the CPU's per-block local scatter: far fewer global atomics,
// and neighbouring invocations share nodes in fast memory.

const BLOCK_CELLS: i32 = 4;
const LOCAL_REACH: u32 = 7u;
const LOCAL_NODES: u32 = 343u;
// 343 nodes x 7 quantities (PIC/FLIP) x 2 words.
const MAX_LOCAL_WORDS: u32 = 4802u;
// Particles per work item: one per invocation.
const CHUNK: u32 = 64u;
// Words of `work` before the items: indirect dispatch arguments and the item count.
const WORK_HEADER: u32 = 4u;
const SCAN_THREADS: u32 = 256u;

// [2b]: particles in block b; [2b + 1]: the block's first slot in sorted order.
@group(0) @binding(25) var<storage, read_write> bins: array<atomic<u32>>;
// [3p]: block of particle p; [3p + 1]: its rank in the block; [3s + 2]: the particle in slot s.
@group(0) @binding(26) var<storage, read_write> particle_bins: array<u32>;
// [0..3): dispatch size of the binned scatter; [3]: work items; then per
// item its block and first slot.
@group(0) @binding(27) var<storage, read_write> work: array<u32>;

var<workgroup> local_sums: array<atomic<u32>, MAX_LOCAL_WORDS>;
var<workgroup> chunk_header: vec3<u32>;
var<workgroup> scan_particles: array<u32, SCAN_THREADS>;
var<workgroup> scan_items: array<u32, SCAN_THREADS>;

fn block_dims() -> vec3<u32> {
    return params.dims.xyz / u32(BLOCK_CELLS);
}

fn block_count() -> u32 {
    let dims = block_dims();
    return dims.x * dims.y * dims.z;
}

// The first node of the 7^3 a block's particles reach: one before the block.
fn block_first_node(block: u32) -> vec3<i32> {
    let dims = block_dims();
    let coord = vec3<u32>(block / (dims.y * dims.z), block / dims.z % dims.y, block % dims.z);
    return vec3<i32>(coord) * BLOCK_CELLS - vec3<i32>(1);
}

// Counts each block's particles and gives each particle its rank there.
@compute @workgroup_size(64)
fn bin_count(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
             @builtin(local_invocation_index) local: u32) {
    let p = particle_index(group, groups, local);
    if p == NO_PARTICLE {
        return;
    }
    let cell = vec3<i32>(floor(grid_coordinate(position_mass[p].xyz)));
    let coord = vec3<u32>(clamp(cell / BLOCK_CELLS, vec3<i32>(0), vec3<i32>(block_dims()) - vec3<i32>(1)));
    let dims = block_dims();
    let block = (coord.x * dims.y + coord.y) * dims.z + coord.z;
    particle_bins[3u * p] = block;
    particle_bins[3u * p + 1u] = atomicAdd(&bins[2u * block], 1u);
}

// One workgroup: exclusive prefix sums of the block counts (first slots)
// and of their 64-particle chunks (work items), the work items, and the
// binned scatter's dispatch size.
@compute @workgroup_size(256)
fn bin_offsets(@builtin(local_invocation_index) local: u32) {
    let blocks = block_count();
    let per_thread = (blocks + SCAN_THREADS - 1u) / SCAN_THREADS;
    let first = min(local * per_thread, blocks);
    let last = min(first + per_thread, blocks);
    var particles = 0u;
    var items = 0u;
    for (var b = first; b < last; b++) {
        let count = atomicLoad(&bins[2u * b]);
        particles += count;
        items += (count + CHUNK - 1u) / CHUNK;
    }
    scan_particles[local] = particles;
    scan_items[local] = items;
    workgroupBarrier();
    if local == 0u {
        var particle_total = 0u;
        var item_total = 0u;
        for (var t = 0u; t < SCAN_THREADS; t++) {
            let p = scan_particles[t];
            let i = scan_items[t];
            scan_particles[t] = particle_total;
            scan_items[t] = item_total;
            particle_total += p;
            item_total += i;
        }
        let x = min(item_total, params.flags.y);
        work[0] = x;
        work[1] = select(1u, (item_total + x - 1u) / max(x, 1u), x > 0u);
        work[2] = 1u;
        work[3] = item_total;
    }
    workgroupBarrier();
    var slot = scan_particles[local];
    var item = scan_items[local];
    for (var b = first; b < last; b++) {
        let count = atomicLoad(&bins[2u * b]);
        atomicStore(&bins[2u * b + 1u], slot);
        for (var start = 0u; start < count; start += CHUNK) {
            work[WORK_HEADER + 2u * item] = b;
            work[WORK_HEADER + 2u * item + 1u] = slot + start;
            item++;
        }
        slot += count;
    }
}

// Puts each particle in its slot.
@compute @workgroup_size(64)
fn bin_sort(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
            @builtin(local_invocation_index) local: u32) {
    let p = particle_index(group, groups, local);
    if p == NO_PARTICLE {
        return;
    }
    let block = particle_bins[3u * p];
    let slot = atomicLoad(&bins[2u * block + 1u]) + particle_bins[3u * p + 1u];
    particle_bins[3u * slot + 2u] = p;
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

// The work item of this workgroup: (block, first slot, particles), with
// zero particles past the last item. Uniform across the workgroup.
fn load_chunk(group: vec3<u32>, groups: vec3<u32>, local: u32) -> vec3<u32> {
    if local == 0u {
        let item = group.y * groups.x + group.x;
        chunk_header = vec3<u32>(0u);
        if item < work[3] {
            let block = work[WORK_HEADER + 2u * item];
            let first = work[WORK_HEADER + 2u * item + 1u];
            let end = atomicLoad(&bins[2u * block + 1u]) + atomicLoad(&bins[2u * block]);
            chunk_header = vec3<u32>(block, first, min(CHUNK, end - first));
        }
    }
    return workgroupUniformLoad(&chunk_header);
}

// Adds the workgroup's non-zero sums into the grid.
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
