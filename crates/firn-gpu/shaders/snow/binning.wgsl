// The counting sort of the particles by grid block (4^3 cells) that the
// binned scatter (p2g.wgsl) runs on, every substep, as firn_mpm::binning
// bins them on the CPU: bin_count counts each block's particles and ranks
// them, bin_offsets turns the counts into first slots and 64-particle work
// items (and the binned scatter's indirect dispatch size), and bin_sort puts
// each particle in its slot. The buffers are bins, particle_bins and work
// (src/snow/bindings.rs); bins has one entry per allocated block, at the
// block's slot in the grid (nodes.wgsl, blocks.wgsl), so the blocks are
// sorted in block-index order as on a dense grid.

const BLOCK_CELLS: i32 = 4;
// Particles per work item: one per invocation.
const CHUNK: u32 = 64u;
// Words of `work` before the items: indirect dispatch arguments and the item count.
const WORK_HEADER: u32 = 4u;
const SCAN_THREADS: u32 = 256u;

var<workgroup> scan_particles: array<u32, SCAN_THREADS>;
var<workgroup> scan_items: array<u32, SCAN_THREADS>;

// Counts each block's particles and gives each particle its rank there.
@compute @workgroup_size(64)
fn bin_count(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
             @builtin(local_invocation_index) local: u32) {
    let p = snow_particle_index(group, groups, local);
    if p == NO_PARTICLE {
        return;
    }
    let cell = vec3<i32>(floor(grid_coordinate(position_mass[p].xyz)));
    let coord = vec3<u32>(clamp(cell / BLOCK_CELLS, vec3<i32>(0), vec3<i32>(block_dims()) - vec3<i32>(1)));
    // The particle's stencil reaches its own block, so mark_blocks gave it a slot.
    let slot = atomicLoad(&blocks[block_index(coord)]);
    particle_bins[3u * p] = slot;
    particle_bins[3u * p + 1u] = atomicAdd(&bins[3u * slot], 1u);
}

// One workgroup: exclusive prefix sums of the allocated blocks' counts
// (first slots) and of their 64-particle chunks (work items), the work
// items, and the binned scatter's dispatch size.
@compute @workgroup_size(256)
fn bin_offsets(@builtin(local_invocation_index) local: u32) {
    let allocated = min(state.grid_blocks, params.flags.w);
    let per_thread = (allocated + SCAN_THREADS - 1u) / SCAN_THREADS;
    let first = min(local * per_thread, allocated);
    let last = min(first + per_thread, allocated);
    var particles = 0u;
    var items = 0u;
    for (var b = first; b < last; b++) {
        let count = atomicLoad(&bins[3u * b]);
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
        let count = atomicLoad(&bins[3u * b]);
        atomicStore(&bins[3u * b + 1u], slot);
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
    let p = snow_particle_index(group, groups, local);
    if p == NO_PARTICLE {
        return;
    }
    let block_slot = particle_bins[3u * p];
    let slot = atomicLoad(&bins[3u * block_slot + 1u]) + particle_bins[3u * p + 1u];
    particle_bins[3u * slot + 2u] = p;
}
