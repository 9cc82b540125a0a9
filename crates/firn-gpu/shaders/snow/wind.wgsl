// Wind on snow ([wind]; firn_mpm::wind, equations W1 to W3 of
// firn_core::scene::wind): the curl-noise air field of flow/field.wgsl
// dragging on each node's snow in the grid update,
//
//   k_i = c_d h² φ_i (1 − φ_up) / m_i,  φ = min(1, m / (ρ_packed h³))
//   v_i ← v_w + (v_i − v_w) exp(−k_i Δt)
//
// with φ_up the share of a packed cell of the nodes one cell upwind against
// each axis component of the relative wind, weighted by |u_a| / |u|₁.

// What the grid update needs of the wind, beside the field's constants.
struct WindParams {
    // ε_c / L of the three noise components, in noise cells.
    offsets: array<vec4<f32>, 3>,
    // w_c, noise cells per second.
    drift: array<vec4<f32>, 3>,
    // c_d h²: the drag of a node exposed over a whole cell face, kg/s.
    node_drag: f32,
    // ρ_packed h³: the mass of a packed cell.
    packed_mass: f32,
    pad0: u32,
    pad1: u32,
}

// The snow's noise coordinate of component c at a stage of the substep: its
// start, middle or end (the grid update's time, as for the colliders).
fn noise_point(x: vec3<f32>, stage: u32, c: u32) -> vec3<f32> {
    let time = simulated_time() - state.dt * (1.0 - 0.5 * f32(stage));
    return x * field_constants.inv_length + wind.offsets[c].xyz + time * wind.drift[c].xyz;
}

// The mass of the node at `cell`, 0 outside the grid or its allocated blocks.
fn node_mass_at(cell: vec3<i32>) -> f32 {
    if !inside_grid(cell) {
        return 0.0;
    }
    let node = node_index(cell);
    if node == NO_NODE {
        return 0.0;
    }
    return from_fixed(atomicLoad(&mass_hi[node]), atomicLoad(&mass_lo[node])) / params.scales.x;
}

// The exposure 1 - phi_up of the node at `cell` to air moving along
// `relative` (W2, firn_mpm::wind::AirDrag::exposure), the shares measured
// against `full_mass`; 0 without a direction. The drag and spindrift's
// shelter test both use it.
fn exposure_against(cell: vec3<i32>, relative: vec3<f32>, full_mass: f32) -> f32 {
    let weights = abs(relative);
    let total = weights.x + weights.y + weights.z;
    if total <= 0.0 {
        return 0.0;
    }
    var upwind = 0.0;
    for (var axis = 0; axis < 3; axis++) {
        if weights[axis] > 0.0 {
            var offset = vec3<i32>(0);
            offset[axis] = select(1, -1, relative[axis] > 0.0);
            upwind += weights[axis] * min(node_mass_at(cell + offset) / full_mass, 1.0);
        }
    }
    return max(1.0 - upwind / total, 0.0);
}

// k_i of the node at `cell` with mass `mass` moving at `velocity` in air
// moving at `air`.
fn drag_rate(cell: vec3<i32>, mass: f32, velocity: vec3<f32>, air: vec3<f32>) -> f32 {
    if wind.node_drag == 0.0 {
        return 0.0;
    }
    let exposure = exposure_against(cell, air - velocity, wind.packed_mass);
    return wind.node_drag * exposure / max(mass, wind.packed_mass);
}

// v_i after Δt of drag: v_w + (v − v_w) exp(−k Δt) (W3).
fn blown(cell: vec3<i32>, mass: f32, velocity: vec3<f32>, position: vec3<f32>) -> vec3<f32> {
    let air = field_velocity(position, STAGE_END);
    let rate = drag_rate(cell, mass, velocity, air);
    if rate == 0.0 {
        return velocity;
    }
    return air + (velocity - air) * exp(-rate * state.dt);
}
