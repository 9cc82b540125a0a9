// The sparse grid's block table (nodes.wgsl), rebuilt at the start of every
// substep from the particles, as firn_mpm's sparse grid activates the
// blocks its particles reach: mark_blocks marks every block a snow
// particle's stencil reaches (the table was cleared to 0 before), then a
// prefix sum over the table in block-index order gives the marked blocks
// consecutive slots: count_blocks counts each chunk of 1024 blocks,
// block_offsets (one workgroup) turns the counts into each chunk's first
// slot, the number of allocated blocks (state.grid_blocks) and the node
// kernels' dispatch size (one workgroup per block), and assign_blocks writes
// each block's slot (or NO_SLOT) into the table and, for a slot within the
// capacity (params.flags.w), the block into bins[3 s + 2] with its particle
// count and first sorted slot zeroed for binning.wgsl. The slots follow the
// block index, so they do not depend on the order the GPU runs anything in;
// the sums do not depend on the slots either. More blocks than the
// capacity: begin_step stops the batch before the substep, and the host
// grows the grid and runs it again.

// Blocks per chunk of the prefix sum, four per invocation.
const CHUNK_BLOCKS: u32 = 1024u;
const CHUNK_THREADS: u32 = 256u;
// Words of `block_chunks` before the chunks' counts: the node kernels'
// indirect dispatch arguments and a spare word.
const CHUNK_HEADER: u32 = 4u;

var<workgroup> chunk_scan: array<u32, CHUNK_THREADS>;

// Marks the blocks of the nodes particle p's stencil reaches in the grid:
// the quadratic B-splines' 3^3 (APIC) or the cubic ones' 4^3 (PIC/FLIP)
// from the base node of common/bspline.wgsl, at most two blocks per axis.
@compute @workgroup_size(64)
fn mark_blocks(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
               @builtin(local_invocation_index) local: u32) {
    let p = snow_particle_index(group, groups, local);
    if p == NO_PARTICLE {
        return;
    }
    let x = grid_coordinate(position_mass[p].xyz);
    var base = vec3<i32>(floor(x - vec3<f32>(0.5)));
    var reach = 2;
    if params.flags.x == TRANSFER_PIC_FLIP {
        base = vec3<i32>(floor(x) - vec3<f32>(1.0));
        reach = 3;
    }
    let top = vec3<i32>(params.dims.xyz) - vec3<i32>(1);
    let first = vec3<u32>(clamp(base, vec3<i32>(0), top)) / BLOCK_WIDTH;
    let last = vec3<u32>(clamp(base + vec3<i32>(reach), vec3<i32>(0), top)) / BLOCK_WIDTH;
    for (var i = first.x; i <= last.x; i++) {
        for (var j = first.y; j <= last.y; j++) {
            for (var k = first.z; k <= last.z; k++) {
                atomicStore(&blocks[block_index(vec3<u32>(i, j, k))], 1u);
            }
        }
    }
}

// The chunk of a count_blocks or assign_blocks workgroup.
fn chunk_index(group: vec3<u32>, groups: vec3<u32>) -> u32 {
    return group.y * groups.x + group.x;
}

// The marks of an invocation's four blocks (1 marked, 0 not or past the end).
fn marks_of(chunk: u32, local: u32) -> vec4<u32> {
    let first = chunk * CHUNK_BLOCKS + local * 4u;
    var marks = vec4<u32>(0u);
    for (var b = 0u; b < 4u; b++) {
        if first + b < block_count() {
            marks[b] = min(atomicLoad(&blocks[first + b]), 1u);
        }
    }
    return marks;
}

// The sum of one value per invocation, which every invocation gets; on the
// way, chunk_scan[t] becomes the sum of the values of invocations before t.
fn chunk_exclusive_scan(value: u32, local: u32) -> u32 {
    chunk_scan[local] = value;
    for (var stride = 1u; stride < CHUNK_THREADS; stride <<= 1u) {
        workgroupBarrier();
        var add = 0u;
        if local >= stride {
            add = chunk_scan[local - stride];
        }
        workgroupBarrier();
        chunk_scan[local] += add;
    }
    workgroupBarrier();
    let total = chunk_scan[CHUNK_THREADS - 1u];
    workgroupBarrier();
    chunk_scan[local] -= value;
    return total;
}

// Counts the marked blocks of each chunk.
@compute @workgroup_size(256)
fn count_blocks(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                @builtin(local_invocation_index) local: u32) {
    let chunk = chunk_index(group, groups);
    let marks = marks_of(chunk, local);
    let total = chunk_exclusive_scan(dot(marks, vec4<u32>(1u)), local);
    if local == 0u && chunk * CHUNK_BLOCKS < block_count() {
        block_chunks[CHUNK_HEADER + chunk] = total;
    }
}

// One workgroup: each chunk's first slot (an exclusive prefix sum of the
// counts, in place), the allocated blocks and the node kernels' dispatch.
@compute @workgroup_size(256)
fn block_offsets(@builtin(local_invocation_index) local: u32) {
    let chunks = (block_count() + CHUNK_BLOCKS - 1u) / CHUNK_BLOCKS;
    let per_thread = (chunks + CHUNK_THREADS - 1u) / CHUNK_THREADS;
    let first = min(local * per_thread, chunks);
    let last = min(first + per_thread, chunks);
    var count = 0u;
    for (var c = first; c < last; c++) {
        count += block_chunks[CHUNK_HEADER + c];
    }
    let total = chunk_exclusive_scan(count, local);
    var slot = chunk_scan[local];
    for (var c = first; c < last; c++) {
        let chunk_count = block_chunks[CHUNK_HEADER + c];
        block_chunks[CHUNK_HEADER + c] = slot;
        slot += chunk_count;
    }
    if local == 0u {
        // Past the frame's end or after begin_step stopped the batch nothing
        // is marked; the count the host reads stays the last substep's.
        if state.running != 0u {
            state.grid_blocks = total;
        }
        let x = min(total, params.flags.y);
        block_chunks[0] = x;
        block_chunks[1] = select(1u, (total + x - 1u) / max(x, 1u), x > 0u);
        block_chunks[2] = 1u;
    }
}

// Each block's slot, in block-index order, and each slot's block.
@compute @workgroup_size(256)
fn assign_blocks(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                 @builtin(local_invocation_index) local: u32) {
    let chunk = chunk_index(group, groups);
    let marks = marks_of(chunk, local);
    _ = chunk_exclusive_scan(dot(marks, vec4<u32>(1u)), local);
    if chunk * CHUNK_BLOCKS >= block_count() {
        return;
    }
    var slot = block_chunks[CHUNK_HEADER + chunk] + chunk_scan[local];
    let first = chunk * CHUNK_BLOCKS + local * 4u;
    for (var b = 0u; b < 4u; b++) {
        if first + b >= block_count() {
            break;
        }
        if marks[b] == 0u {
            atomicStore(&blocks[first + b], NO_SLOT);
            continue;
        }
        atomicStore(&blocks[first + b], slot);
        if slot < params.flags.w {
            atomicStore(&bins[3u * slot], 0u);
            atomicStore(&bins[3u * slot + 1u], 0u);
            atomicStore(&bins[3u * slot + 2u], first + b);
        }
        slot++;
    }
}
