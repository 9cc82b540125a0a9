// A run split between processes (MPI ranks) with a GPU each
// (firn_gpu::snow::parts): after the scatter, the sums of the grid blocks
// that other parts reach too are packed for the host to send, and the
// other parts' sums of the blocks this part reaches are added in, before
// the grid update. The sums are 64-bit fixed-point integers
// (fixed_point.wgsl), so every part then holds the one process's sums,
// whatever the order they were added in.
//
// `trade_slots[0]` is the number of listed blocks, `trade_slots[1 + b]`
// the grid slot of listed block b. In `traded`, listed block b takes
// traded_block_words() words from b times that on: per quantity the
// transfer sums (mass and momentum; PIC/FLIP also the force impulse), 64
// low words, then 64 high words, node by node in the block's order.

// The quantities the scatter sums: mass and momentum x, y, z (APIC); and
// the force impulse x, y, z (PIC/FLIP).
fn traded_quantities() -> u32 {
    if params.flags.x == TRANSFER_APIC {
        return 4u;
    }
    return 7u;
}

fn traded_block_words() -> u32 {
    return traded_quantities() * 2u * BLOCK_NODES;
}

// The (high, low) words of node's sum of quantity.
fn grid_words(quantity: u32, node: u32) -> vec2<u32> {
    switch quantity {
        case QUANTITY_MASS: {
            return vec2<u32>(atomicLoad(&mass_hi[node]), atomicLoad(&mass_lo[node]));
        }
        case QUANTITY_MOMENTUM_X: {
            return vec2<u32>(atomicLoad(&px_hi[node]), atomicLoad(&px_lo[node]));
        }
        case QUANTITY_MOMENTUM_Y: {
            return vec2<u32>(atomicLoad(&py_hi[node]), atomicLoad(&py_lo[node]));
        }
        case QUANTITY_MOMENTUM_Z: {
            return vec2<u32>(atomicLoad(&pz_hi[node]), atomicLoad(&pz_lo[node]));
        }
        case QUANTITY_FORCE_X: {
            return vec2<u32>(atomicLoad(&fx_hi[node]), atomicLoad(&fx_lo[node]));
        }
        case QUANTITY_FORCE_Y: {
            return vec2<u32>(atomicLoad(&fy_hi[node]), atomicLoad(&fy_lo[node]));
        }
        default: {
            return vec2<u32>(atomicLoad(&fz_hi[node]), atomicLoad(&fz_lo[node]));
        }
    }
}

// The listed block a workgroup works on, or NO_SLOT past the list.
fn listed_block(group: vec3<u32>, groups: vec3<u32>) -> u32 {
    let listed = group.y * groups.x + group.x;
    if listed >= trade_slots[0] {
        return NO_SLOT;
    }
    return listed;
}

// One workgroup per listed block, one invocation per node: copies the
// block's sums into `traded`.
@compute @workgroup_size(64)
fn pack_traded_sums(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                    @builtin(local_invocation_index) local: u32) {
    let listed = listed_block(group, groups);
    if listed == NO_SLOT {
        return;
    }
    let node = trade_slots[1u + listed] * BLOCK_NODES + local;
    let first = listed * traded_block_words();
    for (var quantity = 0u; quantity < traded_quantities(); quantity++) {
        let words = grid_words(quantity, node);
        let at = first + 2u * quantity * BLOCK_NODES + local;
        traded[at] = words.y;
        traded[at + BLOCK_NODES] = words.x;
    }
}

// One workgroup per listed block, one invocation per node: adds the sums
// in `traded` (another part's) into the block's.
@compute @workgroup_size(64)
fn add_traded_sums(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                   @builtin(local_invocation_index) local: u32) {
    let listed = listed_block(group, groups);
    if listed == NO_SLOT {
        return;
    }
    let node = trade_slots[1u + listed] * BLOCK_NODES + local;
    let first = listed * traded_block_words();
    for (var quantity = 0u; quantity < traded_quantities(); quantity++) {
        let at = first + 2u * quantity * BLOCK_NODES + local;
        add_words_to_grid(quantity, node, vec2<u32>(traded[at + BLOCK_NODES], traded[at]));
    }
}
