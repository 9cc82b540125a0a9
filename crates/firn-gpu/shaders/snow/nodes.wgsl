// Node addressing on the sparse grid. The grid's nodes are stored by block
// of 4^3 nodes: an allocated block owns 64 consecutive nodes of every word
// plane and node vector, from 64 times its slot on, node (x, y, z) of the
// block being its ((x * 4 + y) * 4 + z)-th. The block table `blocks` gives
// each block of the domain its slot, or NO_SLOT; blocks.wgsl builds it each
// substep from the particles' stencils, and `bins[3 s + 2]` names the block
// in slot s.

const BLOCK_WIDTH: u32 = 4u;
const BLOCK_NODES: u32 = 64u;
const NO_SLOT: u32 = 0xffffffffu;
const NO_NODE: u32 = 0xffffffffu;

fn block_dims() -> vec3<u32> {
    return params.dims.xyz / BLOCK_WIDTH;
}

fn block_count() -> u32 {
    let dims = block_dims();
    return dims.x * dims.y * dims.z;
}

fn block_index(coord: vec3<u32>) -> u32 {
    let dims = block_dims();
    return (coord.x * dims.y + coord.y) * dims.z + coord.z;
}

fn block_coord(block: u32) -> vec3<u32> {
    let dims = block_dims();
    return vec3<u32>(block / (dims.y * dims.z), block / dims.z % dims.y, block % dims.z);
}

fn inside_grid(node: vec3<i32>) -> bool {
    return all(node >= vec3<i32>(0)) && all(node < vec3<i32>(params.dims.xyz));
}

// Where the node at `node` (inside the grid) is stored, or NO_NODE when its
// block holds no slot this substep (no particle reaches it: no mass).
fn node_index(node: vec3<i32>) -> u32 {
    let at = vec3<u32>(node);
    let slot = atomicLoad(&blocks[block_index(at / BLOCK_WIDTH)]);
    if slot == NO_SLOT {
        return NO_NODE;
    }
    let within = at % BLOCK_WIDTH;
    return slot * BLOCK_NODES + (within.x * BLOCK_WIDTH + within.y) * BLOCK_WIDTH + within.z;
}

// The grid coordinates of the stored node `node` (below allocated_nodes()).
fn node_cell(node: u32) -> vec3<u32> {
    let within = node % BLOCK_NODES;
    let offset = vec3<u32>(within / 16u, within / BLOCK_WIDTH % BLOCK_WIDTH, within % BLOCK_WIDTH);
    return block_coord(atomicLoad(&bins[3u * (node / BLOCK_NODES) + 2u])) * BLOCK_WIDTH + offset;
}

// Nodes stored this substep: 64 per allocated block.
fn allocated_nodes() -> u32 {
    return state.grid_blocks * BLOCK_NODES;
}

// Nodes each node vector has room for (64 per block of capacity).
fn node_capacity() -> u32 {
    return params.flags.w * BLOCK_NODES;
}
