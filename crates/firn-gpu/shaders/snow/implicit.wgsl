// Step 6 of Stomakhin et al. 2013 (their eq. 9), as firn_mpm::implicit: the
// semi-implicit grid velocities from
//
//   (M + beta dt^2 H) v^{n+1} = M v*,
//
// solved by conjugate residuals from v*, preconditioned by M^-1, on the free
// velocity components of the nodes in contact (P S P x = P M v*, S =
// M + beta dt^2 H). The grid update before it (grid_update.wgsl,
// update_grid_free) leaves v* without the collisions; solve_load applies
// them and records the components they fix (colliders.wgsl,
// collide_all_constrained); solve_store applies them once more to the
// result.
//
// H is never assembled. Per particle, linearize keeps the stress
// differential (common/stress_differential.wgsl) for the whole solve; a
// product with H gathers dF_E = beta dt^2 (sum_i y_i grad w_ip^T) F_E over
// the particle's stencil and scatters A_p F_E^T grad w_ip,
// A_p = V_p^0 dP(dF_E), into the force word planes as 64-bit fixed point
// (fixed_point.wgsl): the sums do not depend on the order particles run in.
// The node kernel that reads a product zeroes its words for the next one.
//
// Each node kernel also reduces one dot product: a fixed tree over its
// workgroup into one partial per workgroup, which a one-workgroup kernel
// sums in a fixed order and turns into the recurrence's scalars (alpha,
// gamma, the residual, the stopping test) in `solve`. Nothing is read back
// per iteration; the host records a few iterations at a time and reads
// `solve.running` between them. Once the solve stops, every kernel of it
// returns at once. The node kernels run one workgroup per allocated block
// of the sparse grid (nodes.wgsl), so a workgroup's partial is its block's.

// The node vectors, one plane of nodes each: the first four in
// solve_vectors, the rest in solve_products.
const VECTOR_X: u32 = 0u;
const VECTOR_R: u32 = 1u;
const VECTOR_Z: u32 = 2u;
const VECTOR_P: u32 = 3u;
const VECTOR_SP: u32 = 4u;
const VECTOR_PRODUCT: u32 = 5u;
// xyz: direction, w: kind (colliders.wgsl, CONSTRAINT_*).
const VECTOR_CONSTRAINT: u32 = 6u;
const VECTORS_IN_FIRST_BUFFER: u32 = 4u;

// The solve's state within a substep, and the partial sums of the
// workgroups' reductions.
struct SolveState {
    // 1 while the conjugate residuals iterate.
    running: u32,
    // 1 once this substep's solve has begun.
    solved: u32,
    // Iterations (products with H besides the first).
    iterations: u32,
    // 1 if the residual reached the tolerance.
    converged: u32,
    // Nodes with mass.
    active_nodes: atomic<u32>,
    // Relative residual |r| / max(|M v*|, |r_0|) in the M^-1 norm.
    residual: f32,
    // |M v*|^2 in the M^-1 norm.
    momentum: f32,
    // The squared residual the solve stops at.
    stop_at: f32,
    reference: f32,
    // r . z, z . S z, S p . M^-1 S p of the recurrence.
    rz: f32,
    z_sz: f32,
    denominator: f32,
    alpha: f32,
    gamma: f32,
    pad0: u32,
    pad1: u32,
    // One sum per workgroup of the last node kernel.
    partials: array<f32>,
}

fn node_count() -> u32 {
    return allocated_nodes();
}

fn node_word(vector: u32, node: u32) -> vec4<f32> {
    if vector < VECTORS_IN_FIRST_BUFFER {
        return solve_vectors[vector * node_capacity() + node];
    }
    return solve_products[(vector - VECTORS_IN_FIRST_BUFFER) * node_capacity() + node];
}

fn set_node_word(vector: u32, node: u32, value: vec4<f32>) {
    if vector < VECTORS_IN_FIRST_BUFFER {
        solve_vectors[vector * node_capacity() + node] = value;
    } else {
        solve_products[(vector - VECTORS_IN_FIRST_BUFFER) * node_capacity() + node] = value;
    }
}

fn node_vector(vector: u32, node: u32) -> vec3<f32> {
    return node_word(vector, node).xyz;
}

fn set_node_vector(vector: u32, node: u32, value: vec3<f32>) {
    set_node_word(vector, node, vec4<f32>(value, 0.0));
}

fn node_constraint(node: u32) -> vec4<f32> {
    return node_word(VECTOR_CONSTRAINT, node);
}

fn solve_node_mass(node: u32) -> f32 {
    return from_fixed(atomicLoad(&mass_hi[node]), atomicLoad(&mass_lo[node])) / params.scales.x;
}

// 1 / m_i, the preconditioner; 0 for nodes without mass.
fn inverse_node_mass(node: u32) -> f32 {
    let mass = solve_node_mass(node);
    return select(0.0, 1.0 / mass, mass > 0.0);
}

fn node_position(node: u32) -> vec3<f32> {
    return params.origin.xyz + vec3<f32>(node_cell(node)) * params.origin.w;
}

fn solve_running() -> bool {
    return state.running != 0u && solve.running != 0u;
}

// The last product beta dt^2 H y at a node, read from the force word planes,
// which are zeroed for the next product (the load zeroes them first).
fn take_product(node: u32) -> vec3<f32> {
    let sum = vec3<f32>(
        from_fixed(atomicLoad(&fx_hi[node]), atomicLoad(&fx_lo[node])),
        from_fixed(atomicLoad(&fy_hi[node]), atomicLoad(&fy_lo[node])),
        from_fixed(atomicLoad(&fz_hi[node]), atomicLoad(&fz_lo[node])),
    );
    atomicStore(&fx_lo[node], 0u);
    atomicStore(&fx_hi[node], 0u);
    atomicStore(&fy_lo[node], 0u);
    atomicStore(&fy_hi[node], 0u);
    atomicStore(&fz_lo[node], 0u);
    atomicStore(&fz_hi[node], 0u);
    return sum / params.scales.y;
}

// ---- per particle ----

// The stress differential of every snow particle at its F_E, with hardened
// mu and lambda (eq. 35), once per substep.
@compute @workgroup_size(64)
fn linearize(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
             @builtin(local_invocation_index) local: u32) {
    let p = snow_particle_index(group, groups, local);
    if p == NO_PARTICLE {
        return;
    }
    let material = materials[plastic[p].material & MATERIAL_BITS];
    let factor = exp(material.hardening * (1.0 - plastic[p].plastic_j));
    linearized[p] = stress_differential(elastic[p], material.mu0 * factor, material.lambda0 * factor,
                                        velocity_volume[p].w);
}

// A product's force at one stencil node: A_p F_E^T grad w_ip.
fn add_hessian_force(node: u32, stress: mat3x3<f32>, gradient: vec3<f32>) {
    let force = stress * gradient * params.scales.y;
    add_to_grid(QUANTITY_FORCE_X, node, force.x);
    add_to_grid(QUANTITY_FORCE_Y, node, force.y);
    add_to_grid(QUANTITY_FORCE_Z, node, force.z);
}

// A_p F_E^T for particle p's velocity gradient sum_i y_i grad w_ip^T.
fn hessian_stress(p: u32, velocity_gradient: mat3x3<f32>) -> mat3x3<f32> {
    let d = linearized[p];
    let delta = velocity_gradient * d.elastic * (params.implicit.x * state.dt * state.dt);
    return apply_stress_differential(d, delta) * transpose(d.elastic);
}

// PIC/FLIP: the cubic B-spline gradients (eq. 39-40).
fn scatter_hessian_cubic(p: u32, vector: u32) {
    let weights = cubic_weights(grid_coordinate(position_mass[p].xyz));
    let inverse_h = 1.0 / params.origin.w;
    var gradient_sum = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var i = 0; i < 4; i++) {
        for (var j = 0; j < 4; j++) {
            for (var k = 0; k < 4; k++) {
                let cell = weights.base + vec3<i32>(i, j, k);
                if !inside_grid(cell) {
                    continue;
                }
                let g = weight_gradient(weights.values[i], weights.values[j], weights.values[k],
                                        weights.slopes[i], weights.slopes[j], weights.slopes[k]) * inverse_h;
                let y = node_vector(vector, node_index(cell));
                gradient_sum += mat3x3<f32>(y * g.x, y * g.y, y * g.z);
            }
        }
    }
    let stress = hessian_stress(p, gradient_sum);
    for (var i = 0; i < 4; i++) {
        for (var j = 0; j < 4; j++) {
            for (var k = 0; k < 4; k++) {
                let cell = weights.base + vec3<i32>(i, j, k);
                if !inside_grid(cell) {
                    continue;
                }
                let g = weight_gradient(weights.values[i], weights.values[j], weights.values[k],
                                        weights.slopes[i], weights.slopes[j], weights.slopes[k]) * inverse_h;
                add_hessian_force(node_index(cell), stress, g);
            }
        }
    }
}

// APIC in the MLS form: grad w_ip = (4/h^2) w_ip (x_i - x_p) over the
// quadratic stencil.
fn scatter_hessian_mls(p: u32, vector: u32) {
    let weights = quadratic_weights(grid_coordinate(position_mass[p].xyz));
    let scale = 4.0 / params.origin.w;
    var gradient_sum = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var i = 0; i < 3; i++) {
        for (var j = 0; j < 3; j++) {
            for (var k = 0; k < 3; k++) {
                let cell = weights.base + vec3<i32>(i, j, k);
                if !inside_grid(cell) {
                    continue;
                }
                let w = weights.values[i].x * weights.values[j].y * weights.values[k].z;
                let g = (vec3<f32>(f32(i), f32(j), f32(k)) - weights.offset) * (w * scale);
                let y = node_vector(vector, node_index(cell));
                gradient_sum += mat3x3<f32>(y * g.x, y * g.y, y * g.z);
            }
        }
    }
    let stress = hessian_stress(p, gradient_sum);
    for (var i = 0; i < 3; i++) {
        for (var j = 0; j < 3; j++) {
            for (var k = 0; k < 3; k++) {
                let cell = weights.base + vec3<i32>(i, j, k);
                if !inside_grid(cell) {
                    continue;
                }
                let w = weights.values[i].x * weights.values[j].y * weights.values[k].z;
                let g = (vec3<f32>(f32(i), f32(j), f32(k)) - weights.offset) * (w * scale);
                add_hessian_force(node_index(cell), stress, g);
            }
        }
    }
}

// beta dt^2 H y into the force word planes, y the node vector `vector`.
fn scatter_hessian(group: vec3<u32>, groups: vec3<u32>, local: u32, vector: u32) {
    let p = snow_particle_index(group, groups, local);
    if p == NO_PARTICLE || solve.running == 0u {
        return;
    }
    if params.flags.x == TRANSFER_PIC_FLIP {
        scatter_hessian_cubic(p, vector);
    } else {
        scatter_hessian_mls(p, vector);
    }
}

// The product with the starting iterate x = v*.
@compute @workgroup_size(64)
fn hessian_of_x(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                @builtin(local_invocation_index) local: u32) {
    scatter_hessian(group, groups, local, VECTOR_X);
}

// The product with the preconditioned residual z.
@compute @workgroup_size(64)
fn hessian_of_z(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                @builtin(local_invocation_index) local: u32) {
    scatter_hessian(group, groups, local, VECTOR_Z);
}

// ---- reductions ----

var<workgroup> group_terms: array<f32, 64>;
var<workgroup> group_flag: u32;

// Invocation 0's `value`, the same for the whole workgroup.
fn workgroup_flag(value: bool, local: u32) -> bool {
    if local == 0u {
        group_flag = select(0u, 1u, value);
    }
    return workgroupUniformLoad(&group_flag) != 0u;
}

// The sum of one term per invocation, added in a fixed tree.
fn workgroup_sum(term: f32, local: u32) -> f32 {
    group_terms[local] = term;
    for (var stride = 32u; stride > 0u; stride >>= 1u) {
        workgroupBarrier();
        if local < stride {
            group_terms[local] += group_terms[local + stride];
        }
    }
    return workgroupUniformLoad(&group_terms[0]);
}

fn node_groups() -> u32 {
    return state.grid_blocks;
}

// Stores the workgroup's sum of `term` as its partial.
fn store_partial(group: vec3<u32>, groups: vec3<u32>, local: u32, term: f32) {
    let sum = workgroup_sum(term, local);
    let index = group.y * groups.x + group.x;
    if local == 0u && index < node_groups() {
        solve.partials[index] = sum;
    }
}

// The sum of the last node kernel's partials: each invocation adds a
// strided share in order, then the tree; run by one workgroup.
fn sum_partials(local: u32) -> f32 {
    var sum = 0.0;
    for (var i = local; i < node_groups(); i += 64u) {
        sum += solve.partials[i];
    }
    return workgroup_sum(sum, local);
}

// |r| / max(|M v*|, |r_0|) from r . z.
fn relative_residual(rz: f32) -> f32 {
    if solve.reference > 0.0 {
        return sqrt(rz / solve.reference);
    }
    return 0.0;
}

// ---- per node ----

// Reads m_i and v*, applies the collisions while recording which components
// they fix, zeroes the other vectors and the force word planes (PIC/FLIP's
// scatter left its force impulse there); returns m_i |v*|^2.
fn load_node(node: u32) -> f32 {
    if node >= node_count() {
        return 0.0;
    }
    take_product(node);
    for (var vector = VECTOR_R; vector <= VECTOR_PRODUCT; vector++) {
        set_node_vector(vector, node, vec3<f32>(0.0));
    }
    let mass = solve_node_mass(node);
    if mass <= 0.0 {
        set_node_vector(VECTOR_X, node, vec3<f32>(0.0));
        set_node_word(VECTOR_CONSTRAINT, node, vec4<f32>(0.0, 0.0, 0.0, CONSTRAINT_FIXED));
        return 0.0;
    }
    atomicAdd(&solve.active_nodes, 1u);
    let collided = collide_all_constrained(node_position(node), node_velocity_new(node));
    set_node_vector(VECTOR_X, node, collided.velocity);
    set_node_word(VECTOR_CONSTRAINT, node, collided.constraint);
    return mass * dot(collided.velocity, collided.velocity);
}

// From the product beta dt^2 H x at x = v*: r = -P product, z = M^-1 r;
// returns r . z.
fn initial_residual_node(node: u32) -> f32 {
    if node >= node_count() {
        return 0.0;
    }
    let r = -project(node_constraint(node), take_product(node));
    let z = r * inverse_node_mass(node);
    set_node_vector(VECTOR_R, node, r);
    set_node_vector(VECTOR_Z, node, z);
    return dot(r, z);
}

// Completes the product beta dt^2 H z into S z = P (M z + beta dt^2 H z);
// returns z . S z.
fn finish_product_node(node: u32) -> f32 {
    if node >= node_count() {
        return 0.0;
    }
    let z = node_vector(VECTOR_Z, node);
    let product = project(node_constraint(node), z * solve_node_mass(node) + take_product(node));
    set_node_vector(VECTOR_PRODUCT, node, product);
    return dot(z, product);
}

// p = z + gamma p, S p = S z + gamma S p; returns S p . M^-1 S p.
fn next_direction_node(node: u32) -> f32 {
    if node >= node_count() {
        return 0.0;
    }
    let gamma = solve.gamma;
    let p = node_vector(VECTOR_Z, node) + node_vector(VECTOR_P, node) * gamma;
    let sp = node_vector(VECTOR_PRODUCT, node) + node_vector(VECTOR_SP, node) * gamma;
    set_node_vector(VECTOR_P, node, p);
    set_node_vector(VECTOR_SP, node, sp);
    return dot(sp, sp) * inverse_node_mass(node);
}

// x += alpha p, r -= alpha S p, z = M^-1 r; returns r . z.
fn advance_node(node: u32) -> f32 {
    if node >= node_count() {
        return 0.0;
    }
    let alpha = solve.alpha;
    let x = node_vector(VECTOR_X, node) + node_vector(VECTOR_P, node) * alpha;
    let r = node_vector(VECTOR_R, node) - node_vector(VECTOR_SP, node) * alpha;
    let z = r * inverse_node_mass(node);
    set_node_vector(VECTOR_X, node, x);
    set_node_vector(VECTOR_R, node, r);
    set_node_vector(VECTOR_Z, node, z);
    return dot(r, z);
}

@compute @workgroup_size(64)
fn solve_load(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
              @builtin(local_invocation_index) local: u32) {
    if !workgroup_flag(state.running != 0u, local) {
        return;
    }
    store_partial(group, groups, local, load_node(linear_index(group, groups, local)));
}

@compute @workgroup_size(64)
fn solve_initial_residual(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                          @builtin(local_invocation_index) local: u32) {
    if !workgroup_flag(solve_running(), local) {
        return;
    }
    store_partial(group, groups, local, initial_residual_node(linear_index(group, groups, local)));
}

@compute @workgroup_size(64)
fn solve_finish_product(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                        @builtin(local_invocation_index) local: u32) {
    if !workgroup_flag(solve_running(), local) {
        return;
    }
    store_partial(group, groups, local, finish_product_node(linear_index(group, groups, local)));
}

@compute @workgroup_size(64)
fn solve_next_direction(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                        @builtin(local_invocation_index) local: u32) {
    if !workgroup_flag(solve_running(), local) {
        return;
    }
    store_partial(group, groups, local, next_direction_node(linear_index(group, groups, local)));
}

@compute @workgroup_size(64)
fn solve_advance(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                 @builtin(local_invocation_index) local: u32) {
    if !workgroup_flag(solve_running(), local) {
        return;
    }
    store_partial(group, groups, local, advance_node(linear_index(group, groups, local)));
}

// The final velocities: the iterate through the colliders once more, so
// that no node moves into one, into the word planes of v^{n+1} for the
// gather.
@compute @workgroup_size(64)
fn solve_store(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
               @builtin(local_invocation_index) local: u32) {
    let node = linear_index(group, groups, local);
    if node >= node_count() || state.running == 0u || solve_node_mass(node) <= 0.0 {
        return;
    }
    let velocity_new = collide_all(node_position(node), node_vector(VECTOR_X, node));
    atomicStore(&px_hi[node], bitcast<u32>(velocity_new.x));
    atomicStore(&py_hi[node], bitcast<u32>(velocity_new.y));
    atomicStore(&pz_hi[node], bitcast<u32>(velocity_new.z));
}

// ---- the recurrence's scalars, one workgroup each ----

// After solve_load: |M v*|^2; the solve begins.
@compute @workgroup_size(64)
fn solve_begin(@builtin(local_invocation_index) local: u32) {
    if !workgroup_flag(state.running != 0u, local) {
        return;
    }
    let momentum = sum_partials(local);
    if local == 0u {
        solve.momentum = momentum;
        solve.iterations = 0u;
        solve.converged = 0u;
        solve.solved = 1u;
        solve.running = 1u;
    }
}

// After solve_initial_residual: the stopping target
// tolerance^2 max(|M v*|^2, |r_0|^2), and whether v* already meets it.
@compute @workgroup_size(64)
fn solve_start(@builtin(local_invocation_index) local: u32) {
    if !workgroup_flag(solve_running(), local) {
        return;
    }
    let rz = sum_partials(local);
    if local == 0u {
        solve.rz = rz;
        solve.reference = max(rz, solve.momentum);
        solve.stop_at = params.implicit.y * params.implicit.y * solve.reference;
        solve.residual = relative_residual(rz);
        finish_if_converged(rz);
    }
}

fn finish_if_converged(rz: f32) {
    let converged = rz <= solve.stop_at;
    solve.converged = select(0u, 1u, converged);
    solve.running = select(1u, 0u, converged);
}

// After solve_finish_product: z . S z, and gamma for the next direction
// (0 for the first).
@compute @workgroup_size(64)
fn solve_curvature(@builtin(local_invocation_index) local: u32) {
    if !workgroup_flag(solve_running(), local) {
        return;
    }
    let z_sz = sum_partials(local);
    if local == 0u {
        solve.gamma = select(z_sz / solve.z_sz, 0.0, solve.iterations == 0u);
        solve.z_sz = z_sz;
    }
}

// After solve_next_direction: alpha = z . S z / (S p . M^-1 S p), or the
// end of the solve at the iteration limit or a breakdown (z . S z = 0 is
// possible, as S may be indefinite).
@compute @workgroup_size(64)
fn solve_step_length(@builtin(local_invocation_index) local: u32) {
    if !workgroup_flag(solve_running(), local) {
        return;
    }
    let denominator = sum_partials(local);
    if local == 0u {
        solve.denominator = denominator;
        let z_sz = solve.z_sz;
        let healthy = finite(z_sz) && z_sz != 0.0 && denominator > 0.0 && finite(denominator);
        if solve.iterations >= u32(params.implicit.z) || !healthy {
            solve.running = 0u;
        } else {
            solve.alpha = z_sz / denominator;
        }
    }
}

// After solve_advance: r . z, one more iteration, and the stopping test.
@compute @workgroup_size(64)
fn solve_residual(@builtin(local_invocation_index) local: u32) {
    if !workgroup_flag(solve_running(), local) {
        return;
    }
    let rz = sum_partials(local);
    if local == 0u {
        solve.rz = rz;
        solve.iterations += 1u;
        solve.residual = relative_residual(rz);
        finish_if_converged(rz);
    }
}
