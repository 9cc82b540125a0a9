// The grid update (thesis §3.4 steps 4 and 5, as firn_mpm::grid_update):
// grid velocities from the scattered momentum, v_i = p_i / m_i, the forces
// and gravity, v_i* = v_i + dt (f_i / m_i + g) (for APIC the force impulse is
// already inside the momentum), the wind's drag where the scene has one
// (wind.wgsl), the grid-based collisions with the
// colliders placed at the substep's end (Quellcode 12), and the rigid
// bodies' push, summed for them (coupling.wgsl). The velocities
// replace the sums in the word planes: v_i in the low words, v_i* in the
// high words, for the gather. One workgroup per allocated block
// (nodes.wgsl), dispatched indirectly.

fn momentum_at(node: u32) -> vec3<f32> {
    return vec3<f32>(
        from_fixed(atomicLoad(&px_hi[node]), atomicLoad(&px_lo[node])),
        from_fixed(atomicLoad(&py_hi[node]), atomicLoad(&py_lo[node])),
        from_fixed(atomicLoad(&pz_hi[node]), atomicLoad(&pz_lo[node])),
    );
}

fn impulse_at(node: u32) -> vec3<f32> {
    return vec3<f32>(
        from_fixed(atomicLoad(&fx_hi[node]), atomicLoad(&fx_lo[node])),
        from_fixed(atomicLoad(&fy_hi[node]), atomicLoad(&fy_lo[node])),
        from_fixed(atomicLoad(&fz_hi[node]), atomicLoad(&fz_lo[node])),
    );
}

// Stores v_i in the low word planes and v_i^{n+1} in the high ones.
fn store_node_velocities(node: u32, velocity: vec3<f32>, velocity_new: vec3<f32>) {
    atomicStore(&px_lo[node], bitcast<u32>(velocity.x));
    atomicStore(&py_lo[node], bitcast<u32>(velocity.y));
    atomicStore(&pz_lo[node], bitcast<u32>(velocity.z));
    atomicStore(&px_hi[node], bitcast<u32>(velocity_new.x));
    atomicStore(&py_hi[node], bitcast<u32>(velocity_new.y));
    atomicStore(&pz_hi[node], bitcast<u32>(velocity_new.z));
}

// A node's velocities after steps 4 and 5: v_i and v_i^{n+1}, with its
// snow mass (0 for a node without, whose velocities are zero) and position.
struct NodeVelocities {
    mass: f32,
    position: vec3<f32>,
    velocity: vec3<f32>,
    velocity_new: vec3<f32>,
}

// Steps 4 and 5: v_i = p_i / m_i, v_i* = v_i + dt (f_i / m_i + g), the
// wind's drag when `windy`, then, when `colliding`, the grid collisions at
// the end of the substep, on a node with mass. The semi-implicit integrator
// leaves the collisions to its solve (implicit.wgsl), which records the
// components they fix. The entry points below pass `windy` and `colliding`
// as constants, so the scene without wind runs no wind code: lavapipe, for
// one, runs both sides of a branch it cannot prove uniform.
fn node_velocities(node: u32, windy: bool, colliding: bool) -> NodeVelocities {
    let mass = from_fixed(atomicLoad(&mass_hi[node]), atomicLoad(&mass_lo[node])) / params.scales.x;
    if mass <= 0.0 {
        return NodeVelocities(0.0, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    }
    let inverse_mass = 1.0 / mass;
    let velocity = momentum_at(node) / params.scales.y * inverse_mass;
    var change = params.gravity.xyz * state.dt;
    if params.flags.x == TRANSFER_PIC_FLIP {
        change += impulse_at(node) / params.scales.y * inverse_mass;
    }
    let cell = node_cell(node);
    let position = params.origin.xyz + vec3<f32>(cell) * params.origin.w;
    var velocity_star = velocity + change;
    if windy {
        velocity_star = blown(vec3<i32>(cell), mass, velocity_star, position);
    }
    var velocity_new = velocity_star;
    if colliding {
        velocity_new = collide_all(position, velocity_star);
    }
    return NodeVelocities(mass, position, velocity, velocity_new);
}

// Whether an invocation of the grid update has a node to update.
fn updates_node(node: u32) -> bool {
    return node < allocated_nodes() && state.running != 0u;
}

// Steps 4 and 5 on node `node` (node_velocities), stored for the gather.
fn update_node(node: u32, windy: bool, colliding: bool) {
    if !updates_node(node) {
        return;
    }
    let node_state = node_velocities(node, windy, colliding);
    store_node_velocities(node, node_state.velocity, node_state.velocity_new);
}

// update_node with the colliders, then the rigid bodies' push on a node
// with mass, summed for them (coupling.wgsl). A function of its own, so
// that the kernels of scenes without bodies do not bind their buffers.
fn update_coupled_node(node: u32, windy: bool) {
    if !updates_node(node) {
        return;
    }
    let node_state = node_velocities(node, windy, true);
    var velocity_new = node_state.velocity_new;
    if node_state.mass > 0.0 {
        velocity_new = collide_bodies(node_state.position, node_state.mass, velocity_new);
    }
    store_node_velocities(node, node_state.velocity, velocity_new);
}

// The grid update of a scene without wind.
@compute @workgroup_size(64)
fn update_grid(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
               @builtin(local_invocation_index) local: u32) {
    update_node(linear_index(group, groups, local), false, true);
}

// The grid update of a scene with a [wind]; with no drag there is nothing to
// do. (A constant `true` here, which lets the compiler unroll the whole
// field, crashed lavapipe, Mesa's software Vulkan, while running the kernel;
// the uniform test keeps it working and costs nothing.)
@compute @workgroup_size(64)
fn update_grid_in_wind(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                       @builtin(local_invocation_index) local: u32) {
    update_node(linear_index(group, groups, local), wind.node_drag > 0.0, true);
}

// The grid update of a semi-implicit scene without wind: v* without the
// collisions, which the solve applies.
@compute @workgroup_size(64)
fn update_grid_free(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                    @builtin(local_invocation_index) local: u32) {
    update_node(linear_index(group, groups, local), false, false);
}

// The grid update of a semi-implicit scene with a [wind].
@compute @workgroup_size(64)
fn update_grid_free_in_wind(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                            @builtin(local_invocation_index) local: u32) {
    update_node(linear_index(group, groups, local), wind.node_drag > 0.0, false);
}

// The grid update of a scene with rigid bodies and without wind: the
// workgroup first marks the bodies near its block.
@compute @workgroup_size(64)
fn update_grid_coupled(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                       @builtin(local_invocation_index) local: u32) {
    let node = linear_index(group, groups, local);
    mark_near_bodies(node - local, local);
    update_coupled_node(node, false);
}

// The grid update of a scene with rigid bodies and a [wind].
@compute @workgroup_size(64)
fn update_grid_coupled_in_wind(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                               @builtin(local_invocation_index) local: u32) {
    let node = linear_index(group, groups, local);
    mark_near_bodies(node - local, local);
    update_coupled_node(node, wind.node_drag > 0.0);
}
