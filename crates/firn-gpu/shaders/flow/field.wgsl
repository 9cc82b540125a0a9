// The velocity v = s · curl ψ' of seed 002 (eq. 1-4, after Bridson et al.
// 2007), as firn_flow::field computes it:
//
//   ψ(x, t) = γ M (n(q₁), n(q₂), n(q₃)) + ½ (1 − γ) M_f (p × (x − o))   (eq. 1)
//   q_c = x / L + offsets_c(t)
//
// near a sphere ψ' = α ψ + (1 − α) n̂ (n̂ · ψ) with α = ramp(d / d0)
// (eq. 2-3), and the curl is exact (product rule through the modulation) or
// central differences of ψ' (eq. 4).

// Each program that includes this file gives noise_point(x, stage, c), the
// noise coordinate q_c of component c at a stage of its step
// (flow/noise_point.wgsl for the flow, snow/wind.wgsl for the wind on snow),
// and binds field_constants and obstacles.

// ramp(r) = 6r⁵ − 15r⁴ + 10r³ on [0, 1] and its derivative 30 r² (1 − r)²
// (seed eq. 2).
fn ramp(ratio: f32) -> vec2<f32> {
    let r = min(max(ratio, 0.0), 1.0);
    let r2 = r * r;
    let value = r2 * r * (10.0 + r * (6.0 * r - 15.0));
    let one_minus = 1.0 - r;
    return vec2<f32>(value, 30.0 * r2 * one_minus * one_minus);
}

// d / d0 of obstacle k at x.
fn influence_ratio(k: u32, x: vec3<f32>) -> f32 {
    let rel = x - obstacles[k].sphere.xyz;
    return (sqrt(dot(rel, rel)) - obstacles[k].sphere.w) * obstacles[k].inv_influence;
}

// The obstacle with the least d / d0 (the first on ties); call only when
// there is one.
fn most_influential(x: vec3<f32>) -> u32 {
    var best = 0u;
    var best_ratio = influence_ratio(0u, x);
    for (var k = 1u; k < field_constants.obstacle_count; k++) {
        let ratio = influence_ratio(k, x);
        if ratio < best_ratio {
            best = k;
            best_ratio = ratio;
        }
    }
    return best;
}

// Around an obstacle: r = |x − c| (kept off zero), n̂, α and α' = ramp' / d0.
struct SphereFrame {
    r: f32,
    normal: vec3<f32>,
    alpha: f32,
    alpha_slope: f32,
}

fn sphere_frame(k: u32, x: vec3<f32>) -> SphereFrame {
    let sphere = obstacles[k].sphere;
    let rel = x - sphere.xyz;
    let r = max(sqrt(dot(rel, rel)), sphere.w * 1e-6);
    let normal = (1.0 / r) * rel;
    let ramped = ramp((r - sphere.w) * obstacles[k].inv_influence);
    return SphereFrame(r, normal, ramped.x, ramped.y * obstacles[k].inv_influence);
}

// ψ' = α ψ + (1 − α) n̂ (n̂ · ψ) (seed eq. 3).
fn modulate_potential(k: u32, x: vec3<f32>, psi: vec3<f32>) -> vec3<f32> {
    let frame = sphere_frame(k, x);
    return frame.alpha * psi + ((1.0 - frame.alpha) * dot(frame.normal, psi)) * frame.normal;
}

// curl ψ' = α curl ψ + (α' − (1 − α)/r)(n̂ × ψ) + (1 − α)(Jᵀn̂) × n̂, with
// `jacobian[c]` = ∇ψ_c of the turbulence; the background about the sphere's
// centre adds ½ M (n̂ × p) to Jᵀ n̂.
fn modulate_curl(k: u32, x: vec3<f32>, psi: vec3<f32>, jacobian: array<vec3<f32>, 3>, curl: vec3<f32>) -> vec3<f32> {
    let frame = sphere_frame(k, x);
    let n = frame.normal;
    let beta = 1.0 - frame.alpha;
    let jacobian_t_n = (jacobian[0] * n.x + jacobian[1] * n.y + jacobian[2] * n.z)
        + field_constants.half_background * cross(n, field_constants.direction.xyz);
    let tangential = cross(jacobian_t_n, n);
    return (frame.alpha * curl + (frame.alpha_slope - beta / frame.r) * cross(n, psi)) + beta * tangential;
}

// The exact curl: three noise samples with gradients give ψ and its Jacobian.
fn velocity_analytic(x: vec3<f32>, stage: u32) -> vec3<f32> {
    let n0 = simplex3(noise_point(x, stage, 0u));
    let n1 = simplex3(noise_point(x, stage, 1u));
    let n2 = simplex3(noise_point(x, stage, 2u));
    let psi = field_constants.turbulence * vec3<f32>(n0.value, n1.value, n2.value);
    let scale = field_constants.turbulence_gradient;
    let jacobian = array<vec3<f32>, 3>(scale * n0.gradient, scale * n1.gradient, scale * n2.gradient);
    let turbulence_curl = vec3<f32>(
        jacobian[2].y - jacobian[1].z,
        jacobian[0].z - jacobian[2].x,
        jacobian[1].x - jacobian[0].y,
    );
    let direction = field_constants.direction.xyz;
    var v = turbulence_curl + field_constants.background * direction;
    if field_constants.obstacle_count > 0u {
        let k = most_influential(x);
        // Beyond d0 α = 1 and the modulation leaves v unchanged.
        if influence_ratio(k, x) < 1.0 {
            let rel = x - obstacles[k].sphere.xyz;
            let about_center = psi + field_constants.half_background * cross(direction, rel);
            v = modulate_curl(k, x, about_center, jacobian, v);
        }
    }
    return field_constants.speed * v;
}

// ψ'(x) modulated by obstacle k, or unmodulated about the world origin
// when `k` is NO_OBSTACLE.
const NO_OBSTACLE: u32 = 0xFFFFFFFFu;

fn potential(x: vec3<f32>, stage: u32, k: u32) -> vec3<f32> {
    let turbulence = field_constants.turbulence * vec3<f32>(
        simplex3(noise_point(x, stage, 0u)).value,
        simplex3(noise_point(x, stage, 1u)).value,
        simplex3(noise_point(x, stage, 2u)).value,
    );
    let direction = field_constants.direction.xyz;
    if k == NO_OBSTACLE {
        return turbulence + field_constants.half_background * cross(direction, x);
    }
    let rel = x - obstacles[k].sphere.xyz;
    let psi = turbulence + field_constants.half_background * cross(direction, rel);
    return modulate_potential(k, x, psi);
}

// Central differences of ψ' (seed eq. 4), with the obstacle chosen once at x.
fn velocity_finite_difference(x: vec3<f32>, stage: u32) -> vec3<f32> {
    var k = NO_OBSTACLE;
    if field_constants.obstacle_count > 0u {
        k = most_influential(x);
    }
    var columns = array<vec3<f32>, 3>();
    for (var j = 0u; j < 3u; j++) {
        var ahead = x;
        var behind = x;
        ahead[j] = x[j] + field_constants.difference_step;
        behind[j] = x[j] - field_constants.difference_step;
        columns[j] = field_constants.inv_two_steps * (potential(ahead, stage, k) - potential(behind, stage, k));
    }
    let curl = vec3<f32>(
        columns[1].z - columns[2].y,
        columns[2].x - columns[0].z,
        columns[0].y - columns[1].x,
    );
    return field_constants.speed * curl;
}

// The field velocity at x at a stage of the substep.
fn field_velocity(x: vec3<f32>, stage: u32) -> vec3<f32> {
    if field_constants.finite_difference != 0u {
        return velocity_finite_difference(x, stage);
    }
    return velocity_analytic(x, stage);
}

// The field's velocity over a step of dt from x, stage by stage: the midpoint
// rule (RK2) or classic RK4 (firn_flow::integrate on the CPU). Flow particles
// (flow/step.wgsl) and spindrift (snow/spindrift.wgsl) are carried by it.
fn integrated_velocity(x: vec3<f32>, dt: f32, half_dt: f32) -> vec3<f32> {
    let k1 = field_velocity(x, STAGE_START);
    let k2 = field_velocity(x + half_dt * k1, STAGE_MIDDLE);
    if field_constants.integrator == 0u {
        return k2;
    }
    let k3 = field_velocity(x + half_dt * k2, STAGE_MIDDLE);
    let k4 = field_velocity(x + dt * k3, STAGE_END);
    return (1.0 / 6.0) * ((k1 + k4) + 2.0 * (k2 + k3));
}
