// Entry points that run single library functions over arrays, so tests can
// compare them with the CPU functions they mirror (svd3, the B-spline
// weights, the snow model's elastic update, the colliders). The arrays are
// bound by ParityBindings in src/snow/bindings.rs.

// Vectors written per point by weights_parity: both bases, then the
// quadratic values and slopes, then the cubic values and slopes.
const WEIGHT_VECTORS: u32 = 16u;

// Vectors written per point by collider_parity.
const COLLIDER_VECTORS: u32 = 6u;

// Collider vectors_in[2n + 1].w, placed at time vectors_in[2n].w, at point
// vectors_in[2n].xyz on a velocity vectors_in[2n + 1].xyz: the velocity
// after its contact; the placed position and the signed distance at the
// point (w); the rotation; the velocity; the angular velocity and whether
// it is turned (w: 1); the outward normal at the point.
@compute @workgroup_size(64)
fn collider_parity(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = id.x;
    if n >= arrayLength(&vectors_in) / 2u {
        return;
    }
    let at = vectors_in[2u * n];
    let moving = vectors_in[2u * n + 1u];
    let collider = colliders[u32(moving.w)];
    let placed = placement(collider, at.w);
    let surface = placed_surface(collider, placed, at.xyz);
    let first = n * COLLIDER_VECTORS;
    vectors_out[first] = vec4<f32>(collide(collider, placed, at.xyz, moving.xyz), 0.0);
    vectors_out[first + 1u] = vec4<f32>(placed.position, surface.distance);
    vectors_out[first + 2u] = placed.rotation;
    vectors_out[first + 3u] = vec4<f32>(placed.velocity, 0.0);
    vectors_out[first + 4u] = vec4<f32>(placed.angular_velocity, select(0.0, 1.0, placed.turned));
    vectors_out[first + 5u] = vec4<f32>(surface.normal, 0.0);
}

// U and V to matrices_out[2n], [2n + 1]; sigma to vectors_out[n].
@compute @workgroup_size(64)
fn svd_parity(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = id.x;
    if n >= arrayLength(&matrices_in) {
        return;
    }
    let svd = svd3(matrices_in[n]);
    matrices_out[2u * n] = svd.u;
    matrices_out[2u * n + 1u] = svd.v;
    vectors_out[n] = vec4<f32>(svd.sigma, 0.0);
}

// The weights of a particle at grid coordinate vectors_in[n].xyz.
@compute @workgroup_size(64)
fn weights_parity(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = id.x;
    if n >= arrayLength(&vectors_in) {
        return;
    }
    let x = vectors_in[n].xyz;
    let quadratic = quadratic_weights(x);
    let cubic = cubic_weights(x);
    let first = n * WEIGHT_VECTORS;
    vectors_out[first] = vec4<f32>(vec3<f32>(quadratic.base), 0.0);
    vectors_out[first + 1u] = vec4<f32>(vec3<f32>(cubic.base), 0.0);
    for (var k = 0u; k < 3u; k++) {
        vectors_out[first + 2u + k] = vec4<f32>(quadratic.values[k], 0.0);
        vectors_out[first + 5u + k] = vec4<f32>(quadratic.slopes[k], 0.0);
    }
    for (var k = 0u; k < 4u; k++) {
        vectors_out[first + 8u + k] = vec4<f32>(cubic.values[k], 0.0);
        vectors_out[first + 12u + k] = vec4<f32>(cubic.slopes[k], 0.0);
    }
}

// The elastic update of trial F_E matrices_in[n] with (J_P, V_p^0) in
// vectors_in[n].xy: F_E and V_p^0 tau_p to matrices_out[2n], [2n + 1];
// (J_P, hardening factor) to vectors_out[n].
@compute @workgroup_size(64)
fn stress_parity(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = id.x;
    if n >= arrayLength(&matrices_in) {
        return;
    }
    let state = elastic_update(matrices_in[n], vectors_in[n].x, vectors_in[n].y, parity_material[0]);
    matrices_out[2u * n] = state.elastic;
    matrices_out[2u * n + 1u] = state.stress;
    vectors_out[n] = vec4<f32>(state.plastic_j, state.hardening_factor, 0.0, 0.0);
}

// The semi-implicit solve's stress differential at F_E = matrices_in[2n] in
// the direction matrices_in[2n + 1], with (mu, lambda, V_p^0) in
// vectors_in[n].xyz: V_p^0 dP to matrices_out[n].
@compute @workgroup_size(64)
fn stress_differential_parity(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = id.x;
    if n >= arrayLength(&vectors_in) {
        return;
    }
    let p = vectors_in[n];
    let linearized = stress_differential(matrices_in[2u * n], p.x, p.y, p.z);
    matrices_out[n] = apply_stress_differential(linearized, matrices_in[2u * n + 1u]);
}
